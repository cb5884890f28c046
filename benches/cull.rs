//! Criterion benches of BVH build and the main culling strategies on the
//! built-in factory scene (100k instances) with the Valve Index profile.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use vergence::bench::cull::{head_path, scene_bounds};
use vergence::cull::{Bvh, CullParams, Culler, Strategy, DEFAULT_LEAF_SIZE};
use vergence::scene::factory;
use vergence::view::profile::HmdProfile;
use vergence::view::StereoRig;

fn benches(c: &mut Criterion) {
    let bounds = factory::generate(100_000, factory::DEFAULT_SEED)
        .expect("factory")
        .world_aabbs();
    let eyes = HmdProfile::load("valve-index")
        .expect("built-in profile")
        .eyes();
    let (lo, hi) = scene_bounds(&bounds);
    c.bench_function("bvh_build_100k", |b| {
        b.iter(|| Bvh::build(black_box(&bounds), DEFAULT_LEAF_SIZE))
    });
    let bvh = Bvh::build(&bounds, DEFAULT_LEAF_SIZE).expect("valid bounds");
    let rig = StereoRig::from_head(head_path(10, 1, lo, hi), &eyes);
    let params = CullParams::default();
    for s in [
        Strategy::PerEye,
        Strategy::Superfrustum,
        Strategy::ConicalSuperfrustum,
        Strategy::PerEyeBrute,
    ] {
        let mut culler = Culler::new();
        c.bench_function(&format!("cull_100k_{}", s.name()), |b| {
            b.iter(|| {
                culler
                    .cull(s, black_box(&rig), 0, &bvh, &params)
                    .map(|o| o.visible.len())
            })
        });
    }
}

criterion_group!(cull_benches, benches);
criterion_main!(cull_benches);
