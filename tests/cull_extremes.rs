//! One test per extreme the culling must survive: half-angles of 89.9°,
//! total FOV ≥ 180° (fallback), canted eyes, mirrored and vertically
//! asymmetric FOVs (and the per-plane merge bug), IPD 0 and 1 m, near plane
//! 1e-5 m, 1e7 m from the origin, invalid poses and bounds.

use glam::{DQuat, DVec3};
use vergence::cull::{
    compare, cull, cull_flat, exact_per_eye, Bvh, BvhError, CullError, CullOutput, CullParams,
    Strategy,
};
use vergence::view::frustum::{Frustum, Plane, PlaneSet};
use vergence::view::{Fov, Pose, StereoRig};

const DEG: f64 = std::f64::consts::PI / 180.0;

/// Boxes on a jittered grid around `c`, 0.05–1 m across.
fn grid(c: DVec3, half: f64, step: f64) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::new();
    let n = (2.0 * half / step) as i32;
    let mut k = 0u32;
    for i in 0..=n {
        for j in 0..=n {
            for l in 0..=n {
                k = k.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                let s = 0.05 + 0.95 * ((k >> 8) % 1000) as f64 / 1000.0 * 0.5;
                let p = c + DVec3::new(i as f64, j as f64, l as f64) * step - DVec3::splat(half);
                out.push((p - DVec3::splat(s), p + DVec3::splat(s)));
            }
        }
    }
    out
}

fn stereo(head: Pose, ipd: f64, cant_deg: f64, left: Fov, right: Fov) -> StereoRig {
    StereoRig::from_head(
        head,
        &[
            (
                Pose::from_euler_deg(DVec3::new(-ipd / 2.0, 0.0, 0.0), cant_deg, 0.0, 0.0),
                left,
            ),
            (
                Pose::from_euler_deg(DVec3::new(ipd / 2.0, 0.0, 0.0), -cant_deg, 0.0, 0.0),
                right,
            ),
        ],
    )
}

/// Runs every strategy; checks hierarchy == brute force and no false
/// negatives for the strategies that promise none. Returns outputs by
/// strategy plus the exact list.
fn check(
    rig: &StereoRig,
    boxes: &[(DVec3, DVec3)],
    params: &CullParams,
) -> (Vec<(Strategy, CullOutput)>, Vec<u32>) {
    let bvh = Bvh::build(boxes, 4).unwrap();
    let exact = exact_per_eye(rig, &bvh, params).unwrap();
    let mut outs = Vec::new();
    for s in Strategy::ALL {
        let h = cull(s, rig, 0, &bvh, params).unwrap();
        let f = cull_flat(s, rig, 0, &bvh, params).unwrap();
        assert_eq!(h.visible, f.visible, "{s}: hierarchy != brute force");
        let (_, fneg) = compare(&h.visible, &exact);
        if !s.may_miss() {
            assert_eq!(fneg, 0, "{s}: {fneg} false negatives");
        }
        outs.push((s, h));
    }
    (outs, exact)
}

fn get(outs: &[(Strategy, CullOutput)], s: Strategy) -> &CullOutput {
    &outs.iter().find(|(k, _)| *k == s).unwrap().1
}

#[test]
fn half_angles_of_89_9_degrees() {
    let f = Fov::symmetric(89.9 * DEG, 89.9 * DEG);
    let rig = stereo(Pose::default(), 0.063, 0.0, f, f);
    let (outs, exact) = check(&rig, &grid(DVec3::ZERO, 12.0, 1.5), &CullParams::default());
    assert_eq!(
        get(&outs, Strategy::Superfrustum).stats.fallbacks,
        0,
        "179.8° total still has an apex"
    );
    assert!(!exact.is_empty());
}

#[test]
fn total_fov_of_180_degrees_or_more_falls_back_to_per_eye() {
    // Each eye sees 89.9° outward and is canted 0.5° further out: the outer
    // rays point 90.4° from forward, the outer planes never meet.
    let f = Fov::symmetric(89.9 * DEG, 60.0 * DEG);
    let rig = stereo(Pose::default(), 0.063, 0.5, f, f);
    let (outs, _) = check(&rig, &grid(DVec3::ZERO, 12.0, 1.5), &CullParams::default());
    let sf = get(&outs, Strategy::Superfrustum);
    assert_eq!(sf.stats.fallbacks, 1);
    assert_eq!(sf.visible, get(&outs, Strategy::PerEye).visible);
    let csf = get(&outs, Strategy::ConicalSuperfrustum);
    assert_eq!(csf.stats.fallbacks, 1);
    assert_eq!(csf.visible, get(&outs, Strategy::Conical).visible);
}

