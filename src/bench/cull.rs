//! `vergence cull-bench`: times every culling strategy along a deterministic
//! head path and compares each frame's result with exact per-eye culling.
//!
//! The caller supplies the scene boxes (the CLI: `factory:N`) and the eyes
//! in head space (the CLI: the `--hmd` profile); the head path walks at eye
//! height through the middle 70 % of the scene's bounds.

use std::time::Instant;

use glam::DVec3;

use crate::cull::{
    compare, exact_per_eye, Bvh, BvhError, CullError, CullParams, Culler, Strategy,
    DEFAULT_LEAF_SIZE,
};
use crate::view::{Fov, Pose, StereoRig};

/// Command-line arguments of `cull-bench`.
#[derive(clap::Args, Clone, Debug)]
pub struct CullBenchArgs {
    /// Number of instances in the scene (1 to 50,000,000).
    #[arg(long, default_value_t = 100_000,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=crate::scene::factory::MAX_INSTANCES as u64))]
    pub instances: usize,
    /// Comma-separated strategies to time (default: all).
    #[arg(long, value_delimiter = ',')]
    pub strategies: Vec<String>,
    /// HMD profile giving the eye poses and FOVs (resolved by the caller).
    #[arg(long)]
    pub hmd: Option<String>,
    /// Frames along the head path (1 to 1,000,000).
    #[arg(long, default_value_t = 200,
          value_parser = clap::value_parser!(u64).range(1..=crate::cli::MAX_CULL_BENCH_FRAMES))]
    pub frames: u64,
    /// Worker threads of the culling thread pool (1 to 64).
    #[arg(long, default_value_t = 2,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=crate::cli::MAX_THREADS as u64))]
    pub threads: usize,
    /// Seed of the head path (and of the stand-in scene).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Draw distance in metres (far plane along each eye's view axis;
    /// (0, 1e9]).
    #[arg(long, value_parser = crate::cli::parse_distance)]
    pub draw_distance: Option<f64>,
    /// Near plane in metres ((0, 1000]).
    #[arg(long, default_value_t = 0.05, value_parser = crate::cli::parse_near)]
    pub near: f64,
    /// Half-angle (radians, (0, π/2)) of the lens-visible circle used by
    /// the conical strategies instead of the cone around the FOV rectangle.
    #[arg(long, value_parser = crate::cli::parse_lens_half_angle)]
    pub lens_half_angle: Option<f64>,
    /// Largest number of instances per hierarchy leaf (1 to 65,536).
    #[arg(long, default_value_t = DEFAULT_LEAF_SIZE,
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=crate::cli::MAX_LEAF_SIZE as u64))]
    pub leaf_size: usize,
    /// Randomly renumber the instances first (measures how much the
    /// timings rely on instances being numbered in spatial order).
    #[arg(long)]
    pub shuffle: bool,
    /// Skip the exact per-eye comparison (false positives/negatives read 0).
    #[arg(long)]
    pub no_compare: bool,
}

/// Errors of the bench.
#[derive(Debug, thiserror::Error)]
pub enum CullBenchError {
    /// Bad scene bounds.
    #[error(transparent)]
    Bvh(#[from] BvhError),
    /// Bad strategy name or rig.
    #[error(transparent)]
    Cull(#[from] CullError),
    /// The thread pool could not be created.
    #[error("thread pool: {0}")]
    Pool(String),
    /// Bad arguments.
    #[error("{0}")]
    Args(String),
}

/// Results of one strategy.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StrategyReport {
    /// Strategy name.
    pub name: String,
    /// Median cull time per frame in milliseconds.
    pub median_ms: f64,
    /// 95th percentile cull time per frame in milliseconds.
    pub p95_ms: f64,
    /// Mean volume tests per frame.
    pub tests_per_frame: f64,
    /// Mean visible instances per frame.
    pub visible: f64,
    /// Mean false positives per frame against exact per-eye culling.
    pub false_positives: f64,
    /// Mean false negatives per frame against exact per-eye culling.
    pub false_negatives: f64,
    /// Total false negatives over all frames (never rounded to zero).
    pub false_negatives_total: u64,
    /// Frames that fell back to per-eye volumes.
    pub fallbacks: u64,
}

/// The whole report; serialises to the `--json` object.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CullBenchReport {
    /// Number of instances.
    pub instances: usize,
    /// Worker threads.
    pub threads: usize,
    /// Frames timed per strategy.
    pub frames: u64,
    /// Lens-circle half-angle the conical strategies used (radians; None:
    /// the cone around the FOV rectangle).
    pub lens_half_angle: Option<f64>,
    /// Hierarchy build time in milliseconds (in the same pool).
    pub bvh_build_ms: f64,
    /// Hierarchy node count.
    pub bvh_nodes: usize,
    /// Mean exact per-eye visible instances per frame.
    pub exact_visible: f64,
    /// Per-strategy results.
    pub strategies: Vec<StrategyReport>,
}

