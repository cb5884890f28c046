//! Bytes → every command-line value parser, the `--opt` list parser and
//! the built-in scene specs (`vergence::fuzz_checks::cli_values`). Any Err
//! is fine; a panic, abort or hang is a bug, and an accepted value must lie
//! within its documented bound.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| vergence::fuzz_checks::cli_values(data));
