//! The GPU cull's static tables, made once from the scene: which
//! non-blended primitives each mesh draws (the blended ones are the CPU's:
//! `render::blended`), one indexed indirect draw command per primitive
//! and LOD level with its range of the visible buffer, and per command its
//! triangles, level and error.

use crate::error::{Error, Result};
use crate::render::batches::PipelineKey;
use crate::render::passes::PipelineSetup;
use crate::scene::Scene;
use ash::vk;

/// The tables.
pub(super) struct Table {
    /// Per mesh: its slice (first, count) of `flat`.
    pub slices: Vec<(u32, u32)>,
    /// The meshes' non-blended primitives, one after the other.
    pub flat: Vec<u32>,
    /// The draw command template: `phases` sets of one command per
    /// primitive and level, instance counts zero.
    pub commands: Vec<vk::DrawIndexedIndirectCommand>,
    /// Per primitive: index of its level-0 command.
    pub cmd_first: Vec<u32>,
    /// Per command: triangles, LOD level and object-space error.
    pub cmd_tris: Vec<u64>,
    pub cmd_level: Vec<u8>,
    pub cmd_error: Vec<f32>,
    /// Per primitive: its first command and level count (padded to uvec4).
    pub lod_info: Vec<u32>,
    /// Commands per set.
    pub n_cmds: usize,
    /// Instance-primitive pairs one set's ranges hold.
    pub total: u64,
}

impl Table {
    /// The tables of `scene` for `phases` command sets, with `order` the
    /// non-blended primitives in draw order and room for `blended` ids
    /// after the ranges (an error past what the cull addresses).
    pub fn new(
        setup: &PipelineSetup,
        scene: &Scene,
        order: &[u32],
        phases: usize,
        blended: u32,
    ) -> Result<Table> {
        let keys: &[PipelineKey] = setup.keys;
        let n_prims = scene.primitives.len();
        // Mesh slices into one flat list of their non-blended primitives
        // (the blended ones are culled and sorted on the CPU and drawn from
        // the visible buffer's tail: `blended`), and how many instances use
        // each primitive (the capacity of its visible range).
        let mut slices = Vec::with_capacity(scene.meshes.len());
        let mut flat: Vec<u32> = Vec::new();
        for m in &scene.meshes {
            let start = flat.len() as u32;
            flat.extend(m.primitives.iter().filter(|&&p| keys[p as usize].alpha < 2));
            slices.push((start, flat.len() as u32 - start));
        }
        let mut users = vec![0u64; n_prims];
        for inst in &scene.instances {
            let (start, n) = slices[inst.mesh as usize];
            for &p in &flat[start as usize..(start + n) as usize] {
                users[p as usize] += 1;
            }
        }
        // One draw command per primitive and LOD level (level 0 the
        // original); each level's visible range can hold every user.
        let lod_ranges = &setup.scene.lod_ranges;
        let levels = |p: usize| 1 + lod_ranges[p].len();
        let mut cmd_first = Vec::with_capacity(n_prims);
        let mut n_cmds = 0usize;
        for p in 0..n_prims {
            cmd_first.push(n_cmds as u32);
            n_cmds += levels(p);
        }
        let total: u64 = (0..n_prims).map(|p| users[p] * levels(p) as u64).sum();
        if total + blended as u64 > u32::MAX as u64 / 4 {
            return Err(Error::scene(
                &scene.name,
                format!("{total} instance-primitive pairs exceed what gpu-cull addresses"),
            ));
        }
        let ranges = &setup.scene.ranges;
        let mut commands = vec![vk::DrawIndexedIndirectCommand::default(); phases * n_cmds];
        let mut cmd_tris = vec![0u64; n_cmds];
        let mut cmd_level = vec![0u8; n_cmds];
        let mut cmd_error = vec![0f32; n_cmds];
        for p in 0..n_prims {
            let c = cmd_first[p] as usize;
            cmd_tris[c] = scene.primitives[p].triangles() as u64;
            for (j, (r, e)) in lod_ranges[p].iter().enumerate() {
                cmd_tris[c + 1 + j] = r.index_count as u64 / 3;
                cmd_level[c + 1 + j] = (j + 1) as u8;
                cmd_error[c + 1 + j] = *e;
            }
        }
        let mut base = 0u32;
        for &p in order {
            let p = p as usize;
            for j in 0..levels(p) {
                let r = if j == 0 {
                    ranges[p]
                } else {
                    lod_ranges[p][j - 1].0
                };
                commands[cmd_first[p] as usize + j] = vk::DrawIndexedIndirectCommand {
                    index_count: r.index_count,
                    instance_count: 0,
                    first_index: r.first_index,
                    vertex_offset: r.vertex_offset,
                    first_instance: base,
                };
                base += users[p] as u32;
            }
        }
        // The late commands draw from the late ranges, after the early ones.
        for c in 0..n_cmds * (phases - 1) {
            commands[n_cmds + c] = vk::DrawIndexedIndirectCommand {
                first_instance: commands[c].first_instance + total as u32,
                ..commands[c]
            };
        }
        let lod_info: Vec<u32> = (0..n_prims)
            .flat_map(|p| [cmd_first[p], levels(p) as u32, 0, 0])
            .collect();
        Ok(Table {
            slices,
            flat,
            commands,
            cmd_first,
            cmd_tris,
            cmd_level,
            cmd_error,
            lod_info,
            n_cmds,
            total,
        })
    }

    /// The command template as the GPU copies it (five words a command).
    pub fn words(&self) -> Vec<u32> {
        let mut words: Vec<u32> = Vec::with_capacity(self.commands.len() * 5);
        for c in &self.commands {
            words.extend_from_slice(&[
                c.index_count,
                c.instance_count,
                c.first_index,
                c.vertex_offset as u32,
                c.first_instance,
            ]);
        }
        words
    }
}
