//! Text → rig JSON (`render --rig`) and bench plan (parse, validate and
//! the up-front input checks). Any Err is fine; a panic, abort or hang is
//! a bug, and an accepted rig must have finite tangents.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(rig) = vergence::view::RigFile::parse("fuzz", text) {
        for v in &rig.views {
            assert!(v.fov.tangents().iter().all(|t| t.is_finite()));
        }
        if let Some(areas) = &rig.hidden_area {
            assert_eq!(areas.len(), rig.views.len());
        }
    }
    if let Ok(plan) = vergence::bench::plan::Plan::parse("fuzz", text) {
        // Only built-in names: a fuzzed path must not make the target read
        // files.
        if plan.scenes.iter().all(|s| s.starts_with("factory"))
            && plan.hmds.iter().all(|h| !h.contains('/') && !h.ends_with(".toml"))
        {
            let _ = plan.check_inputs();
        }
    }
});