impl CullBenchReport {
    /// A plain-text table of the report.
    pub fn to_table(&self) -> String {
        let mut s = format!(
            "cull-bench: {} instances, {} threads, {} frames, BVH build {:.1} ms ({} nodes), exact visible {:.0}/frame\n",
            self.instances, self.threads, self.frames, self.bvh_build_ms, self.bvh_nodes, self.exact_visible
        );
        if let Some(a) = self.lens_half_angle {
            s += &format!("conical strategies use a lens circle of half-angle {a} rad\n");
        }
        s += &format!(
            "{:<22} {:>9} {:>9} {:>12} {:>10} {:>10} {:>10} {:>9}\n",
            "strategy",
            "median ms",
            "p95 ms",
            "tests/frame",
            "visible",
            "false pos",
            "false neg",
            "fallbacks"
        );
        for r in &self.strategies {
            s += &format!(
                "{:<22} {:>9.3} {:>9.3} {:>12.0} {:>10.0} {:>10.1} {:>10.1} {:>9}\n",
                r.name,
                r.median_ms,
                r.p95_ms,
                r.tests_per_frame,
                r.visible,
                r.false_positives,
                r.false_negatives,
                r.fallbacks
            );
        }
        s
    }
}

/// Head pose of frame `f` on the deterministic path: a slow Lissajous walk
/// at standing height through the 100 m hall, turning and nodding.
pub fn head_path(frame: u64, seed: u64, lo: DVec3, hi: DVec3) -> Pose {
    let t = frame as f64 / 90.0;
    let ph = (seed % 1000) as f64 * 0.618;
    let tau = std::f64::consts::TAU;
    let (c, e) = ((lo + hi) * 0.5, (hi - lo) * 0.35);
    let pos = DVec3::new(
        c.x + e.x * (tau * t / 23.0 + ph).sin(),
        lo.y + 1.7 + 0.05 * (tau * t * 1.7).sin(),
        c.z + e.z * (tau * t / 17.0 + 2.0 * ph).sin(),
    );
    let yaw = (360.0 * t / 9.0 + ph.to_degrees()) % 360.0;
    let pitch = 15.0 * (tau * t / 5.0).sin();
    let roll = 3.0 * (tau * t / 3.0).sin();
    Pose::from_euler_deg(pos, yaw, pitch, roll)
}

/// Head pose of frame `f` on the orbit path: outside the box `lo`..`hi`
/// at 0.8 of its diagonal from the centre, raised by a quarter of it,
/// circling slowly and looking at the centre, so the whole scene is in
/// view.
pub fn orbit_path(frame: u64, seed: u64, lo: DVec3, hi: DVec3) -> Pose {
    let t = frame as f64 / 90.0;
    let ph = (seed % 1000) as f64 * 0.618;
    let c = (lo + hi) * 0.5;
    let r = (hi - lo).length().max(1.0);
    let a = std::f64::consts::TAU * t / 30.0 + ph;
    let pos = c + DVec3::new(0.8 * r * a.sin(), 0.25 * r, 0.8 * r * a.cos());
    let d = c - pos;
    // Yaw about +Y from -Z, pitch up from the horizontal (Pose's Euler
    // convention: -Z forward).
    let yaw = (-d.x).atan2(-d.z).to_degrees();
    let pitch = (d.y / d.length()).asin().to_degrees();
    Pose::from_euler_deg(pos, yaw, pitch, 0.0)
}

/// The box enclosing all `bounds` (origin for none).
pub fn scene_bounds(bounds: &[(DVec3, DVec3)]) -> (DVec3, DVec3) {
    let lo = bounds
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |a, b| a.min(b.0));
    let hi = bounds
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, b| a.max(b.1));
    if lo.x > hi.x {
        (DVec3::ZERO, DVec3::ZERO)
    } else {
        (lo, hi)
    }
}

/// A seeded Fisher–Yates permutation of `bounds`.
fn shuffle(bounds: &[(DVec3, DVec3)], seed: u64) -> Vec<(DVec3, DVec3)> {
    let mut v = bounds.to_vec();
    let mut state = seed.wrapping_mul(0x2545_F491_4F6C_DD1D) | 1;
    for i in (1..v.len()).rev() {
        // xorshift64 (Marsaglia, 2003).
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        v.swap(i, (state % (i as u64 + 1)) as usize);
    }
    v
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let idx = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[idx]
}

/// The strategies to time (every one unless `--strategies` names some,
/// each at most once), with the thread, frame and lens arguments checked.
fn checked_strategies(args: &CullBenchArgs) -> Result<Vec<Strategy>, CullBenchError> {
    let strategies: Vec<Strategy> = if args.strategies.is_empty() {
        Strategy::ALL.to_vec()
    } else {
        args.strategies
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()?
    };
    if let Some(s) = strategies
        .iter()
        .enumerate()
        .find(|(i, s)| strategies[..*i].contains(s))
        .map(|(_, s)| s)
    {
        return Err(CullBenchError::Args(format!(
            "--strategies lists {} twice (each strategy is timed once)",
            s.name()
        )));
    }
    if !(1..=crate::cli::MAX_THREADS).contains(&args.threads)
        || !(1..=crate::cli::MAX_CULL_BENCH_FRAMES).contains(&args.frames)
    {
        return Err(CullBenchError::Args(format!(
            "--threads must be within 1..={} and --frames within 1..={}",
            crate::cli::MAX_THREADS,
            crate::cli::MAX_CULL_BENCH_FRAMES
        )));
    }
    if let Some(a) = args.lens_half_angle {
        crate::cli::parse_lens_half_angle(&a.to_string())
            .map_err(|m| CullBenchError::Args(format!("--lens-half-angle: {m}")))?;
    }
    Ok(strategies)
}

