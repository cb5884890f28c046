//! Stereo culling strategies over a bounding volume hierarchy. Pure math: the
//! input is a [`StereoRig`] (poses and FOV angles) and world-space instance
//! boxes; the output is the sorted list of visible instance indices and
//! statistics. Parallel work runs in the caller's current rayon pool.
//!
//! ```
//! use glam::DVec3;
//! use vergence::cull::{cull, Bvh, CullParams, Strategy, DEFAULT_LEAF_SIZE};
//! use vergence::view::{Fov, Pose, StereoRig};
//!
//! let bounds = vec![(DVec3::new(-1.0, -1.0, -6.0), DVec3::new(1.0, 1.0, -4.0))];
//! let eye = |x: f64| (Pose { position: DVec3::new(x, 0.0, 0.0), ..Pose::default() }, Fov::symmetric(0.9, 0.9));
//! let rig = StereoRig::from_head(Pose::default(), &[eye(-0.032), eye(0.032)]);
//! let bvh = Bvh::build(&bounds, DEFAULT_LEAF_SIZE).unwrap();
//! let out = cull(Strategy::Superfrustum, &rig, 0, &bvh, &CullParams::default()).unwrap();
//! assert_eq!(out.visible, vec![0]);
//! ```

pub mod bvh;
pub mod gpu;
pub mod hiz;
pub mod traverse;
pub mod volume;

use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;

use crate::view::cone::Cone;
use crate::view::frustum::{Frustum, PlaneSet, VolumeError};
use crate::view::superfrustum::Superfrustum;
use crate::view::StereoRig;

pub use bvh::{Bvh, BvhError};
use traverse::{brute, traverse, Marks};

/// Leaf size used by the bench and recommended for callers.
pub const DEFAULT_LEAF_SIZE: usize = 16;

/// A culling strategy, selectable by name (`--opt`, `--strategies`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Strategy {
    /// Baseline: each eye's frustum on the hierarchy, union of the results.
    PerEye,
    /// One combined frustum (Everitt) on the hierarchy; per-eye fallback.
    Superfrustum,
    /// Each eye's enclosing cone on the hierarchy, union.
    Conical,
    /// One cone enclosing both eye cones; per-eye cones fallback.
    ConicalSuperfrustum,
    /// One eye's frustum per frame, alternating (`frame_index % views`).
    RoundRobin,
    /// One eye's cone per frame, alternating.
    RoundRobinConical,
    /// Each eye's frustum against every instance, no hierarchy.
    PerEyeBrute,
}

impl Strategy {
    /// Every strategy, in report order.
    pub const ALL: [Strategy; 7] = [
        Strategy::PerEye,
        Strategy::Superfrustum,
        Strategy::Conical,
        Strategy::ConicalSuperfrustum,
        Strategy::RoundRobin,
        Strategy::RoundRobinConical,
        Strategy::PerEyeBrute,
    ];

    /// The strategy's command-line name.
    pub fn name(&self) -> &'static str {
        match self {
            Strategy::PerEye => "per-eye",
            Strategy::Superfrustum => "superfrustum",
            Strategy::Conical => "conical",
            Strategy::ConicalSuperfrustum => "conical-superfrustum",
            Strategy::RoundRobin => "round-robin",
            Strategy::RoundRobinConical => "round-robin-conical",
            Strategy::PerEyeBrute => "per-eye-brute",
        }
    }

    /// True when the strategy may miss instances exact per-eye culling keeps
    /// by design (the round-robin strategies). The conical strategies can
    /// miss too when `CullParams::lens_half_angle` narrows their cones.
    pub fn may_miss(&self) -> bool {
        matches!(self, Strategy::RoundRobin | Strategy::RoundRobinConical)
    }
}

impl fmt::Display for Strategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Strategy {
    type Err = CullError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Strategy::ALL
            .into_iter()
            .find(|st| st.name() == s.trim())
            .ok_or_else(|| CullError::UnknownStrategy(s.to_string()))
    }
}

/// Errors from culling.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CullError {
    /// Unknown strategy name.
    #[error(
        "unknown culling strategy '{0}' (expected one of per-eye, superfrustum, conical, conical-superfrustum, round-robin, round-robin-conical, per-eye-brute)"
    )]
    UnknownStrategy(String),
    /// The rig has no views.
    #[error("the rig has no views")]
    NoViews,
    /// A view volume could not be built (invalid pose, FOV or distances);
    /// nothing was culled.
    #[error("view {view}: {source}")]
    Volume {
        /// Index of the offending view.
        view: usize,
        /// What was wrong.
        source: VolumeError,
    },
}

