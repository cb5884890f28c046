//! Basic orientation checks of the culling volumes.

use glam::DVec3;
use vergence::cull::bench::builtin_eyes;
use vergence::cull::{cull, exact_per_eye, Bvh, CullParams, Strategy};
use vergence::view::{Pose, StereoRig};

fn unit_box(c: DVec3) -> (DVec3, DVec3) {
    (c - DVec3::splat(0.1), c + DVec3::splat(0.1))
}

#[test]
fn front_kept_back_and_sides_rejected() {
    let eyes = builtin_eyes(None).unwrap();
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
