//! Text → rig JSON (`render --rig`) and bench plan (parse, validate, the
//! configurations and the up-front input checks;
//! `vergence::fuzz_checks::rig_plan`). Any Err is fine; a panic, abort or
//! hang is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::rig_plan(data));
