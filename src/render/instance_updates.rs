//! Moving instances on the GPU: only what moved is uploaded. The frame's
//! moved instances are staged as records (the vertex shader's
//! `InstanceData`, and with `gpu-cull` the cull's instance box) in the
//! frame slot's host-visible buffer, and copied into the resident
//! device-local buffers at the start of the frame's command buffer, runs
//! of consecutive instances as one copy region each.
//!
//! Ordering: the copy waits for every earlier vertex and compute stage
//! (the frames still in flight read the same resident buffers; a pipeline
//! barrier's first scope covers all commands submitted before it on the
//! queue) and the frame's own cull and draws wait for the copy.

use crate::error::{Error, Result};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc};
use crate::gpu::ring::{FrameRing, Garbage};
use crate::gpu::Context;
use crate::render::scene_gpu::instance_record;
use crate::scene::motion::Moved;
use crate::scene::WorldBounds;
use ash::vk;
use gpu_allocator::MemoryLocation;
use rayon::prelude::*;

/// Floats of one vertex-shader instance record (`InstanceData`).
pub const INSTANCE_FLOATS: usize = 16;
/// Floats of one cull instance box.
pub const BOX_FLOATS: usize = 12;

/// One resident buffer's staged records: destination offsets and data.
#[derive(Default)]
struct Stream {
    /// Record index in the destination buffer, per staged record.
    at: Vec<u32>,
    /// The records, back to back.
    data: Vec<f32>,
}

impl Stream {
    /// Appends `n` records `floats` wide for the instances `index(i)`,
    /// record `i` filled by `fill(i, out)` in parallel.
    fn push(
        &mut self,
        n: usize,
        floats: usize,
        index: impl Fn(usize) -> u32,
        fill: impl Fn(usize, &mut [f32]) + Sync,
    ) {
        self.at.extend((0..n).map(index));
        let start = self.data.len();
        self.data.resize(start + n * floats, 0.0);
        self.data[start..]
            .par_chunks_mut(floats)
            .enumerate()
            .with_min_len(256)
            .for_each(|(i, out)| fill(i, out));
    }

    fn clear(&mut self) {
        self.at.clear();
        self.data.clear();
    }

    /// Copy regions for `floats`-wide records staged at byte `base` of the
    /// staging buffer, consecutive destinations merged.
    fn regions(&self, floats: usize, base: u64) -> Vec<vk::BufferCopy> {
        let size = (floats * 4) as u64;
        let mut out: Vec<vk::BufferCopy> = Vec::new();
        for (k, &at) in self.at.iter().enumerate() {
            let src = base + k as u64 * size;
            let dst = at as u64 * size;
            match out.last_mut() {
                Some(r) if r.src_offset + r.size == src && r.dst_offset + r.size == dst => {
                    r.size += size
                }
                _ => out.push(vk::BufferCopy {
                    src_offset: src,
                    dst_offset: dst,
                    size,
                }),
            }
        }
        out
    }
}

/// Makes a moved instance's cull box record from its transform and world
/// bounds.
pub type BoxRecord<'a> = dyn Fn(&Moved, &WorldBounds) -> [f32; BOX_FLOATS] + Sync + 'a;

/// The per-slot staging of moved instances.
pub struct InstanceUpdates {
    staging: Vec<Option<Buffer>>,
    instances: Stream,
    boxes: Stream,
}

/// What one frame's update copied.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct UpdateStats {
    /// Instances whose records were copied.
    pub moved: u64,
    /// Bytes copied into the resident buffers.
    pub upload_bytes: u64,
    /// Copy regions (runs of consecutive instances).
    pub regions: u64,
}

impl InstanceUpdates {
    /// Staging for `slots` frame slots (allocated on first use).
    pub fn new(slots: usize) -> InstanceUpdates {
        InstanceUpdates {
            staging: (0..slots).map(|_| None).collect(),
            instances: Stream::default(),
            boxes: Stream::default(),
        }
    }

    /// Stages the records of `moved` (world bounds in `bounds`, one per
    /// entry): each one's vertex-shader record, and with `boxes` its cull
    /// box as that function makes it. Built in parallel.
    pub fn stage(
        &mut self,
        moved: &[Moved],
        bounds: &[WorldBounds],
        boxes: Option<&BoxRecord<'_>>,
    ) {
        // One frame's motion replaces what an earlier, failed frame left
        // staged (the same instances twice would overlap copy regions).
        self.clear();
        let n = moved.len().min(bounds.len());
        let index = |i: usize| moved[i].index;
        self.instances.push(n, INSTANCE_FLOATS, index, |i, out| {
            out.copy_from_slice(&instance_record(&moved[i].transform))
        });
        if let Some(f) = boxes {
            self.boxes.push(n, BOX_FLOATS, index, |i, out| {
                out.copy_from_slice(&f(&moved[i], &bounds[i]))
            });
        }
    }

