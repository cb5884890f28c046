//! Bytes → the LOD cache decoder (`vergence::fuzz_checks::lod_cache`). Any
//! Err is fine (the cache is rebuilt); a panic, abort or hang is a bug, and
//! accepted chains must index within their primitives.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::lod_cache(data));