/// Parameters shared by all strategies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CullParams {
    /// Near plane distance in metres (> 0).
    pub near: f64,
    /// Draw distance: a far plane at this depth along each eye's view axis;
    /// `None` culls nothing by distance.
    pub draw_distance: Option<f64>,
    /// Half-angle of the lens-visible circle for the conical strategies;
    /// `None` uses the cone enclosing the FOV rectangle. A lens circle can
    /// miss what the rectangle keeps; such misses show as false negatives.
    pub lens_half_angle: Option<f64>,
    /// Also compute exact per-eye culling and count false positives and
    /// false negatives (slow; for tests and reports).
    pub compare_exact: bool,
}

impl Default for CullParams {
    fn default() -> Self {
        CullParams {
            near: 0.05,
            draw_distance: None,
            lens_half_angle: None,
            compare_exact: false,
        }
    }
}

/// Counters of one cull.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CullStats {
    /// Volume tests performed (hierarchy nodes plus instances; per volume).
    pub tests: u64,
    /// Instances kept.
    pub accepted: u64,
    /// Instances rejected.
    pub rejected: u64,
    /// 1 when a combined volume was impossible and per-eye volumes were
    /// used instead, else 0 (sums over frames in reports).
    pub fallbacks: u64,
    /// Kept instances that exact per-eye culling rejects (when compared).
    pub false_positives: Option<u64>,
    /// Rejected instances that exact per-eye culling keeps (when compared).
    pub false_negatives: Option<u64>,
}

/// Result of one cull.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CullOutput {
    /// Visible instance indices, ascending.
    pub visible: Vec<u32>,
    /// Counters.
    pub stats: CullStats,
}

/// The volumes one strategy tests for one frame.
enum Volumes {
    Planes(Vec<PlaneSet>),
    Cones(Vec<Cone>),
}

fn eye_frusta(rig: &StereoRig, p: &CullParams) -> Result<Vec<Frustum>, CullError> {
    if rig.views.is_empty() {
        return Err(CullError::NoViews);
    }
    rig.views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            Frustum::from_view(v, p.near, p.draw_distance)
                .map_err(|e| CullError::Volume { view: i, source: e })
        })
        .collect()
}

fn eye_cones(rig: &StereoRig, p: &CullParams) -> Result<Vec<Cone>, CullError> {
    rig.views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            match p.lens_half_angle {
                Some(a) => Cone::from_lens(v, a, p.draw_distance),
                None => Cone::from_view(v, p.draw_distance),
            }
            .map_err(|e| CullError::Volume { view: i, source: e })
        })
        .collect()
}

/// Builds the volumes of `strategy` for this frame; the bool is true when a
/// combined volume was impossible and per-eye volumes replace it.
fn volumes(
    strategy: Strategy,
    rig: &StereoRig,
    frame: u64,
    p: &CullParams,
) -> Result<(Volumes, bool), CullError> {
    // Frusta are always built: they validate every pose, FOV and distance,
    // so invalid input fails the same way for every strategy.
    let frusta = eye_frusta(rig, p)?;
    let pick = (frame % frusta.len() as u64) as usize;
    let planes = |fs: &[Frustum]| Volumes::Planes(fs.iter().map(|f| f.planes).collect());
    Ok(match strategy {
        Strategy::PerEye | Strategy::PerEyeBrute => (planes(&frusta), false),
        Strategy::RoundRobin => (planes(&frusta[pick..=pick]), false),
        Strategy::Superfrustum => match Superfrustum::enclosing(&frusta) {
            Ok(sf) => (Volumes::Planes(vec![sf.planes]), false),
            Err(_) => (planes(&frusta), true),
        },
        Strategy::Conical => (Volumes::Cones(eye_cones(rig, p)?), false),
        Strategy::RoundRobinConical => (Volumes::Cones(vec![eye_cones(rig, p)?[pick]]), false),
        Strategy::ConicalSuperfrustum => {
            let cones = eye_cones(rig, p)?;
            match Cone::enclosing(&cones) {
                Ok(c) => (Volumes::Cones(vec![c]), false),
                Err(_) => (Volumes::Cones(cones), true),
            }
        }
    })
}

fn hierarchy<V: volume::Volume>(bvh: &Bvh, vols: &[V], marks: &Marks) -> u64 {
    vols.iter().map(|v| traverse(bvh, v, marks)).sum()
}

/// Per-frame culling context: owns the visibility bitset and the output
/// list, reused from frame to frame so a frame allocates nothing once the
/// buffers have grown (DESIGN rule 2). One per render thread.
#[derive(Debug, Default)]
pub struct Culler {
    marks: Marks,
    out: CullOutput,
}

impl Culler {
    /// An empty context; buffers grow on first use.
    pub fn new() -> Culler {
        Culler::default()
    }

    /// The output of the last cull (empty before the first).
    pub fn last(&self) -> &CullOutput {
        &self.out
    }

