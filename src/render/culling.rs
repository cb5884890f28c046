//! Culling as the frame loops use it: the configuration's strategy over a
//! BVH of the scene's instance bounds, with errors in the application's
//! terms.

use crate::config::RenderConfig;
use crate::cull::{Bvh, CullParams, CullStats, Culler, Strategy, DEFAULT_LEAF_SIZE};
use crate::error::{Error, Result};
use crate::scene::Scene;
use std::time::Instant;

/// Culling for `render` and `run`: the strategy from the configuration over a BVH of
/// the scene's instance bounds.
pub struct CullState {
    strategy: Strategy,
    bvh: Bvh,
    culler: Culler,
    params: CullParams,
    /// Milliseconds the BVH build took.
    pub build_ms: f64,
}

impl CullState {
    /// The culling `config` asks for over `scene` (None: `cull = "none"`).
    pub fn new(config: &RenderConfig, scene: &Scene) -> Result<Option<CullState>> {
        let Some(strategy) = config.cull.strategy() else {
            return Ok(None);
        };
        // With gpu-cull the renderer's compute pass culls every frame.
        if config.gpu_cull {
            return Ok(None);
        }
        let t = Instant::now();
        let bvh = Bvh::build(&scene.world_aabbs(), DEFAULT_LEAF_SIZE)
            .map_err(|e| Error::scene(&scene.name, e.to_string()))?;
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        let params = CullParams {
            near: config.near,
            draw_distance: config.draw_distance,
            ..CullParams::default()
        };
        Ok(Some(CullState {
            strategy,
            bvh,
            culler: Culler::new(),
            params,
            build_ms,
        }))
    }

    /// Culls for `rig` at frame number `frame`: the visible instance list
    /// and the counters.
    pub fn cull(
        &mut self,
        rig: &crate::view::StereoRig,
        frame: u64,
    ) -> Result<(&[u32], CullStats)> {
        let out = self
            .culler
            .cull(self.strategy, rig, frame, &self.bvh, &self.params)
            .map_err(|e| Error::config("view for culling", e.to_string()))?;
        Ok((&out.visible, out.stats))
    }

    /// False positives and false negatives of this strategy's cull of
    /// `rig` at frame number `frame` against exact per-eye culling: the
    /// cull is replayed with its own buffers (culling depends only on the
    /// rig and the frame number), so the ground truth can be taken after a
    /// timed loop instead of inside it.
    pub fn replay_accuracy(&self, rig: &crate::view::StereoRig, frame: u64) -> Result<(u64, u64)> {
        let mut culler = Culler::new();
        let out = culler
            .cull(self.strategy, rig, frame, &self.bvh, &self.params)
            .map_err(|e| Error::config("view for culling", e.to_string()))?;
        let mut visible = out.visible.clone();
        visible.sort_unstable();
        let exact = crate::cull::exact_per_eye(rig, &self.bvh, &self.params)
            .map_err(|e| Error::config("view for culling", e.to_string()))?;
        Ok(crate::cull::compare(&visible, &exact))
    }
}
