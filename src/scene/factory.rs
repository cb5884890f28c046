//! The built-in procedural scene `factory`: an industrial hall of 10 m bays
//! laid out from the origin along +X and -Z. Each bay has a floor tile, a
//! column, an overhead pipe and a lamp, and either shelving racks loaded with
//! crates or a machine with barrels. Generation stops at exactly N instances
//! and is deterministic for a seed, so golden images and benchmarks repeat.

use super::{shapes, Instance, Material, Mesh, Scene};
use crate::error::Result;
use glam::{DAffine3, DQuat, DVec3};

/// Instance count of plain `factory`.
pub const DEFAULT_INSTANCES: usize = 100_000;
/// Seed of the built-in scene.
pub const DEFAULT_SEED: u64 = 0x5EED_FAC7;
/// The largest instance count accepted (memory guard: ~200 bytes each).
pub const MAX_INSTANCES: usize = 50_000_000;
/// Bay edge length in metres.
pub const BAY: f64 = 10.0;

/// A small deterministic generator (SplitMix64; Steele, Lea and Flood,
/// "Fast Splittable Pseudorandom Number Generators", OOPSLA 2014).
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[derive(Clone, Copy)]
enum M {
    Floor,
    Column,
    Upright,
    Shelf,
    CrateSmall,
    CrateLarge,
    Pipe,
    MachineBody,
    MachineDrum,
    Barrel,
    Lamp,
}

fn material(name: &str, rgb: [f32; 3], metallic: f32, roughness: f32) -> Material {
    Material {
        name: name.into(),
        base_color: [rgb[0], rgb[1], rgb[2], 1.0],
        metallic,
        roughness,
        ..Material::default()
    }
}

fn build_assets(scene: &mut Scene) {
    scene.materials = vec![
        material("concrete", [0.42, 0.42, 0.40], 0.0, 0.9),
        material("safety-yellow", [0.85, 0.62, 0.05], 0.2, 0.5),
        material("rack-blue", [0.05, 0.18, 0.55], 0.5, 0.4),
        material("rack-orange", [0.90, 0.35, 0.05], 0.3, 0.5),
        material("cardboard", [0.55, 0.40, 0.22], 0.0, 0.8),
        material("steel", [0.75, 0.75, 0.78], 1.0, 0.3),
        material("machine-green", [0.10, 0.45, 0.25], 0.3, 0.45),
        material("barrel-red", [0.65, 0.06, 0.05], 0.4, 0.35),
        Material {
            emissive: [4.0, 3.8, 3.2],
            ..material("lamp", [1.0, 1.0, 0.95], 0.0, 0.5)
        },
    ];
    let prims = [
        shapes::cuboid([5.0, 0.05, 5.0], 0),
        shapes::cylinder(0.3, 5.0, 16, 1),
        shapes::cuboid([0.05, 2.0, 0.05], 2),
        shapes::cuboid([1.4, 0.03, 0.5], 3),
        shapes::cuboid([0.3, 0.3, 0.3], 4),
        shapes::cuboid([0.5, 0.4, 0.4], 4),
        shapes::cylinder(0.15, 5.0, 12, 5),
        shapes::cuboid([1.5, 1.0, 1.0], 6),
        shapes::cylinder(0.6, 0.8, 24, 5),
        shapes::cylinder(0.3, 0.45, 16, 7),
        shapes::cuboid([0.6, 0.05, 0.2], 8),
    ];
    let names = [
        "floor",
        "column",
        "upright",
        "shelf",
        "crate-small",
        "crate-large",
        "pipe",
        "machine-body",
        "machine-drum",
        "barrel",
        "lamp",
    ];
    for (i, (p, n)) in prims.into_iter().zip(names).enumerate() {
        scene.primitives.push(p);
        scene.meshes.push(Mesh {
            name: n.into(),
            primitives: vec![i as u32],
        });
    }
}

struct Placer<'a> {
    scene: &'a mut Scene,
    limit: usize,
}

impl Placer<'_> {
    fn full(&self) -> bool {
        self.scene.instances.len() >= self.limit
    }

    fn put(&mut self, mesh: M, pos: DVec3, rot: DQuat) {
        if !self.full() {
            let transform = DAffine3::from_rotation_translation(rot, pos);
            self.scene.instances.push(Instance {
                mesh: mesh as u32,
                transform,
            });
        }
    }

    fn at(&mut self, mesh: M, pos: DVec3) {
        self.put(mesh, pos, DQuat::IDENTITY);
    }
}

