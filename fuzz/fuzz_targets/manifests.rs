//! TOML text → HMD profile (and a rig at the origin, whose views must be
//! finite, and its lenses' maps), scene manifest (its moving placements
//! finite at any time), bench plan and tuned config file. Any Err is
//! fine; a panic, abort or hang is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(p) = vergence::view::profile::HmdProfile::parse("fuzz", text) {
        let rig = p.rig(vergence::view::Pose::default());
        for v in &rig.views {
            assert!(v.fov.tangents().iter().all(|t| t.is_finite()));
        }
        // Lenses: the forward and inverse maps stay finite over the panel.
        for v in &p.views {
            let Some(lens) = &v.lens else { continue };
            for j in 0..=4 {
                for i in 0..=4 {
                    let uv = [i as f64 / 4.0, j as f64 / 4.0];
                    if let Some(t) = lens.tangent_of_panel(uv, 1) {
                        assert!(t.iter().all(|x| x.is_finite()));
                        let _ = lens.panel_of_tangent(t, 1);
                    }
                }
            }
        }
    }
    let dir = std::env::temp_dir().join("vergence-fuzz-manifest");
    let _ = std::fs::create_dir_all(&dir);
    // Scenes are capped so one input cannot ask for millions of instances.
    if !text.contains("instances") && !text.contains("count") {
        if let Ok(scene) = vergence::scene::manifest::from_text(&dir.join("fuzz.toml"), text) {
            // Moving placements stay finite at any time.
            let mut moved = Vec::new();
            for t in [0.0, 1.5, 3.6e6] {
                vergence::scene::motion::transforms_at(&scene.moving, t, &mut moved);
                assert!(moved.iter().all(|m| m.transform.is_finite()));
            }
        }
    }
    let _ = vergence::bench::plan::Plan::parse("fuzz", text);
    let _ = toml::from_str::<vergence::bench::tune::ConfigFile>(text);
});
