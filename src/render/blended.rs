//! Blended primitives under `gpu-cull`. Transparent surfaces (glass,
//! visors) must be drawn after everything opaque and back to front, which
//! a GPU cull that appends instances in whatever order its threads run
//! does not give. So the GPU culls and draws the opaque and masked
//! primitives, and the CPU culls the instances that have blended
//! primitives — usually few — with the configuration's strategy over a
//! hierarchy of their boxes alone, sorts them back to front like the CPU
//! path ([`Batcher::build_blended`]) and draws them after the opaque
//! draws and the sky, reading their instance ids from the tail of the GPU
//! cull's visible buffer ([`crate::render::passes::gpu_cull::GpuCull::set_blended`]).

use super::batches::{Batcher, Batches};
use super::culling::CullState;
use crate::config::RenderConfig;
use crate::error::{Error, Result};
use crate::scene::Scene;
use std::collections::HashMap;

/// The blended instances and their culling.
pub struct GpuBlended {
    /// Instance index of each culled box.
    ids: Vec<u32>,
    /// Box index of each blended instance (for moves).
    box_of: HashMap<u32, u32>,
    /// The strategy over their boxes.
    cull: CullState,
    /// Ids the visible buffer's tail must hold: one per instance and
    /// blended primitive.
    capacity: u32,
    /// This frame's visible instances (scratch).
    visible: Vec<u32>,
}

impl GpuBlended {
    /// The blended instances of `scene` (None: it has none) culled with
    /// `config`'s strategy.
    pub fn new(config: &RenderConfig, scene: &Scene, batcher: &Batcher) -> Result<Option<Self>> {
        let blended = batcher.blended_instances();
        if blended.is_empty() {
            return Ok(None);
        }
        let strategy = config
            .culling
            .cull
            .strategy()
            .ok_or_else(|| Error::config("--opt", "gpu-cull needs a culling strategy"))?;
        let all = scene.world_aabbs();
        let bounds: Vec<_> = blended.iter().map(|&(i, _)| all[i as usize]).collect();
        let cull = CullState::over_boxes(strategy, config, &bounds)
            .map_err(|e| Error::scene(&scene.name, e))?;
        let capacity = blended.iter().map(|&(_, n)| n as u64).sum::<u64>();
        Ok(Some(GpuBlended {
            ids: blended.iter().map(|&(i, _)| i).collect(),
            box_of: blended
                .iter()
                .enumerate()
                .map(|(k, &(i, _))| (i, k as u32))
                .collect(),
            cull,
            capacity: u32::try_from(capacity).map_err(|_| {
                Error::scene(&scene.name, "too many blended instance-primitive pairs")
            })?,
            visible: Vec::new(),
        }))
    }

    /// Ids the visible buffer's tail must hold.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// This frame's blended draws of `rig` (frame number `frame`) into
    /// `out`, their first instance counted from `base`.
    pub fn batch(
        &mut self,
        rig: &crate::view::StereoRig,
        frame: u64,
        batcher: &mut Batcher,
        base: u32,
        out: &mut Batches,
    ) -> Result<()> {
        let (kept, _) = self.cull.cull(rig, frame)?;
        self.visible.clear();
        self.visible
            .extend(kept.iter().map(|&k| self.ids[k as usize]));
        batcher.build_blended(&self.visible, rig.head.position, base, out);
        Ok(())
    }

    /// Moves the blended ones among `moved` (instance index, new world
    /// box); the others are the GPU's.
    pub fn move_instances(&mut self, moved: &[(u32, (glam::DVec3, glam::DVec3))]) -> Result<()> {
        let mine: Vec<_> = moved
            .iter()
            .filter_map(|&(i, b)| self.box_of.get(&i).map(|&k| (k, b)))
            .collect();
        if mine.is_empty() {
            return Ok(());
        }
        self.cull.move_instances(&mine)
    }
}
