//! Basic orientation checks of the culling volumes.

use glam::DVec3;
use vergence::cull::{cull, exact_per_eye, Bvh, CullParams, Strategy};
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

fn unit_box(c: DVec3) -> (DVec3, DVec3) {
    (c - DVec3::splat(0.1), c + DVec3::splat(0.1))
}

#[test]
fn front_kept_back_and_sides_rejected() {
    let eyes = HmdProfile::load("valve-index").unwrap().eyes();
    let rig = StereoRig::from_head(Pose::default(), &eyes);
    let boxes = vec![
        unit_box(DVec3::new(0.0, 0.0, -5.0)),
        unit_box(DVec3::new(0.0, 0.0, 5.0)),
        unit_box(DVec3::new(20.0, 0.0, -1.0)),
        unit_box(DVec3::new(-20.0, 0.0, -1.0)),
        unit_box(DVec3::new(0.0, 20.0, -1.0)),
        unit_box(DVec3::new(0.0, -20.0, -1.0)),
        unit_box(DVec3::new(3.0, 2.0, -5.0)),
    ];
    let bvh = Bvh::build(&boxes, 1).unwrap();
    for s in Strategy::ALL {
        let out = cull(s, &rig, 0, &bvh, &CullParams::default()).unwrap();
        assert!(out.visible.contains(&0), "{s}");
        assert!(!out.visible.contains(&1), "{s}");
        assert!(
            !out.visible.contains(&2) && !out.visible.contains(&3),
            "{s}: {:?}",
            out.visible
        );
    }
    assert_eq!(
        exact_per_eye(&rig, &bvh, &CullParams::default()).unwrap(),
        vec![0, 6]
    );
}

#[test]
fn superfrustum_apex_recedes_to_where_the_outer_planes_meet() {
    use vergence::view::frustum::Frustum;
    use vergence::view::superfrustum::Superfrustum;
    use vergence::view::Fov;
    // Everitt: symmetric eyes at ±ipd/2 with half-angle h meet on the axis
    // (ipd/2) / tan h behind the eyes.
    let (ipd, h) = (0.063, 0.96f64);
    let eye = |x: f64| {
        (
            Pose {
                position: DVec3::new(x, 0.0, 0.0),
                ..Pose::default()
            },
            Fov::symmetric(h, 0.9),
        )
    };
    let rig = StereoRig::from_head(Pose::default(), &[eye(-ipd / 2.0), eye(ipd / 2.0)]);
    let fr: Vec<Frustum> = rig
        .views
        .iter()
        .map(|v| Frustum::from_view(v, 0.05, None).unwrap())
        .collect();
    let sf = Superfrustum::enclosing(&fr).unwrap();
    let expected = ipd / 2.0 / h.tan();
    let got = sf.apex_recession().unwrap();
    assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
    for (a, b) in sf
        .tangents
        .iter()
        .zip([-h.tan(), h.tan(), 0.9f64.tan(), -0.9f64.tan()])
    {
        assert!((a - b).abs() < 1e-12);
    }
}