fn rack_bay(p: &mut Placer, rng: &mut SplitMix64, o: DVec3) {
    for row in 0..2 {
        let z = o.z - 3.0 - 4.0 * row as f64;
        for x0 in [2.0, 5.5] {
            let x = o.x + x0;
            for (dx, dz) in [(-1.35, -0.45), (1.35, -0.45), (-1.35, 0.45), (1.35, 0.45)] {
                p.at(M::Upright, DVec3::new(x + dx, 2.0, z + dz));
            }
            for level in 0..4 {
                let y = 0.3 + level as f64 * 1.1;
                p.at(M::Shelf, DVec3::new(x, y, z));
                let crates = (rng.next_u64() % 4) as usize;
                for c in 0..crates {
                    let big = rng.unit() < 0.3;
                    let cx = x - 0.9 + c as f64 * 0.6 + (rng.unit() - 0.5) * 0.1;
                    let (mesh, h) = if big {
                        (M::CrateLarge, 0.4)
                    } else {
                        (M::CrateSmall, 0.3)
                    };
                    let rot = DQuat::from_rotation_y((rng.unit() - 0.5) * 0.3);
                    p.put(mesh, DVec3::new(cx, y + 0.03 + h, z), rot);
                }
            }
        }
    }
}

fn machine_bay(p: &mut Placer, rng: &mut SplitMix64, o: DVec3) {
    let yaw = DQuat::from_rotation_y(rng.unit() * std::f64::consts::TAU);
    p.put(M::MachineBody, o + DVec3::new(5.0, 1.0, -5.0), yaw);
    p.put(M::MachineDrum, o + DVec3::new(5.0, 2.8, -5.0), yaw);
    let barrels = 4 + (rng.next_u64() % 8) as usize;
    for i in 0..barrels {
        let x = o.x + 1.0 + (i % 4) as f64 * 0.7;
        let z = o.z - 8.5 - (i / 4) as f64 * 0.7;
        p.at(M::Barrel, DVec3::new(x, 0.5, z));
    }
}

/// Generates `factory:n` deterministically from `seed`.
pub fn generate(n: usize, seed: u64) -> Result<Scene> {
    super::count_within("factory", n, MAX_INSTANCES, "instance count")?;
    let mut scene = Scene {
        name: format!("factory:{n}"),
        // The hall's entrance, looking in.
        spawn: Some(crate::view::Pose::from_euler_deg(
            DVec3::new(3.0, 0.0, 2.0),
            -25.0,
            0.0,
            0.0,
        )),
        ..Scene::default()
    };
    build_assets(&mut scene);
    scene.instances.reserve(n);
    let mut rng = SplitMix64::new(seed);
    // About 45 instances per bay; lay bays out in a near-square grid.
    let width = ((n as f64 / 45.0).sqrt().ceil() as usize).max(1);
    let mut p = Placer {
        scene: &mut scene,
        limit: n,
    };
    let mut bay = 0usize;
    while !p.full() {
        let (i, j) = (bay % width, bay / width);
        let o = DVec3::new(i as f64 * BAY, 0.0, -(j as f64) * BAY);
        p.at(M::Floor, o + DVec3::new(5.0, -0.05, -5.0));
        p.at(M::Column, o + DVec3::new(0.0, 5.0, 0.0));
        let pipe = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
        p.put(M::Pipe, o + DVec3::new(5.0, 8.0, -0.5), pipe);
        p.at(M::Lamp, o + DVec3::new(5.0, 9.0, -5.0));
        if rng.unit() < 0.75 {
            rack_bay(&mut p, &mut rng, o);
        } else {
            machine_bay(&mut p, &mut rng, o);
        }
        bay += 1;
    }
    scene.nodes = scene.instances.len();
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_count_and_deterministic() {
        let a = generate(12_345, 7).unwrap();
        let b = generate(12_345, 7).unwrap();
        assert_eq!(a.instances.len(), 12_345);
        let same = a
            .instances
            .iter()
            .zip(&b.instances)
            .all(|(x, y)| x.mesh == y.mesh && x.transform == y.transform);
        assert!(same);
        let c = generate(12_345, 8).unwrap();
        assert!(a
            .instances
            .iter()
            .zip(&c.instances)
            .any(|(x, y)| x.transform != y.transform));
    }

    #[test]
    fn hall_is_roughly_square_and_on_the_floor() {
        let s = generate(100_000, DEFAULT_SEED).unwrap();
        let (lo, hi) = s.bounds();
        let (w, d) = (hi.x - lo.x, hi.z - lo.z);
        assert!(
            w > 300.0 && w < 600.0 && d > 300.0 && d < 700.0,
            "{w} x {d}"
        );
        assert!(lo.y >= -0.11 && hi.y <= 10.1, "{lo} {hi}");
    }

    #[test]
    fn zero_and_absurd_counts_are_errors() {
        assert!(generate(0, 1).is_err());
        assert!(generate(MAX_INSTANCES + 1, 1).is_err());
    }
}
