//! Bytes → the rehearsal script parser (`vergence::fuzz_checks::rehearse`).
//! Any Err is fine; a panic, or an accepted script outside its bounds, is a
//! bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::rehearse(data));
