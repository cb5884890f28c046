//! Point clouds rasterized in compute (`shaders/points_raster.comp`, after
//! Schütz et al. 2021): before the forward scopes, `points-raster` clears
//! the frame slot's key buffer (one 64-bit key per pixel per view), then one
//! thread per point projects it into every view and keeps, per pixel, the
//! nearest point's depth and colour with a 64-bit atomic max. Inside each
//! forward scope, before the meshes, a full-screen draw
//! (`shaders/points_composite.frag`) writes every keyed pixel's colour and
//! depth, so the depth test composites points and meshes. The points live
//! on the GPU as one vec4 each: the offset from the cloud's origin and the
//! sRGB colour's bits; the origin's offset from the render origin (f64 on
//! the CPU, then f32) comes as a push constant, so a survey-coordinate
//! cloud renders without jitter.

use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::{Error, Result};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets, GraphicsPipelineDesc};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::scene::points::PointCloud;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// The distance, metres, at which a point has `--opt point-size`'s size;
/// farther points shrink as 1 / distance (to one pixel).
pub const POINT_SIZE_DISTANCE_M: f32 = 2.0;

/// Threads per workgroup of the rasterizer.
const GROUP: u64 = 256;
/// Workgroups per dispatch row (the rest go to further rows).
const ROW: u64 = 65_535;

/// One frame slot's buffers.
struct Slot {
    keys: Buffer,
    drawn: Buffer,
    /// The frame's point ranges: (first thread, first point) per node.
    ranges: Buffer,
}

/// The point buffer, the per-slot keys and counters, the rasterizer and
/// the composite.
pub struct PointsPass {
    /// The points, [`PointsPass::per_buffer`] per buffer.
    points: Vec<Buffer>,
    per_buffer: u64,
    count: u64,
    /// The cloud's octree (None: every point every frame).
    octree: Option<crate::scene::octree::Octree>,
    origin: glam::DVec3,
    /// This frame's selection: ranges written and points to draw.
    ranges: u32,
    selected: u64,
    /// Side of a point at [`POINT_SIZE_DISTANCE_M`], pixels.
    point_size: f32,
    extent: vk::Extent2D,
    slots: Vec<Slot>,
    sets: DescriptorSets,
    raster: vk::Pipeline,
    composite: vk::Pipeline,
}

impl PointsPass {
    /// Uploads `cloud` and builds the pass for eyes of `extent` with one
    /// set per frame uniform buffer in `frames`; one error when the device
    /// lacks 64-bit buffer atomics. On failure, destroys what it made.
    pub fn new(
        setup: &PipelineSetup,
        cloud: &PointCloud,
        extent: vk::Extent2D,
        frames: &[Buffer],
        point_size: f32,
    ) -> Result<PointsPass> {
        let ctx = setup.ctx;
        if !ctx.caps.atomic_int64 {
            return Err(Error::Gpu(format!(
                "{} offers no 64-bit buffer atomics (shaderInt64 and shaderBufferInt64Atomics, VK_KHR_shader_atomic_int64), which vergence's point rasterizer needs; a scene with a point cloud cannot render on it",
                ctx.device_name
            )));
        }
        let per_buffer = points_per_buffer(ctx);
        let need = (cloud.len() as u64).div_ceil(per_buffer);
        if need > MAX_BUFFERS as u64 {
            return Err(Error::Gpu(format!(
                "{} points need {need} buffers of {per_buffer} (maxStorageBufferRange {} bytes); vergence binds at most {MAX_BUFFERS}",
                cloud.len(),
                ctx.caps.max_storage_buffer_range
            )));
        }
        let points = upload_points(ctx, cloud, per_buffer)?;
        let mut made = PointsPass {
            points,
            per_buffer,
            count: cloud.len() as u64,
            octree: cloud.octree.clone(),
            origin: cloud.origin,
            ranges: 1,
            selected: cloud.len() as u64,
            point_size,
            extent,
            slots: Vec::new(),
            sets: DescriptorSets {
                set_layout: vk::DescriptorSetLayout::null(),
                layout: vk::PipelineLayout::null(),
                pool: vk::DescriptorPool::null(),
                sets: Vec::new(),
            },
            raster: vk::Pipeline::null(),
            composite: vk::Pipeline::null(),
        };
        match made.build(setup, frames) {
            Ok(()) => Ok(made),
            Err(e) => {
                made.destroy(ctx);
                Err(e)
            }
        }
    }

