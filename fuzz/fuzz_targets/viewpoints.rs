//! Bytes → the viewpoints file parser (`vergence::fuzz_checks::viewpoints`).
//! Any Err is fine; a panic, or accepted viewpoints outside their bounds,
//! is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::viewpoints(data));
