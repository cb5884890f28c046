//! The invariants the fuzz targets assert, shared by the cargo-fuzz
//! targets (`fuzz/fuzz_targets/`) and the stable mutation tests
//! (`tests/fuzz_mutate.rs`): each takes arbitrary bytes, runs a parser on
//! them and panics only when an accepted value breaks its documented bound.
//! Any `Err` is fine.

use crate::cli;

/// Bytes → every command-line value parser (`crate::cli`), the `--opt`
/// list parser and the built-in scene specs (`cad:N`).
pub fn cli_values(data: &[u8]) {
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
    let mut c = crate::config::RenderConfig::default();
    if c.apply_opts(s, &crate::config::cull_names()).is_ok() {
        if let Some(m) = c.effort.mffr.and_then(|m| m.split) {
            assert!(m >= crate::config::MIN_MFFR_SPLIT_M);
        }
    }
    // A cad spec the parser accepts is one the bench's up-front check
    // accepts too (two entry points, one rule).
    if let Some(Ok(_)) = crate::scene::cad::spec_count(s) {
        assert!(crate::scene::Scene::check_spec(s).is_ok(), "{s:?}");
    }
}

/// Text → rig JSON (`render --rig`) and bench plan (parse, validate, each
/// configuration's renderer settings, and the up-front input checks when
/// the plan names only built-in scenes and profiles, so a fuzzed path never
/// makes it read files). An accepted rig must have finite tangents and one
/// hidden area per view; an accepted configuration must validate.
pub fn rig_plan(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(rig) = crate::view::RigFile::parse("fuzz", text) {
        for v in &rig.views {
            assert!(v.fov.tangents().iter().all(|t| t.is_finite()));
        }
        if let Some(areas) = &rig.hidden_area {
            assert_eq!(areas.len(), rig.views.len());
        }
    }
    if let Ok(plan) = crate::bench::plan::Plan::parse("fuzz", text) {
        // A configuration's own keys reach its renderer settings.
        for c in &plan.configs {
            if let Ok(config) = plan.config_for(c) {
                assert_eq!(
                    config.submission.record_threads, c.record_threads,
                    "{}",
                    c.name
                );
                assert_eq!(
                    config.submission.per_draw,
                    c.per_draw.unwrap_or_default(),
                    "{}",
                    c.name
                );
            }
        }
        let built_in =
            |s: &String| s == "factory" || s.starts_with("factory:") || s.starts_with("cad:");
        if plan.scenes.iter().all(built_in)
            && plan
                .hmds
                .iter()
                .all(|h| !h.contains('/') && !h.ends_with(".toml"))
        {
            let _ = plan.check_inputs();
        }
    }
}

/// Bytes → the LOD cache decoder, against a small scene whose cache the
/// seeds are (`scene::lod_cache`): an accepted file must give chains whose
/// indices lie within their primitives, whole triangles, and finite,
/// non-decreasing errors.
pub fn lod_cache(data: &[u8]) {
    let scene = lod_cache_scene();
    let hash = crate::scene::lod_cache::content_hash(&scene);
    if let Ok(c) = crate::scene::lod_cache::decode(data, hash, &scene) {
        assert_eq!(c.levels.len(), scene.primitives.len());
        for (p, levels) in scene.primitives.iter().zip(&c.levels) {
            let mut last = 0.0f32;
            for l in levels {
                assert!(l.indices.len().is_multiple_of(3));
                assert!(l.indices.iter().all(|&i| (i as usize) < p.positions.len()));
                assert!(l.error.is_finite() && l.error >= last);
                last = l.error;
            }
        }
    }
}

/// Bytes → the point-cloud octree cache decoder, against a small cloud
/// whose cache the seeds are: an accepted file must give an octree and
/// order [`check_octree`] accepts.
pub fn octree_cache(data: &[u8]) {
    // The cloud and its hash once per process: building and hashing them
    // for every input took most of each run.
    static CLOUD: std::sync::OnceLock<(usize, u64)> = std::sync::OnceLock::new();
    let &(points, hash) = CLOUD.get_or_init(|| {
        let positions = octree_cache_cloud();
        let hash = crate::scene::octree_cache::content_hash(glam::DVec3::ZERO, &positions);
        (positions.len(), hash)
    });
    if let Ok((tree, order)) = crate::scene::octree_cache::decode(data, hash, points) {
        check_octree(&tree, &order, points);
    }
}

/// The cloud [`octree_cache`] decodes against (a lattice of 27,000 points).
pub fn octree_cache_cloud() -> Vec<[f32; 3]> {
    (0..27_000u32)
        .map(|i| {
            [
                (i % 30) as f32,
                (i / 30 % 30) as f32 * 0.5,
                (i / 900) as f32,
            ]
        })
        .collect()
}

/// What the renderer relies on in a decoded octree over `points` points:
/// the order is a permutation, every node's range lies in the cloud and
/// its children are later nodes.
pub fn check_octree(tree: &crate::scene::octree::Octree, order: &[u32], points: usize) {
    assert_eq!(order.len(), points);
    let mut seen = vec![false; points];
    for &i in order {
        assert!(!std::mem::replace(&mut seen[i as usize], true));
    }
    for (k, n) in tree.nodes.iter().enumerate() {
        assert!(n.first as usize + n.count as usize <= points);
        for &c in &n.children {
            assert!(
                c == crate::scene::octree::NONE
                    || (c as usize > k && (c as usize) < tree.nodes.len())
            );
        }
    }
}