    fn build(&mut self, setup: &PipelineSetup, frames: &[Buffer]) -> Result<()> {
        let ctx = setup.ctx;
        let pixels = 2 * self.extent.width as u64 * self.extent.height as u64;
        for i in 0..frames.len() {
            let keys = Buffer::new(
                ctx,
                &BufferDesc {
                    name: &format!("point keys {i}"),
                    size: 8 * pixels.max(1),
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_DST,
                    location: MemoryLocation::GpuOnly,
                    category: "per-frame",
                },
            )?;
            let small = |name: String, size: u64, location| {
                Buffer::new(
                    ctx,
                    &BufferDesc {
                        name: &name,
                        size,
                        usage: vk::BufferUsageFlags::STORAGE_BUFFER
                            | vk::BufferUsageFlags::TRANSFER_DST,
                        location,
                        category: "per-frame",
                    },
                )
            };
            let nodes = self.octree.as_ref().map_or(1, |t| t.nodes.len().max(1)) as u64;
            let made =
                small(format!("points drawn {i}"), 4, MemoryLocation::GpuToCpu).and_then(|drawn| {
                    match small(
                        format!("point ranges {i}"),
                        8 * nodes,
                        MemoryLocation::CpuToGpu,
                    ) {
                        Ok(ranges) => Ok((drawn, ranges)),
                        Err(e) => {
                            drawn.destroy(ctx);
                            Err(e)
                        }
                    }
                });
            let (drawn, mut ranges) = match made {
                Ok(b) => b,
                Err(e) => {
                    keys.destroy(ctx);
                    return Err(e);
                }
            };
            // Without an octree the one range is every point.
            if let Err(e) = ranges.write(0, as_bytes(&[0u32, 0u32])) {
                for b in [keys, drawn, ranges] {
                    b.destroy(ctx);
                }
                return Err(e);
            }
            self.slots.push(Slot {
                keys,
                drawn,
                ranges,
            });
        }
        let (uniform, storage) = (
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
        );
        let compute = vk::ShaderStageFlags::COMPUTE;
        let bindings = [
            (uniform, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
            (storage, 1, compute),
        ];
        self.sets = DescriptorSets::new(ctx, &bindings, compute, 48, frames.len(), "points")?;
        for ((slot, &set), frame) in self.slots.iter().zip(&self.sets.sets).zip(frames) {
            let info = |b: &Buffer| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.buffer)
                    .range(vk::WHOLE_SIZE)]
            };
            // Unused point bindings repeat the first buffer.
            let part = |k: usize| info(self.points.get(k).unwrap_or(&self.points[0]));
            let infos = [
                info(frame),
                part(0),
                info(&slot.keys),
                info(&slot.drawn),
                info(&slot.ranges),
                part(1),
                part(2),
                part(3),
                part(4),
            ];
            let writes: Vec<vk::WriteDescriptorSet> = infos
                .iter()
                .enumerate()
                .map(|(b, i)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding(b as u32)
                        .descriptor_type(if b == 0 { uniform } else { storage })
                        .buffer_info(i)
                })
                .collect();
            // SAFETY: the set is new and every buffer is live.
            unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        }
        self.raster = compute_pipeline(
            ctx,
            self.sets.layout,
            &shaders::POINTS_RASTER_COMP.words(),
            "points raster",
        )?;
        let (vs, fs) = (
            shaders::FLOOR_VERT.words(),
            shaders::POINTS_COMPOSITE_FRAG.words(),
        );
        self.composite = GraphicsPipelineDesc {
            depth_write: true,
            depth_compare: vk::CompareOp::GREATER,
            ..setup.fullscreen_desc("points composite", &vs, &fs)
        }
        .build(ctx)?;
        Ok(())
    }

    /// Points in the cloud.
    pub fn total(&self) -> u64 {
        self.count
    }

    /// Chooses what frame slot `slot` draws of the cloud for `rig` within
    /// `budget` points (the octree's nodes nearest-first; without an octree
    /// every point) and writes the slot's ranges; the slot must be free.
    /// Returns the points chosen.
    pub fn select(
        &mut self,
        slot: usize,
        rig: &crate::view::StereoRig,
        near: f64,
        budget: u64,
    ) -> Result<u64> {
        let Some(tree) = &self.octree else {
            return Ok(self.count);
        };
        let s = tree.select(self.origin, rig, near, budget);
        let mut words = Vec::with_capacity(2 * s.nodes.len().max(1));
        let mut at = 0u32;
        for &i in &s.nodes {
            let n = &tree.nodes[i as usize];
            words.extend([at, n.first]);
            at += n.count;
        }
        if words.is_empty() {
            words.extend([0, 0]);
        }
        self.slots[slot].ranges.write(0, as_bytes(&words))?;
        self.ranges = (words.len() / 2) as u32;
        self.selected = s.points;
        Ok(s.points)
    }

    /// `slot`'s key buffer (the composite's binding).
    pub fn keys(&self, slot: usize) -> vk::Buffer {
        self.slots[slot].keys.buffer
    }

    /// Records `points-raster` for `slot` with `views` views, the cloud's
    /// origin at `offset` from the render origin: clear, rasterize, and
    /// make the keys readable to the composite.
    pub fn record_raster(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        q: &mut Queries,
        (slot, views): (usize, u32),
        offset: [f32; 3],
    ) {
        let s = &self.slots[slot];
        let d = &ctx.device;
        q.begin_pass(ctx, cmd, "points-raster");
        let to_compute = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )];
        let to_fragment = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(
                vk::PipelineStageFlags2::FRAGMENT_SHADER | vk::PipelineStageFlags2::HOST,
            )
            .dst_access_mask(vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::HOST_READ)];
        let groups = self.selected.div_ceil(GROUP).max(1);
        let (x, y) = (groups.min(ROW) as u32, groups.div_ceil(ROW) as u32);
        let mut push = [0u32; 12];
        for k in 0..3 {
            push[k] = offset[k].to_bits();
        }
        push[3] = self.ranges;
        push[4] = self.selected as u32;
        push[5] = self.extent.width;
        push[6] = self.extent.height;
        push[7] = views;
        push[8] = self.per_buffer as u32;
        push[9] = self.point_size.to_bits();
        push[10] = POINT_SIZE_DISTANCE_M.to_bits();
        // SAFETY: recording into the frame's open command buffer outside any
        // rendering scope; this slot's buffers were last used by the slot's
        // previous frame, whose fence the renderer has waited on.
        unsafe {
            d.cmd_fill_buffer(cmd, s.keys.buffer, 0, vk::WHOLE_SIZE, 0);
            d.cmd_fill_buffer(cmd, s.drawn.buffer, 0, vk::WHOLE_SIZE, 0);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_compute),
            );
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.raster);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.sets.layout,
                0,
                &[self.sets.sets[slot]],
                &[],
            );
            d.cmd_push_constants(
                cmd,
                self.sets.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(&push),
            );
            d.cmd_dispatch(cmd, x, y, 1);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_fragment),
            );
        }
        q.end_pass(ctx, cmd);
    }

    /// Inside a forward scope, before the meshes: the keyed pixels of view
    /// `eye` with their depth. Returns the draw calls.
    pub fn record_composite(&self, rec: &Recorder, eye: u32) -> u64 {
        rec.bind(self.composite);
        rec.push([0, eye, self.extent.width, self.extent.height]);
        rec.draw(3);
        1
    }

    /// The points `slot`'s last frame rasterized (counted once per view
    /// they landed in); its fence must have signalled.
    pub fn read(&mut self, slot: usize) -> Result<u64> {
        let m = self.slots[slot]
            .drawn
            .mapped()
            .ok_or_else(|| Error::Gpu("the points counter is not mapped".into()))?;
        Ok(u32::from_le_bytes([m[0], m[1], m[2], m[3]]) as u64)
    }

    /// Destroys everything; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.raster, &self.composite]);
        self.sets.destroy(ctx);
        for s in self.slots {
            s.keys.destroy(ctx);
            s.drawn.destroy(ctx);
            s.ranges.destroy(ctx);
        }
        for b in self.points {
            b.destroy(ctx);
        }
    }
}

