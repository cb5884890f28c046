//! Culling as the frame loops use it: the configuration's strategy over a
//! BVH of the scene's instance bounds, with errors in the application's
//! terms.

use crate::config::RenderConfig;
use crate::cull::{Bvh, CullParams, CullStats, Culler, Strategy, DEFAULT_LEAF_SIZE};
use crate::error::{Error, Result};
use crate::interact::section::SectionPlane;
use crate::scene::Scene;
use std::time::Instant;

/// Culling for `render` and `run`: the strategy from the configuration over a BVH of
/// the scene's instance bounds.
pub struct CullState {
    strategy: Strategy,
    bvh: Bvh,
    culler: Culler,
    params: CullParams,
    /// The section plane: instances wholly beyond it are dropped after
    /// the strategy's cull.
    section: Option<SectionPlane>,
    /// The visible list after the section plane.
    kept: Vec<u32>,
    /// Milliseconds the BVH build took.
    pub build_ms: f64,
}

impl CullState {
    /// The culling `config` asks for over `scene` (None: `cull = "none"`).
    pub fn new(config: &RenderConfig, scene: &Scene) -> Result<Option<CullState>> {
        let Some(strategy) = config.culling.cull.strategy() else {
            return Ok(None);
        };
        // With gpu-cull the renderer's compute pass culls every frame.
        if config.culling.gpu_cull {
            return Ok(None);
        }
        let made = Self::over_boxes(strategy, config, &scene.world_aabbs())
            .map_err(|e| Error::scene(&scene.name, e))?;
        Ok(Some(CullState {
            section: config.frame.section.map(plane_of),
            ..made
        }))
    }

    /// `strategy` over the boxes `bounds` (world min, max; the culled
    /// indices are theirs), with `config`'s near plane and draw distance
    /// and no section plane; the error is the hierarchy's.
    pub fn over_boxes(
        strategy: Strategy,
        config: &RenderConfig,
        bounds: &[(glam::DVec3, glam::DVec3)],
    ) -> std::result::Result<CullState, String> {
        let t = Instant::now();
        let bvh = Bvh::build(bounds, DEFAULT_LEAF_SIZE).map_err(|e| e.to_string())?;
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        let params = CullParams {
            near: config.frame.near,
            draw_distance: config.culling.draw_distance,
            ..CullParams::default()
        };
        Ok(CullState {
            strategy,
            bvh,
            culler: Culler::new(),
            params,
            section: None,
            kept: Vec::new(),
            build_ms,
        })
    }

    /// Sets the section plane the following culls apply (None: none).
    pub fn set_section(&mut self, plane: Option<SectionPlane>) {
        self.section = plane;
    }

    /// Moves the instances in `moved` (instance index, new world box): the
    /// following culls test them where they now are.
    pub fn move_instances(&mut self, moved: &[(u32, (glam::DVec3, glam::DVec3))]) -> Result<()> {
        self.bvh
            .update(moved)
            .map_err(|e| Error::config("scene motion", e.to_string()))
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
        let Some(plane) = self.section else {
            return Ok((&out.visible, out.stats));
        };
        // Each kept instance's box against the plane: one more test each.
        let mut stats = out.stats;
        let inst = &self.bvh.instances;
        self.kept.clear();
        self.kept.extend(out.visible.iter().copied().filter(|&i| {
            let (lo, hi) = inst.get(i as usize);
            !plane.culls_box(lo, hi)
        }));
        let dropped = (out.visible.len() - self.kept.len()) as u64;
        stats.tests += out.visible.len() as u64;
        stats.accepted -= dropped;
        stats.rejected += dropped;
        Ok((&self.kept, stats))
    }

    /// False positives and false negatives of this strategy's cull (without
    /// the section plane) of
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

/// The section plane of a configuration's (n.x, n.y, n.z, d).
pub fn plane_of(p: [f64; 4]) -> SectionPlane {
    SectionPlane {
        normal: glam::DVec3::new(p[0], p[1], p[2]),
        d: p[3],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{shapes, Instance, Material, Mesh, Scene};
    use crate::view::{Fov, Pose, StereoRig};
    use glam::{DAffine3, DVec3};

    /// Twenty unit boxes in a row down −Z, 1 m apart, in front of a head at
    /// the origin.
    fn row() -> Scene {
        let mut scene = Scene::default();
        scene.materials.push(Material::default());
        scene.primitives.push(shapes::cuboid([0.5, 0.5, 0.5], 0));
        scene.meshes.push(Mesh {
            name: "box".into(),
            primitives: vec![0],
        });
        for i in 0..20 {
            scene.instances.push(Instance {
                mesh: 0,
                transform: DAffine3::from_translation(DVec3::new(0.0, 0.0, -3.0 - i as f64)),
            });
        }
        scene
    }

    #[test]
    fn instances_wholly_beyond_the_section_plane_are_culled() {
        let scene = row();
        let config = RenderConfig {
            culling: crate::config::CullingConfig {
                cull: "per-eye".parse().unwrap(),
                ..Default::default()
            },
            ..RenderConfig::default()
        };
        let mut state = CullState::new(&config, &scene)
            .unwrap()
            .expect("a strategy");
        let eye = |x: f64| {
            (
                Pose {
                    position: DVec3::new(x, 0.0, 0.0),
                    ..Pose::default()
                },
                Fov::symmetric(0.8, 0.8),
            )
        };
        let rig = StereoRig::from_head(Pose::default(), &[eye(-0.03), eye(0.03)]);
        let (all, s0) = state.cull(&rig, 0).unwrap();
        let all = all.to_vec();
        assert_eq!(all.len(), 20, "every box is in view");
        // Cut away what lies beyond z = −10.2: boxes centred at −3 … −22
        // with half-size 0.5 start beyond it from the one centred at −11
        // (its near face at −10.5), while the one at −10 straddles it.
        let plane = SectionPlane::through(DVec3::new(0.0, 0.0, -10.2), DVec3::NEG_Z).unwrap();
        state.set_section(Some(plane));
        let (kept, s1) = state.cull(&rig, 1).unwrap();
        let expect: Vec<u32> = all
            .iter()
            .copied()
            .filter(|&i| scene.instances[i as usize].transform.translation.z > -10.6)
            .collect();
        assert_eq!(kept, expect.as_slice());
        assert_eq!(kept.len(), 8, "z = −3 … −10");
        assert_eq!(s1.accepted, 8);
        assert_eq!(s1.rejected, s0.rejected + 12);
        state.set_section(None);
        assert_eq!(state.cull(&rig, 2).unwrap().0.len(), 20);
    }
}
