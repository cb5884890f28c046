//! The gaze model against its definition.

use super::*;

#[test]
fn the_centre_path_stays_on_the_axis() {
    let g = GazePath::centre();
    for t in [-1.0, 0.0, 0.5, 100.0] {
        assert_eq!(g.at(t), [0.0, 0.0]);
    }
}

#[test]
fn a_seed_gives_one_path_and_another_seed_another() {
    assert_eq!(GazePath::saccades(3, 10.0), GazePath::saccades(3, 10.0));
    assert_ne!(GazePath::saccades(3, 10.0), GazePath::saccades(4, 10.0));
}

#[test]
fn fixations_and_saccades_follow_the_model() {
    for seed in 0..20 {
        let g = GazePath::saccades(seed, 30.0);
        let list = g.saccade_list();
        // About three saccades a second (a fixation of ~310 ms mean plus
        // the saccade itself).
        assert!(
            (60..=140).contains(&list.len()),
            "seed {seed}: {}",
            list.len()
        );
        let mean = list.iter().map(|s| s.1).sum::<f64>() / list.len() as f64;
        assert!(
            (2.5..=6.5).contains(&mean),
            "seed {seed}: mean amplitude {mean}"
        );
        for (start, amplitude) in list {
            assert!(amplitude <= AMPLITUDE_MAX_DEG + 1e-9);
            // Still before the saccade, moving during it, landed after it
            // (the main sequence's duration).
            let d = saccade_s(amplitude);
            let before = g.at(start - 1e-6);
            let after = g.at(start + d + 1e-6);
            let moved = ((after[0] - before[0]).powi(2) + (after[1] - before[1]).powi(2)).sqrt();
            assert!((moved - amplitude).abs() < 1e-6, "{moved} vs {amplitude}");
            if amplitude > 0.1 {
                let mid = g.at(start + d / 2.0);
                assert!(mid != before && mid != after);
            }
        }
    }
}

#[test]
fn the_gaze_stays_near_the_axis_and_moves_no_faster_than_an_eye() {
    for seed in 0..10 {
        let g = GazePath::saccades(seed, 20.0);
        let dt = 0.0005;
        let mut last = g.at(0.0);
        let mut t = dt;
        while t < 20.0 {
            let p = g.at(t);
            assert!(p[0].hypot(p[1]) <= RADIUS_DEG + 1e-9, "{p:?}");
            let v = ((p[0] - last[0]).powi(2) + (p[1] - last[1]).powi(2)).sqrt() / dt;
            assert!(v <= 600.0, "seed {seed} at {t}: {v} deg/s");
            last = p;
            t += dt;
        }
    }
}

#[test]
fn a_direction_lands_on_the_image_point_of_its_tangents() {
    let fov = Fov {
        left: -0.9,
        right: 0.7,
        up: 0.8,
        down: -1.0,
    };
    let [tl, tr, tu, td] = fov.tangents();
    for deg in [[0.0, 0.0], [10.0, -5.0], [-12.0, 8.0], [25.0, 30.0]] {
        let n = ndc(&fov, deg);
        // Back from NDC (+y down) to the tangents the image is linear in.
        let tx = tl + (n[0] + 1.0) / 2.0 * (tr - tl);
        let ty = tu + (n[1] + 1.0) / 2.0 * (td - tu);
        assert!((tx - deg[0].to_radians().tan()).abs() < 1e-12, "{deg:?}");
        assert!((ty - deg[1].to_radians().tan()).abs() < 1e-12, "{deg:?}");
    }
    // Up is up: a gaze above the axis lies above the axis's row.
    assert!(ndc(&fov, [0.0, 10.0])[1] < ndc(&fov, [0.0, 0.0])[1]);
}