/// The scene [`lod_cache`] decodes against (two simple shapes).
pub fn lod_cache_scene() -> crate::scene::Scene {
    use crate::scene::{shapes, Mesh, Scene};
    Scene {
        name: "fuzz".into(),
        primitives: vec![
            shapes::cylinder(1.0, 2.0, 48, 0),
            shapes::cuboid([1.0, 1.0, 1.0], 0),
        ],
        meshes: vec![Mesh {
            name: "m".into(),
            primitives: vec![0, 1],
        }],
        ..Scene::default()
    }
}

/// Bytes → the PLY and the LAS/LAZ readers: any Err is fine; an accepted cloud has
/// finite offsets, one colour and class per point, and no more points than
/// the limit.
pub fn point_file(data: &[u8]) {
    let check = |c: crate::scene::points::PointCloud| {
        assert!(c.origin.is_finite());
        assert!(c.positions.iter().flatten().all(|v| v.is_finite()));
        assert_eq!(c.positions.len(), c.colors.len());
        assert_eq!(c.positions.len(), c.classification.len());
        assert!(c.len() as u64 <= crate::scene::points::MAX_POINTS);
    };
    if let Ok(c) = crate::scene::ply::read_ply_bytes(std::path::Path::new("fuzz.ply"), data) {
        check(c);
    }
    if let Ok(c) = crate::scene::e57::read_e57_bytes(std::path::Path::new("fuzz.e57"), data) {
        check(c);
    }
    let name = std::path::Path::new("fuzz.las");
    if let Ok(c) = crate::scene::points::read_las_bytes(name, data.to_vec()) {
        check(c);
    }
}

/// Bytes → a kiosk file's parser (`run --kiosk`): an accepted kiosk has
/// one to [`crate::targets::kiosk::MAX_SCENES`] scenes with unique names,
/// each at most [`crate::targets::kiosk::MAX_VIEWPOINTS`] viewpoints, and
/// a log that keeps at least one rotated file.
pub fn kiosk(data: &[u8]) {
    use crate::targets::kiosk::{Kiosk, MAX_SCENES, MAX_VIEWPOINTS};
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(k) = Kiosk::parse(text, std::path::Path::new(".")) else {
        return;
    };
    assert!((1..=MAX_SCENES).contains(&k.scenes.len()));
    for (i, s) in k.scenes.iter().enumerate() {
        assert!(s.viewpoints.len() <= MAX_VIEWPOINTS);
        assert!(k.scenes[..i].iter().all(|o| o.name != s.name));
        assert!(!s.name.chars().any(char::is_control));
    }
    if let Some(log) = &k.log {
        assert!(log.keep >= 1 && log.max_bytes > 0);
    }
}

/// Bytes → a viewpoints file's parser (`run --viewpoint FILE`, what F8 in
/// `view` appends): an accepted file has 1 to
/// [`crate::targets::keep_pose::MAX_VIEWPOINTS`] entries, each a valid
/// pose within the distance limit.
pub fn viewpoints(data: &[u8]) {
    use crate::targets::keep_pose::{parse_viewpoints, MAX_VIEWPOINTS};
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(v) = parse_viewpoints(text) else {
        return;
    };
    assert!((1..=MAX_VIEWPOINTS).contains(&v.len()));
    for (_, pose) in &v {
        assert!(pose.validate().is_ok());
        assert!(pose.position.abs().max_element() <= crate::cli::MAX_DISTANCE_M);
    }
}

/// Bytes → the rehearsal script parser (`run --rehearse FILE`): an
/// accepted script has 1 to [`crate::targets::rehearse::MAX_STEPS`] steps,
/// each held for a positive time, at most
/// [`crate::targets::rehearse::MAX_TOTAL_S`] in all, with finite poses,
/// unit quaternions and inputs within their ranges.
pub fn rehearse(data: &[u8]) {
    use crate::targets::rehearse::{Script, MAX_STEPS, MAX_TOTAL_S};
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(s) = Script::parse(text, std::path::Path::new("fuzz.toml")) else {
        return;
    };
    assert!((1..=MAX_STEPS).contains(&s.steps.len()));
    let total: f64 = s.steps.iter().map(|st| st.hold.as_secs_f64()).sum();
    assert!(total <= MAX_TOTAL_S + 1e-6);
    for st in &s.steps {
        assert!(!st.hold.is_zero());
        let poses = std::iter::once(&st.head).chain(st.hands.iter().map(|h| &h.pose));
        for p in poses {
            assert!(p.position.iter().all(|v| v.is_finite()));
            let n: f32 = p.orientation.iter().map(|v| v * v).sum();
            assert!((n - 1.0).abs() < 1e-3, "unit quaternion: {n}");
        }
        for h in &st.hands {
            assert!((0.0..=1.0).contains(&h.trigger) && (0.0..=1.0).contains(&h.squeeze));
            assert!(h.thumbstick.iter().all(|v| (-1.0..=1.0).contains(v)));
        }
    }
}