    /// Drops what is staged.
    pub fn clear(&mut self) {
        self.instances.clear();
        self.boxes.clear();
    }

    /// Whether anything is staged.
    pub fn is_empty(&self) -> bool {
        self.instances.at.is_empty() && self.boxes.at.is_empty()
    }

    /// Writes the staged records into `slot`'s staging buffer (grown when
    /// too small, the old one handed to `ring` until its frames are done)
    /// and records their copies into `instances` (and `boxes`) on `cmd`.
    /// The slot's previous frame must be done. Clears the staging lists.
    pub fn record(
        &mut self,
        ctx: &Context,
        ring: &mut FrameRing,
        slot: usize,
        cmd: vk::CommandBuffer,
        instances: vk::Buffer,
        boxes: Option<vk::Buffer>,
    ) -> Result<UpdateStats> {
        if self.is_empty() {
            return Ok(UpdateStats::default());
        }
        if boxes.is_none() {
            self.boxes.clear();
        }
        let inst_bytes = (self.instances.data.len() * 4) as u64;
        let need = inst_bytes + (self.boxes.data.len() * 4) as u64;
        if self.staging[slot].as_ref().is_none_or(|b| b.size < need) {
            let buffer = Buffer::new(
                ctx,
                &BufferDesc {
                    name: "moved instances",
                    size: need.next_power_of_two().max(4096),
                    usage: vk::BufferUsageFlags::TRANSFER_SRC,
                    location: MemoryLocation::CpuToGpu,
                    category: "per-frame",
                },
            )?;
            if let Some(old) = self.staging[slot].replace(buffer) {
                ring.defer(Garbage::Buffer(old));
            }
        }
        let staging = self.staging[slot].as_mut().expect("allocated above");
        staging.write(0, as_bytes(&self.instances.data))?;
        staging.write(inst_bytes as usize, as_bytes(&self.boxes.data))?;
        let src = staging.buffer;
        let inst_regions = self.instances.regions(INSTANCE_FLOATS, 0);
        let box_regions = self.boxes.regions(BOX_FLOATS, inst_bytes);
        let before = [vk::MemoryBarrier2::default()
            .src_stage_mask(
                vk::PipelineStageFlags2::VERTEX_SHADER | vk::PipelineStageFlags2::COMPUTE_SHADER,
            )
            .dst_stage_mask(vk::PipelineStageFlags2::COPY)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)];
        let after = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(
                vk::PipelineStageFlags2::VERTEX_SHADER | vk::PipelineStageFlags2::COMPUTE_SHADER,
            )
            .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ)];
        let d = &ctx.device;
        // SAFETY: `cmd` is recording outside a render pass; the buffers are
        // alive and the regions lie within them (records were staged for
        // instance indices of the scene the resident buffers hold).
        unsafe {
            d.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&before));
            if !inst_regions.is_empty() {
                d.cmd_copy_buffer(cmd, src, instances, &inst_regions);
            }
            if let (Some(dst), false) = (boxes, box_regions.is_empty()) {
                d.cmd_copy_buffer(cmd, src, dst, &box_regions);
            }
            d.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&after));
        }
        let stats = UpdateStats {
            moved: self.instances.at.len().max(self.boxes.at.len()) as u64,
            upload_bytes: need,
            regions: (inst_regions.len() + box_regions.len()) as u64,
        };
        self.instances.clear();
        self.boxes.clear();
        Ok(stats)
    }

    /// Destroys the staging buffers; the device must be idle.
    pub fn destroy(&mut self, ctx: &Context) {
        for b in self.staging.iter_mut().filter_map(Option::take) {
            b.destroy(ctx);
        }
    }
}

/// Checks that instance `index` lies within a scene of `count` instances.
pub fn check_index(index: u32, count: usize) -> Result<()> {
    if (index as usize) < count {
        Ok(())
    } else {
        Err(Error::config(
            "scene motion",
            format!("moved instance {index} is not in the scene ({count} instances)"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn consecutive_records_share_one_region() {
        let mut s = Stream::default();
        for i in [3u32, 4, 5, 9, 10, 2] {
            s.at.push(i);
            s.data.extend_from_slice(&[0.0; 4]);
        }
        let r = s.regions(4, 100);
        let got: Vec<(u64, u64, u64)> = r
            .iter()
            .map(|r| (r.src_offset, r.dst_offset, r.size))
            .collect();
        assert_eq!(
            got,
            [(100, 48, 48), (148, 144, 32), (180, 32, 16)],
            "runs 3–5 and 9–10 merge; 2 stands alone"
        );
    }
}
