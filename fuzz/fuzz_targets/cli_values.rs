//! Bytes → every command-line value parser (`vergence::cli`) and the
//! `--opt` list parser. Any Err is fine; a panic, abort or hang is a bug,
//! and an accepted value must lie within its documented bound.
#![no_main]

use libfuzzer_sys::fuzz_target;
use vergence::cli;

fuzz_target!(|data: &[u8]| {
    let Ok(s) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(v) = cli::parse_seconds(s) {
        assert!(v > 0.0 && v <= cli::MAX_RUN_SECONDS);
        let _ = std::time::Duration::from_secs_f64(v);
    }
    if let Ok(a) = cli::parse_lens_half_angle(s) {
        assert!(a > 0.0 && a < std::f64::consts::FRAC_PI_2);
    }
    if let Ok(v) = cli::parse_near(s) {
        assert!(v.is_finite() && v > 0.0);
    }
    if let Ok(v) = cli::parse_distance(s) {
        assert!(v.is_finite() && v > 0.0);
    }
    let _ = cli::parse_positive(s);
    let _ = cli::parse_non_negative(s);
    let _ = cli::parse_ppd(s);
    if let Ok(p) = cli::parse_pose(s) {
        assert!(p.validate().is_ok());
    }
    let mut c = vergence::config::RenderConfig::default();
    if c.apply_opts(s, &vergence::bench::plan::cull_names()).is_ok() {
        if let Some(m) = c.mffr.and_then(|m| m.split) {
            assert!(m >= vergence::config::MIN_MFFR_SPLIT_M);
        }
    }
});
