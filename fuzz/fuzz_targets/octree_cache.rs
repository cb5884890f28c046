//! Bytes → the point-cloud octree cache decoder
//! (`vergence::fuzz_checks::octree_cache`). Any Err is fine (the octree is
//! built instead); a panic, abort or hang is a bug, and an accepted file
//! must give a permutation and nodes within the cloud.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::octree_cache(data));