/// Points staged per copy (16 bytes each: 256 MiB).
const STAGE_POINTS: usize = 16 << 20;

/// The most point buffers one cloud binds.
const MAX_BUFFERS: usize = 5;

/// Points per buffer: what one storage-buffer descriptor reaches
/// (maxStorageBufferRange / 16, at most 2^28), or `VERGENCE_POINTS_PER_BUFFER`
/// (a test knob: small values spread a small cloud over several buffers).
fn points_per_buffer(ctx: &Context) -> u64 {
    let limit = (ctx.caps.max_storage_buffer_range as u64 / 16).clamp(1, 1 << 28);
    std::env::var("VERGENCE_POINTS_PER_BUFFER")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
        .map_or(limit, |v| v.clamp(1, limit))
}

/// Uploads `cloud` as one vec4 per point (offset, colour bits) into new
/// device-local buffers of `per_buffer` points, through a staging buffer
/// of at most [`STAGE_POINTS`] points reused per chunk (a billion points
/// never sit twice in host memory).
fn upload_points(ctx: &Context, cloud: &PointCloud, per_buffer: u64) -> Result<Vec<Buffer>> {
    let n = cloud.len();
    let mut out: Vec<Buffer> = Vec::new();
    let parts = (n as u64).div_ceil(per_buffer).max(1);
    for k in 0..parts {
        let len = (n as u64 - (k * per_buffer).min(n as u64)).min(per_buffer);
        match upload_part(ctx, cloud, (k * per_buffer) as usize, len as usize) {
            Ok(b) => out.push(b),
            Err(e) => {
                for b in out {
                    b.destroy(ctx);
                }
                return Err(e);
            }
        }
    }
    Ok(out)
}