#[test]
fn canted_eyes_up_to_45_degrees() {
    for cant in [-45.0, -20.0, 20.0, 45.0] {
        let f = Fov {
            left: -40.0 * DEG,
            right: 40.0 * DEG,
            up: 35.0 * DEG,
            down: -50.0 * DEG,
        };
        let rig = stereo(
            Pose::from_euler_deg(DVec3::new(1.0, 2.0, 3.0), 30.0, 10.0, 5.0),
            0.07,
            cant,
            f,
            f,
        );
        let (outs, _) = check(
            &rig,
            &grid(DVec3::new(1.0, 2.0, 3.0), 12.0, 1.5),
            &CullParams::default(),
        );
        assert_eq!(
            get(&outs, Strategy::Superfrustum).stats.fallbacks,
            0,
            "cant {cant}"
        );
    }
    // 45° outward with 50° half-angles reaches 95°: fallback, still exact.
    let f = Fov::symmetric(50.0 * DEG, 40.0 * DEG);
    let (outs, _) = check(
        &stereo(Pose::default(), 0.07, 45.0, f, f),
        &grid(DVec3::ZERO, 12.0, 1.5),
        &CullParams::default(),
    );
    assert_eq!(get(&outs, Strategy::Superfrustum).stats.fallbacks, 1);
}

#[test]
fn mirrored_and_vertically_asymmetric_fovs_and_the_per_plane_merge_bug() {
    // Mirrored: each eye's wide side points inward, so the outermost eye
    // does not own the widest outer plane.
    let l = Fov {
        left: -0.3,
        right: 0.9,
        up: 0.2,
        down: -0.9,
    };
    let r = Fov {
        left: -0.9,
        right: 0.3,
        up: 0.9,
        down: -0.2,
    };
    let rig = stereo(Pose::default(), 0.063, 0.0, l, r);
    let boxes = grid(DVec3::ZERO, 10.0, 0.8);
    let (outs, exact) = check(&rig, &boxes, &CullParams::default());
    assert_eq!(get(&outs, Strategy::Superfrustum).stats.fallbacks, 0);

    // The naive merge: left plane of the left eye, right plane of the right
    // eye, near of the left eye, and the higher top / lower bottom plane.
    let p = CullParams::default();
    let fl = Frustum::from_view(&rig.views[0], p.near, None).unwrap();
    let fr = Frustum::from_view(&rig.views[1], p.near, None).unwrap();
    let world = |f: &Frustum, i: usize| {
        let pl = f.planes.planes[i];
        Plane {
            normal: pl.normal,
            d: pl.d - pl.normal.dot(f.apex()),
        }
    };
    let top = if l.up > r.up {
        world(&fl, 3)
    } else {
        world(&fr, 3)
    };
    let bottom = if l.down < r.down {
        world(&fl, 4)
    } else {
        world(&fr, 4)
    };
    let naive = PlaneSet {
        origin: DVec3::ZERO,
        planes: [
            world(&fl, 0),
            world(&fl, 1),
            world(&fr, 2),
            top,
            bottom,
            world(&fl, 0),
        ],
        len: 5,
    };
    let naive_kept: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| naive.keeps_box(boxes[i as usize].0, boxes[i as usize].1))
        .collect();
    let (_, naive_misses) = compare(&naive_kept, &exact);
    assert!(
        naive_misses > 0,
        "the per-plane merge should over-cull this rig"
    );
    let (_, ours) = compare(&get(&outs, Strategy::Superfrustum).visible, &exact);
    assert_eq!(ours, 0);
}

#[test]
fn ipd_of_zero_and_one_metre() {
    let f = Fov {
        left: -0.96,
        right: 0.9,
        up: 0.98,
        down: -0.95,
    };
    for ipd in [0.0, 1.0] {
        let rig = stereo(
            Pose::from_euler_deg(DVec3::ZERO, 60.0, -20.0, 0.0),
            ipd,
            0.0,
            f,
            f,
        );
        let (outs, _) = check(&rig, &grid(DVec3::ZERO, 12.0, 1.5), &CullParams::default());
        assert_eq!(get(&outs, Strategy::Superfrustum).stats.fallbacks, 0);
        assert_eq!(get(&outs, Strategy::ConicalSuperfrustum).stats.fallbacks, 0);
    }
}

#[test]
fn near_plane_of_1e_minus_5() {
    let f = Fov::symmetric(0.9, 0.9);
    let rig = stereo(Pose::default(), 0.0, 0.0, f, f);
    let tiny = |z: f64| {
        (
            DVec3::new(-1e-6, -1e-6, z - 1e-6),
            DVec3::new(1e-6, 1e-6, z + 1e-6),
        )
    };
    let boxes = vec![tiny(-3e-5), tiny(3e-5), tiny(-5e-6)];
    let params = CullParams {
        near: 1e-5,
        ..CullParams::default()
    };
    let (outs, exact) = check(&rig, &boxes, &params);
    assert_eq!(exact, vec![0], "in front of the near plane only");
    assert_eq!(get(&outs, Strategy::Superfrustum).visible, vec![0]);
    assert_eq!(get(&outs, Strategy::PerEye).visible, vec![0]);
}

