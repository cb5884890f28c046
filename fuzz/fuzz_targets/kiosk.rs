//! Bytes → the kiosk file parser (`vergence::fuzz_checks::kiosk`). Any
//! Err is fine; a panic, or an accepted kiosk outside its bounds, is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::kiosk(data));
