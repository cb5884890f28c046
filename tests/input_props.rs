//! Property tests of the text parsers issue 18 bounded (the stable-toolchain
//! counterpart of the `cli_values` and `rig_plan` fuzz targets): random
//! and mutated inputs to the CLI value parsers, `--opt` lists, rig JSON and
//! bench plans never panic, and what they accept lies within the bounds.

use proptest::prelude::*;
use vergence::cli;

/// Numbers near and past every bound, in several spellings.
fn numberish() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:e}")),
        any::<u64>().prop_map(|v| v.to_string()),
        Just("NaN".to_string()),
        Just("-inf".to_string()),
        Just("1e20".to_string()),
        Just("1.5707963267948966".to_string()),
        "[-+0-9.eE]{0,12}",
        ".{0,16}",
    ]
}

const RIG: &str = r#"{"head": {"position": [0, 1.7, 0], "orientation": [0, 0, 0, 1]}, "views": [{"pose": {"position": [-0.03, 1.7, 0], "orientation": [0, 0, 0, 1]}, "fov": {"left": -0.8, "right": 0.8, "up": 0.8, "down": -0.8}, "hidden_area": [[0, 0], [0.1, 0], [0, 0.1]]}, {"pose": {"position": [0.03, 1.7, 0], "orientation": [0, 0, 0, 1]}, "fov": {"left": -0.8, "right": 0.8, "up": 0.8, "down": -0.8}, "hidden_area": [[0, 0], [0.1, 0], [0, 0.1]]}]}"#;

const PLAN: &str = "name = \"p\"\nscenes = [\"factory:10\"]\nhmds = [\"monado-sim\"]\nscales = [1.0]\nframes = 4\n[[configs]]\nname = \"a\"\nopt = \"two-pass\"\n";

/// `text` with the byte range `at..at+len` replaced by `with`.
fn splice(text: &str, at: usize, len: usize, with: &str) -> String {
    let b = text.as_bytes();
    let at = at % (b.len() + 1);
    let end = (at + len).min(b.len());
    let mut out = b[..at].to_vec();
    out.extend_from_slice(with.as_bytes());
    out.extend_from_slice(&b[end..]);
    String::from_utf8_lossy(&out).into_owned()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn cli_values_stay_within_their_bounds(s in numberish()) {
        if let Ok(v) = cli::parse_seconds(&s) {
            prop_assert!(v > 0.0 && v <= cli::MAX_RUN_SECONDS);
            let _ = std::time::Duration::from_secs_f64(v);
        }
        if let Ok(a) = cli::parse_lens_half_angle(&s) {
            prop_assert!(a > 0.0 && a < std::f64::consts::FRAC_PI_2);
        }
        if let Ok(v) = cli::parse_near(&s) {
            prop_assert!(v.is_finite() && v > 0.0 && v <= 1e3);
        }
        if let Ok(v) = cli::parse_ppd(&s) {
            prop_assert!(v.is_finite() && (0.0099..1000.0).contains(&v));
        }
        let _ = cli::parse_distance(&s);
        let _ = cli::parse_positive(&s);
        let _ = cli::parse_non_negative(&s);
        let pose = format!("{s},0,{s},0,{s},0");
        if let Ok(p) = cli::parse_pose(&pose) {
            prop_assert!(p.validate().is_ok());
        }
    }

    #[test]
    fn opt_lists_never_panic(items in prop::collection::vec(prop_oneof![
        Just("multiview".to_string()), Just("two-pass".to_string()), Just("msaa4".to_string()),
        Just("no-msaa".to_string()), Just("per-eye".to_string()), Just("superfrustum".to_string()),
        Just("foveation".to_string()), numberish().prop_map(|n| format!("mffr={n}")),
        numberish().prop_map(|n| format!("rdm={n}")), numberish().prop_map(|n| format!("foveation={n}")),
        numberish().prop_map(|n| format!("gaze={n}:{n}")),
    ], 0..6)) {
        let mut c = vergence::config::RenderConfig::default();
        if c.apply_opts(&items.join(","), &vergence::bench::plan::cull_names()).is_ok() {
            if let Some(d) = c.effort.mffr.and_then(|m| m.split) {
                prop_assert!((vergence::config::MIN_MFFR_SPLIT_M..=vergence::config::MAX_MFFR_SPLIT_M).contains(&d));
            }
        }
    }

    #[test]
    fn mutated_rig_files_never_panic(at in 0usize..700, len in 0usize..8, with in prop_oneof![numberish(), Just(", 5".to_string()), Just("\"x\": 1, ".to_string()), Just("]".to_string())]) {
        let text = splice(RIG, at, len, &with);
        if let Ok(rig) = vergence::view::RigFile::parse("prop", &text) {
            for v in &rig.views {
                prop_assert!(v.fov.tangents().iter().all(|t| t.is_finite()));
            }
        }
    }

    #[test]
    fn mutated_plans_never_panic(at in 0usize..160, len in 0usize..8, with in prop_oneof![numberish(), Just(", 1e-9".to_string()), Just("\\n".to_string()), Just("factory:0".to_string())]) {
        let text = splice(PLAN, at, len, &with);
        if let Ok(plan) = vergence::bench::plan::Plan::parse("prop", &text) {
            if plan.scenes.iter().all(|s| s.starts_with("factory")) && plan.hmds.iter().all(|h| h == "monado-sim") {
                let _ = plan.check_inputs();
            }
        }
    }
}