    /// Culls `bvh` for one frame with `strategy` and returns the result,
    /// valid until the next call. `frame_index` picks the eye of the
    /// round-robin strategies. `PerEyeBrute` ignores the hierarchy and scans
    /// every instance. Invalid poses, FOVs or distances return an error and
    /// cull nothing. Runs in the current rayon pool.
    pub fn cull(
        &mut self,
        strategy: Strategy,
        rig: &StereoRig,
        frame_index: u64,
        bvh: &Bvh,
        params: &CullParams,
    ) -> Result<&CullOutput, CullError> {
        self.run(
            strategy,
            rig,
            frame_index,
            bvh,
            params,
            strategy == Strategy::PerEyeBrute,
        )
    }

    /// Like [`Culler::cull`] but testing every instance without the
    /// hierarchy, with the same volumes: the reference the hierarchy must
    /// match exactly.
    pub fn cull_flat(
        &mut self,
        strategy: Strategy,
        rig: &StereoRig,
        frame_index: u64,
        bvh: &Bvh,
        params: &CullParams,
    ) -> Result<&CullOutput, CullError> {
        self.run(strategy, rig, frame_index, bvh, params, true)
    }

    fn run(
        &mut self,
        strategy: Strategy,
        rig: &StereoRig,
        frame: u64,
        bvh: &Bvh,
        p: &CullParams,
        flat: bool,
    ) -> Result<&CullOutput, CullError> {
        let (vols, fallback) = volumes(strategy, rig, frame, p)?;
        self.marks.reset(bvh.len());
        let tests = match (&vols, flat) {
            (Volumes::Planes(v), false) => hierarchy(bvh, v, &self.marks),
            (Volumes::Cones(v), false) => hierarchy(bvh, v, &self.marks),
            (Volumes::Planes(v), true) => brute(bvh, v, &self.marks),
            (Volumes::Cones(v), true) => brute(bvh, v, &self.marks),
        };
        self.marks.extract_into(&mut self.out.visible);
        let visible = &self.out.visible;
        let mut stats = CullStats {
            tests,
            accepted: visible.len() as u64,
            rejected: (bvh.len() - visible.len()) as u64,
            fallbacks: u64::from(fallback),
            false_positives: None,
            false_negatives: None,
        };
        if p.compare_exact {
            let exact = exact_per_eye(rig, bvh, p)?;
            let (fp, fneg) = compare(visible, &exact);
            stats.false_positives = Some(fp);
            stats.false_negatives = Some(fneg);
        }
        self.out.stats = stats;
        Ok(&self.out)
    }
}

/// One-shot [`Culler::cull`] (allocates its buffers; renderers should keep
/// a [`Culler`]).
pub fn cull(
    strategy: Strategy,
    rig: &StereoRig,
    frame_index: u64,
    bvh: &Bvh,
    params: &CullParams,
) -> Result<CullOutput, CullError> {
    let mut c = Culler::new();
    c.cull(strategy, rig, frame_index, bvh, params)?;
    Ok(c.out)
}

/// One-shot [`Culler::cull_flat`].
pub fn cull_flat(
    strategy: Strategy,
    rig: &StereoRig,
    frame_index: u64,
    bvh: &Bvh,
    params: &CullParams,
) -> Result<CullOutput, CullError> {
    let mut c = Culler::new();
    c.cull_flat(strategy, rig, frame_index, bvh, params)?;
    Ok(c.out)
}

/// Exact per-eye culling, the ground truth for false positives and
/// negatives: instance `i` is kept when its box intersects some eye's
/// frustum (near plane, optional draw distance), decided by the separating
/// axis test of [`Frustum::intersects_box_exact`]. Parallel, no hierarchy.
pub fn exact_per_eye(
    rig: &StereoRig,
    bvh: &Bvh,
    params: &CullParams,
) -> Result<Vec<u32>, CullError> {
    let frusta = eye_frusta(rig, params)?;
    let inst = &bvh.instances;
    let kept: Vec<u32> = (0..bvh.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&i| {
            let (a, b) = inst.get(i);
            frusta.iter().any(|f| {
                // Any depth beyond the box's farthest corner keeps the exact
                // answer of the unbounded frustum.
                let far = (a - f.apex()).abs().max((b - f.apex()).abs()).length() * 2.0 + 1.0;
                f.intersects_box_exact(a, b, far)
            })
        })
        .map(|i| i as u32)
        .collect();
    Ok(kept)
}

/// Counts (false positives, false negatives) of sorted `visible` against
/// sorted `exact`.
pub fn compare(visible: &[u32], exact: &[u32]) -> (u64, u64) {
    let (mut i, mut j, mut fp, mut fneg) = (0, 0, 0u64, 0u64);
    while i < visible.len() && j < exact.len() {
        match visible[i].cmp(&exact[j]) {
            std::cmp::Ordering::Less => {
                fp += 1;
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                fneg += 1;
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    fp += (visible.len() - i) as u64;
    fneg += (exact.len() - j) as u64;
    (fp, fneg)
}
