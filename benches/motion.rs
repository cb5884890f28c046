//! Criterion benches of moving instances on the CPU: the moving fleet's
//! 30,800 instances (manifests/scenes/moving-fleet.toml) placed at a time,
//! their world bounds, their GPU records staged; and the culling
//! hierarchy's update for 1,000 of 100,000 instances against a full refit.

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;
use rayon::prelude::*;
use vergence::cull::{Bvh, DEFAULT_LEAF_SIZE};
use vergence::render::instance_updates::InstanceUpdates;
use vergence::scene::motion::{transforms_at, Moved};
use vergence::scene::{factory, manifest, WorldBounds};

fn benches(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = manifest::load(&root.join("manifests/scenes/moving-fleet.toml")).expect("scene");
    let mesh_bounds: Vec<_> = (0..scene.meshes.len() as u32)
        .map(|m| scene.mesh_bounds(m))
        .collect();
    let mut moved: Vec<Moved> = Vec::new();
    c.bench_function("motion_transforms_30800", |b| {
        b.iter(|| transforms_at(black_box(&scene.moving), 1.25, &mut moved))
    });
    transforms_at(&scene.moving, 1.25, &mut moved);
    let mut bounds: Vec<WorldBounds> = Vec::new();
    c.bench_function("motion_bounds_30800", |b| {
        b.iter(|| {
            black_box(&moved)
                .par_iter()
                .map(|m| WorldBounds::of(mesh_bounds[m.mesh as usize], &m.transform))
                .collect_into_vec(&mut bounds)
        })
    });
    let mut updates = InstanceUpdates::new(1);
    let boxes = |_: &Moved, b: &WorldBounds| {
        let (c, e) = (b.center.as_vec3(), ((b.max - b.min) * 0.5).as_vec3());
        [c.x, c.y, c.z, 0.0, 0.0, 0.0, 0.0, 0.0, e.x, e.y, e.z, 1.0]
    };
    c.bench_function("motion_stage_records_30800", |b| {
        b.iter(|| {
            updates.clear();
            updates.stage(black_box(&moved), &bounds, Some(&boxes));
        })
    });

    let all = factory::generate(100_000, factory::DEFAULT_SEED)
        .expect("factory")
        .world_aabbs();
    let shifted: Vec<(u32, (DVec3, DVec3))> = (0..1000u32)
        .map(|k| {
            let i = k * 97;
            let (lo, hi) = all[i as usize];
            (i, (lo + DVec3::Y, hi + DVec3::Y))
        })
        .collect();
    let mut bvh = Bvh::build(&all, DEFAULT_LEAF_SIZE).expect("valid bounds");
    c.bench_function("bvh_update_1000_of_100k", |b| {
        b.iter(|| bvh.update(black_box(&shifted)))
    });
    c.bench_function("bvh_refit_100k", |b| b.iter(|| bvh.refit(black_box(&all))));
}

criterion_group!(motion_benches, benches);
criterion_main!(motion_benches);
