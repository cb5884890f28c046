//! A terrestrial laser scan of a loaded scene, for test data (`vergence
//! scan`): scanner stations on a grid over the scene's floor, each casting
//! rays in every direction (a Fibonacci sphere: near-uniform directions,
//! González, "Measurement of areas on a sphere using Fibonacci and
//! latitude–longitude lattices", Math. Geosci. 2010) through the scene's
//! instance hierarchy ([`super::raycast::SceneQuery`]). Each hit becomes a
//! point: moved along its ray by Gaussian range noise, coloured with the
//! hit material's base colour, its intensity falling with the incidence
//! angle's cosine and the range squared (the lidar equation for an
//! extended Lambertian target, normalised at 1 m).

use super::raycast::{Ray, SceneQuery};
use crate::scene::factory::SplitMix64;
use crate::scene::points::PointCloud;
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;

/// How to scan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanSettings {
    /// Scanner stations (laid on a near-square grid over the floor).
    pub stations: u32,
    /// Rays per station.
    pub rays_per_station: u32,
    /// Range noise, one standard deviation, metres.
    pub range_noise_m: f64,
    /// The scanner's reach, metres.
    pub max_range_m: f64,
    /// Scanner height above the scene's floor (its lowest point), metres.
    pub height_m: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for ScanSettings {
    fn default() -> Self {
        ScanSettings {
            stations: 4,
            rays_per_station: 250_000,
            range_noise_m: 0.003,
            max_range_m: 120.0,
            height_m: 1.6,
            seed: 1,
        }
    }
}

/// The stations of `settings` over a scene with world bounds `lo`–`hi`:
/// cell centres of a near-square grid over the footprint (x, z), at the
/// scanner height above the floor.
pub fn stations(lo: DVec3, hi: DVec3, settings: &ScanSettings) -> Vec<DVec3> {
    let n = settings.stations.max(1) as usize;
    let cols = (n as f64).sqrt().ceil() as usize;
    let rows = n.div_ceil(cols);
    let y = lo.y + settings.height_m;
    (0..n)
        .map(|i| {
            let (c, r) = (i % cols, i / cols);
            let fx = (c as f64 + 0.5) / cols as f64;
            let fz = (r as f64 + 0.5) / rows as f64;
            DVec3::new(lo.x + (hi.x - lo.x) * fx, y, lo.z + (hi.z - lo.z) * fz)
        })
        .collect()
}

/// Direction `i` of `n` on the Fibonacci sphere (unit length).
pub fn fibonacci_direction(i: u32, n: u32) -> DVec3 {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let y = 1.0 - 2.0 * (i as f64 + 0.5) / n.max(1) as f64;
    let r = (1.0 - y * y).max(0.0).sqrt();
    let phi = golden * i as f64;
    DVec3::new(r * phi.cos(), y, r * phi.sin())
}

/// A standard normal sample from two uniforms (Box–Muller).
fn gaussian(rng: &mut SplitMix64) -> f64 {
    let u1 = rng.unit().max(1e-300);
    let u2 = rng.unit();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Scans `scene`: every station's rays in parallel, hits in station and
/// ray order (so a scan is the same whatever the thread count). The cloud's
/// origin is the scene's bounds centre.
pub fn scan(scene: &Scene, settings: &ScanSettings) -> PointCloud {
    let query = SceneQuery::new(scene);
    let (lo, hi) = scene.bounds();
    let origin = (lo + hi) * 0.5;
    let n = settings.rays_per_station;
    let mut cloud = PointCloud {
        origin,
        ..PointCloud::default()
    };
    for (s, station) in stations(lo, hi, settings).into_iter().enumerate() {
        let hits: Vec<Option<([f32; 3], [u8; 4])>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let dir = fibonacci_direction(i, n);
                let ray = Ray {
                    origin: station,
                    direction: dir,
                    max_t: settings.max_range_m,
                };
                let hit = query.cast(&ray)?;
                let mut rng = SplitMix64::new(
                    settings.seed ^ ((s as u64) << 32 | i as u64).wrapping_mul(0x9E37_79B9),
                );
                let range = hit.t + gaussian(&mut rng) * settings.range_noise_m;
                let p = station + dir * range - origin;
                let cos = hit.normal.dot(-dir).abs();
                let intensity = (cos / hit.t.max(1.0).powi(2)).clamp(0.0, 1.0);
                let material = scene
                    .primitives
                    .get(hit.primitive as usize)
                    .and_then(|p| scene.materials.get(p.material as usize));
                let base = material.map_or([0.8; 4], |m| m.base_color);
                let srgb = |l: f32| (linear_to_srgb(l.clamp(0.0, 1.0)) * 255.0).round() as u8;
                Some((
                    [p.x as f32, p.y as f32, p.z as f32],
                    [
                        srgb(base[0]),
                        srgb(base[1]),
                        srgb(base[2]),
                        (intensity * 255.0).round() as u8,
                    ],
                ))
            })
            .collect();
        for (p, c) in hits.into_iter().flatten() {
            cloud.positions.push(p);
            cloud.colors.push(c);
            cloud.classification.push(1);
        }
    }
    cloud
}

/// Linear light to the sRGB transfer (IEC 61966-2-1).
fn linear_to_srgb(l: f32) -> f32 {
    if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibonacci_directions_are_unit_and_spread() {
        let n = 2000;
        let dirs: Vec<DVec3> = (0..n).map(|i| fibonacci_direction(i, n)).collect();
        assert!(dirs.iter().all(|d| (d.length() - 1.0).abs() < 1e-12));
        // Near-uniform: each octant holds about an eighth.
        for oct in 0..8 {
            let count = dirs
                .iter()
                .filter(|d| {
                    (d.x >= 0.0) == (oct & 1 == 0)
                        && (d.y >= 0.0) == (oct & 2 == 0)
                        && (d.z >= 0.0) == (oct & 4 == 0)
                })
                .count();
            assert!((count as f64 - 250.0).abs() < 25.0, "octant {oct}: {count}");
        }
    }

    /// Every point lies on a surface the scene has: a ray cast from its
    /// station towards it stops within the noise of it.
    #[test]
    fn points_lie_on_the_scene_and_the_scan_is_deterministic() {
        let scene = crate::scene::factory::generate(300, 7).unwrap();
        let settings = ScanSettings {
            stations: 2,
            rays_per_station: 4000,
            range_noise_m: 0.0,
            ..ScanSettings::default()
        };
        let cloud = scan(&scene, &settings);
        assert!(cloud.len() > 3000, "{} points", cloud.len());
        assert_eq!(cloud, scan(&scene, &settings));
        let query = SceneQuery::new(&scene);
        let (lo, hi) = scene.bounds();
        let st = stations(lo, hi, &settings);
        for i in (0..cloud.len()).step_by(97) {
            let p = cloud.world(i);
            let near = st
                .iter()
                .map(|s| {
                    let d = p - *s;
                    let hit = query.cast(&Ray {
                        origin: *s,
                        direction: d.normalize(),
                        max_t: d.length() + 0.01,
                    });
                    hit.map_or(f64::MAX, |h| (h.t - d.length()).abs())
                })
                .fold(f64::MAX, f64::min);
            assert!(near < 1e-3, "point {i} is {near} m off a surface");
        }
    }
}