#[test]
fn ten_million_metres_from_the_origin() {
    let f = Fov {
        left: -0.96,
        right: 0.9,
        up: 0.98,
        down: -0.95,
    };
    let far = DVec3::new(1e7, -1e7, 1e7);
    let at = |o: DVec3| {
        let rig = stereo(Pose::from_euler_deg(o, 35.0, 10.0, 3.0), 0.063, 5.0, f, f);
        let params = CullParams {
            draw_distance: Some(9.0),
            ..CullParams::default()
        };
        check(&rig, &grid(o, 12.0, 1.5), &params)
    };
    let (near_outs, near_exact) = at(DVec3::ZERO);
    let (far_outs, far_exact) = at(far);
    assert_eq!(near_exact, far_exact);
    for ((s, a), (_, b)) in near_outs.iter().zip(&far_outs) {
        assert_eq!(a.visible, b.visible, "{s} differs at 1e7 m");
    }
}

#[test]
fn invalid_poses_are_rejected_and_nothing_is_culled() {
    let f = Fov::symmetric(0.9, 0.9);
    let good = stereo(Pose::default(), 0.063, 0.0, f, f);
    let bvh = Bvh::build(&grid(DVec3::ZERO, 5.0, 1.0), 4).unwrap();
    let p = CullParams::default();
    let mut bad = Vec::new();
    let mut r = good.clone();
    r.views[0].pose.position.x = f64::NAN;
    bad.push(r);
    let mut r = good.clone();
    r.views[1].pose.orientation = DQuat::from_xyzw(f64::NAN, 0.0, 0.0, 1.0);
    bad.push(r);
    let mut r = good.clone();
    r.views[1].pose.orientation = DQuat::from_xyzw(0.0, 0.0, 0.0, 1.1);
    bad.push(r);
    let mut r = good.clone();
    r.views[0].fov.left = f64::INFINITY;
    bad.push(r);
    bad.push(StereoRig {
        head: Pose::default(),
        views: vec![],
        hidden_area: None,
    });
    for rig in &bad {
        for s in Strategy::ALL {
            assert!(cull(s, rig, 0, &bvh, &p).is_err(), "{s} accepted {rig:?}");
            assert!(cull_flat(s, rig, 0, &bvh, &p).is_err());
        }
        assert!(exact_per_eye(rig, &bvh, &p).is_err());
    }
    for near in [0.0, -1.0, f64::NAN] {
        let e = cull(
            Strategy::Superfrustum,
            &good,
            0,
            &bvh,
            &CullParams { near, ..p },
        );
        assert!(matches!(e, Err(CullError::Volume { .. })));
    }
    let e = cull(
        Strategy::PerEye,
        &good,
        0,
        &bvh,
        &CullParams {
            draw_distance: Some(0.01),
            ..p
        },
    );
    assert!(e.is_err(), "draw distance inside the near plane");
    let nan_box = [
        (DVec3::ZERO, DVec3::ONE),
        (DVec3::splat(f64::NAN), DVec3::ONE),
    ];
    assert!(matches!(
        Bvh::build(&nan_box, 4),
        Err(BvhError::InvalidBounds { index: 1, .. })
    ));
    assert!(Bvh::build(&[(DVec3::ONE, DVec3::ZERO)], 4).is_err());
}

#[test]
fn round_robin_false_negatives_are_counted() {
    // Wide IPD and inward-looking FOVs: a box only the right eye sees.
    let l = Fov {
        left: -0.2,
        right: 0.6,
        up: 0.5,
        down: -0.5,
    };
    let r = Fov {
        left: -0.6,
        right: 0.2,
        up: 0.5,
        down: -0.5,
    };
    let rig = stereo(Pose::default(), 1.0, 0.0, l, r);
    let only_right = (
        DVec3::new(0.58, -0.02, -1.02),
        DVec3::new(0.62, 0.02, -0.98),
    );
    let both = (
        DVec3::new(-0.05, -0.05, -3.05),
        DVec3::new(0.05, 0.05, -2.95),
    );
    let bvh = Bvh::build(&[only_right, both], 1).unwrap();
    let p = CullParams {
        compare_exact: true,
        ..CullParams::default()
    };
    assert_eq!(exact_per_eye(&rig, &bvh, &p).unwrap(), vec![0, 1]);
    let left_frame = cull(Strategy::RoundRobin, &rig, 0, &bvh, &p).unwrap();
    assert_eq!(left_frame.visible, vec![1]);
    assert_eq!(left_frame.stats.false_negatives, Some(1));
    let right_frame = cull(Strategy::RoundRobin, &rig, 1, &bvh, &p).unwrap();
    assert_eq!(right_frame.stats.false_negatives, Some(0));
    let sf = cull(Strategy::Superfrustum, &rig, 0, &bvh, &p).unwrap();
    assert_eq!((sf.stats.false_negatives, sf.visible.len()), (Some(0), 2));
}
