//! Which techniques render together: every pair of the fourteen stereo
//! techniques below (each with the superfrustum) either renders — three
//! frames of a factory on lavapipe, zero validation messages, an image
//! that is not empty — or is refused by the configuration with one
//! reason, and the refused pairs are exactly those `docs/composition.md`
//! lists. Pairs made possible by the frame plan have image checks of their
//! own (`occlusion.rs`, `aq.rs`).

mod common;

use common::{context, framing_pose, load};
use std::collections::BTreeSet;
use vergence::bench::plan::cull_names;
use vergence::config::RenderConfig;
use vergence::view::profile::HmdProfile;

/// The techniques, as `--opt` entries.
const TECHNIQUES: [&str; 14] = [
    "gpu-cull",
    "gpu-cull,occlusion",
    "gpu-cull,lod",
    "stencil-mask",
    "foveation=high",
    "rdm",
    "mffr",
    "inset",
    "inset,inset-taau",
    "lms",
    "aq",
    "resolved-sky",
    "no-msaa",
    "two-pass",
];

/// Every pair (first before second in [`TECHNIQUES`]).
fn pairs() -> Vec<(&'static str, &'static str)> {
    let mut v = Vec::new();
    for (i, a) in TECHNIQUES.iter().enumerate() {
        for b in &TECHNIQUES[i + 1..] {
            v.push((*a, *b));
        }
    }
    v
}

/// The configuration of a pair, or the refusal's message.
fn pair_config(a: &str, b: &str) -> Result<RenderConfig, String> {
    let mut c = RenderConfig::default();
    c.apply_opts(&format!("superfrustum,{a},{b}"), &cull_names())
        .map_err(|e| e.to_string())?;
    c.validate().map_err(|e| e.to_string())?;
    Ok(c)
}

/// The refused pairs `docs/composition.md` lists: its table rows
/// `` | `a` | `b` | reason | ``.
fn documented() -> BTreeSet<(String, String)> {
    let text = std::fs::read_to_string(common::root().join("docs/composition.md")).unwrap();
    text.lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            let code = |s: &str| s.strip_prefix('`')?.strip_suffix('`').map(str::to_string);
            match cells.as_slice() {
                ["", a, b, reason, ""] if !reason.is_empty() => Some((code(a)?, code(b)?)),
                _ => None,
            }
        })
        .collect()
}

#[test]
fn the_refused_pairs_are_the_documented_ones() {
    let all = pairs();
    assert_eq!(all.len(), 91);
    let refused: BTreeSet<(String, String)> = all
        .iter()
        .filter(|(a, b)| pair_config(a, b).is_err())
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    for (a, b) in &refused {
        let e = pair_config(a, b).unwrap_err();
        assert!(
            !e.contains('\n') && e.contains("--opt"),
            "{a} with {b}: not one line naming the option: {e}"
        );
    }
    let listed = documented();
    assert_eq!(
        refused,
        listed,
        "refused but not documented: {:?}; documented but rendering: {:?}",
        refused.difference(&listed).collect::<Vec<_>>(),
        listed.difference(&refused).collect::<Vec<_>>()
    );
    eprintln!("{} of 91 pairs render together", 91 - refused.len());
}

#[test]
fn every_accepted_pair_renders() {
    let ctx = context();
    let scene = load("factory:300");
    let profile = HmdProfile::load("valve-index").unwrap();
    let rig = profile.rig(framing_pose(&scene, &profile));
    let rigs = vec![rig.clone(), rig.clone(), rig];
    let mut rendered = 0;
    for (a, b) in pairs() {
        let Ok(config) = pair_config(a, b) else {
            continue;
        };
        let config = {
            let mut rc = config;
            rc.submission.frames_in_flight = 1;
            rc
        };
        let (results, images) = common::frame_by_frame(&ctx, &scene, &config, &rigs, 64);
        assert_eq!(results.len(), 3, "{a} with {b}");
        let last = &images[2];
        for eye in last {
            let first = *eye.get_pixel(0, 0);
            assert!(
                eye.pixels().any(|p| *p != first),
                "{a} with {b}: an eye image of one colour"
            );
        }
        assert!(results[2].stats.triangles > 0, "{a} with {b}");
        rendered += 1;
    }
    assert!(rendered > 0);
}
