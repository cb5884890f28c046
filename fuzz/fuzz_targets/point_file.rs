//! Bytes → the PLY and LAS/LAZ point-cloud readers
//! (`vergence::fuzz_checks::point_file`). Any Err is fine; a panic, abort
//! or hang is a bug, and an accepted cloud must be finite and whole.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::point_file(data));