/// One buffer of `len` points of `cloud` from point `from`.
fn upload_part(ctx: &Context, cloud: &PointCloud, from: usize, len: usize) -> Result<Buffer> {
    let dst = Buffer::new(
        ctx,
        &BufferDesc {
            name: "point cloud",
            size: 16 * len.max(1) as u64,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            location: MemoryLocation::GpuOnly,
            category: "points",
        },
    )?;
    let n = len;
    let chunk = n.clamp(1, STAGE_POINTS);
    let mut staging = match Buffer::new(
        ctx,
        &BufferDesc {
            name: "point staging",
            size: 16 * chunk as u64,
            usage: vk::BufferUsageFlags::TRANSFER_SRC,
            location: MemoryLocation::CpuToGpu,
            category: "staging",
        },
    ) {
        Ok(b) => b,
        Err(e) => {
            dst.destroy(ctx);
            return Err(e);
        }
    };
    let mut result = Ok(());
    let mut data: Vec<[f32; 4]> = Vec::with_capacity(chunk);
    for start in (0..n).step_by(chunk) {
        let end = (start + chunk).min(n);
        data.clear();
        data.extend(
            cloud.positions[from + start..from + end]
                .iter()
                .zip(&cloud.colors[from + start..from + end])
                .map(|(p, c)| [p[0], p[1], p[2], f32::from_bits(u32::from_le_bytes(*c))]),
        );
        result = staging.write(0, as_bytes(&data)).and_then(|()| {
            ctx.one_shot(|cb| {
                // SAFETY: both buffers are live; the region lies inside each.
                unsafe {
                    ctx.device.cmd_copy_buffer(
                        cb,
                        staging.buffer,
                        dst.buffer,
                        &[vk::BufferCopy {
                            src_offset: 0,
                            dst_offset: 16 * start as u64,
                            size: 16 * (end - start) as u64,
                        }],
                    )
                };
            })
        });
        if result.is_err() {
            break;
        }
    }
    staging.destroy(ctx);
    match result {
        Ok(()) => Ok(dst),
        Err(e) => {
            dst.destroy(ctx);
            Err(e)
        }
    }
}