/// Runs the bench on `bounds` with `eyes` (poses relative to the head, left
/// first) in a pool of `args.threads` threads. Each frame computes exact
/// per-eye culling once (untimed), then times every strategy on it, in an
/// order rotated frame by frame.
pub fn run(
    args: &CullBenchArgs,
    bounds: &[(DVec3, DVec3)],
    eyes: &[(Pose, Fov)],
) -> Result<CullBenchReport, CullBenchError> {
    let strategies = checked_strategies(args)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .map_err(|e| CullBenchError::Pool(e.to_string()))?;
    let shuffled;
    let bounds = if args.shuffle {
        shuffled = shuffle(bounds, args.seed);
        &shuffled[..]
    } else {
        bounds
    };
    pool.install(|| {
        let params = CullParams {
            near: args.near,
            draw_distance: args.draw_distance,
            lens_half_angle: args.lens_half_angle,
            ..CullParams::default()
        };
        let t0 = Instant::now();
        let bvh = Bvh::build(bounds, args.leaf_size)?;
        let bvh_build_ms = t0.elapsed().as_secs_f64() * 1e3;
        let mut times = vec![Vec::with_capacity(args.frames as usize); strategies.len()];
        let mut tests = vec![0u64; strategies.len()];
        let mut visible = vec![0u64; strategies.len()];
        let mut fps = vec![0u64; strategies.len()];
        let mut fns = vec![0u64; strategies.len()];
        let mut falls = vec![0u64; strategies.len()];
        let mut exact_total = 0u64;
        // Warm-up: touch every code path and page once before timing.
        let mut cullers: Vec<Culler> = strategies.iter().map(|_| Culler::new()).collect();
        let (lo, hi) = scene_bounds(bounds);
        for (k, &s) in strategies.iter().enumerate() {
            let rig = StereoRig::from_head(head_path(0, args.seed, lo, hi), eyes);
            cullers[k].cull(s, &rig, 0, &bvh, &params)?;
        }
        for f in 0..args.frames {
            let rig = StereoRig::from_head(head_path(f, args.seed, lo, hi), eyes);
            let exact = if args.no_compare {
                None
            } else {
                Some(exact_per_eye(&rig, &bvh, &params)?)
            };
            exact_total += exact.as_ref().map_or(0, |e| e.len() as u64);
            // Rotate the order every frame so no strategy always runs on
            // caches warmed (or flushed) by the same predecessor.
            let m = strategies.len();
            for k in (0..m).map(|j| (j + f as usize) % m) {
                let s = strategies[k];
                let t = Instant::now();
                let out = cullers[k].cull(s, &rig, f, &bvh, &params)?;
                times[k].push(t.elapsed().as_secs_f64() * 1e3);
                tests[k] += out.stats.tests;
                visible[k] += out.visible.len() as u64;
                falls[k] += out.stats.fallbacks;
                if let Some(e) = &exact {
                    let (fp, fneg) = compare(&out.visible, e);
                    fps[k] += fp;
                    fns[k] += fneg;
                }
            }
        }
        let fr = args.frames as f64;
        let reports = strategies
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let mut t = times[k].clone();
                t.sort_by(f64::total_cmp);
                StrategyReport {
                    name: s.name().to_string(),
                    median_ms: percentile(&t, 0.5),
                    p95_ms: percentile(&t, 0.95),
                    tests_per_frame: tests[k] as f64 / fr,
                    visible: visible[k] as f64 / fr,
                    false_positives: fps[k] as f64 / fr,
                    false_negatives: fns[k] as f64 / fr,
                    false_negatives_total: fns[k],
                    fallbacks: falls[k],
                }
            })
            .collect();
        Ok(CullBenchReport {
            instances: bounds.len(),
            threads: args.threads,
            frames: args.frames,
            lens_half_angle: args.lens_half_angle,
            bvh_build_ms,
            bvh_nodes: bvh.node_count(),
            exact_visible: exact_total as f64 / fr,
            strategies: reports,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_orbit_path_stays_outside_and_looks_at_the_centre() {
        let (lo, hi) = (DVec3::new(-60.0, 0.0, -5.0), DVec3::new(60.0, 3.0, 150.0));
        let c = (lo + hi) * 0.5;
        for f in (0..2000).step_by(37) {
            let p = orbit_path(f, 3, lo, hi);
            let inside = p.position.cmpge(lo).all() && p.position.cmple(hi).all();
            assert!(!inside, "frame {f} at {:?}", p.position);
            let forward = p.orientation * DVec3::NEG_Z;
            let to_centre = (c - p.position).normalize();
            assert!(forward.dot(to_centre) > 0.9999, "frame {f}");
        }
    }
}
