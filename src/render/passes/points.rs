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

use super::technique::{self, FrameHook, ScopeHook, Technique};
use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::{Error, Result, VkContext};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets, GraphicsPipelineDesc};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::render::descriptors::SetContents;
use crate::render::plan::PlanInput;
use crate::render::report::RendererReport;
use crate::render::FrameStats;
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
    /// The points drawn, counted in device memory (one atomic per
    /// workgroup: over the bus they cost milliseconds)...
    drawn: Buffer,
    /// ...and copied here for the host after the rasterizer.
    drawn_host: Buffer,
    /// The frame's point ranges: (first thread, first point) per node.
    ranges: Buffer,
    /// The points chosen for the slot's frame.
    selected: u64,
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
    /// This frame's offset of the cloud's origin from the render origin
    /// (the head), set by [`PointsPass::select`].
    offset: [f32; 3],
    /// This frame's selection: ranges written and points to draw.
    ranges: u32,
    selected: u64,
    /// Side of a point at [`POINT_SIZE_DISTANCE_M`], pixels.
    point_size: f32,
    /// Eye-dome lighting's k (300 × the strength; 0: off), pushed to the
    /// composite (`shaders/points_composite.frag` derives it).
    edl_k: f32,
    /// This frame's chosen point ranges (first, count).
    chosen: Vec<(u32, u32)>,
    /// The ranges' words as written, kept to be refilled each frame.
    words: Vec<u32>,
    /// The point-list fallback's layout and pipeline (None: the compute
    /// rasterizer).
    list: Option<(vk::PipelineLayout, vk::Pipeline)>,
    /// Which path draws the points, for the stats.
    path: String,
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
        frames: &[&Buffer],
        point_size: f32,
        force_list: bool,
        edl: Option<f64>,
    ) -> Result<PointsPass> {
        let ctx = setup.ctx;
        let list = force_list || !ctx.caps.atomic_int64;
        if edl.is_some() && list {
            crate::error::warn_once(
                "eye-dome lighting needs the compute path; the points are drawn without it",
            );
        }
        let path = if force_list {
            "point-list pipeline (points-pipeline)".to_string()
        } else if !ctx.caps.atomic_int64 {
            let p = "point-list pipeline (64-bit buffer atomics not offered)".to_string();
            crate::error::warn_once(&format!("point clouds fall back to the {p}"));
            p
        } else {
            "compute (64-bit atomic max)".to_string()
        };
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
            offset: [0.0; 3],
            ranges: 1,
            selected: cloud.len() as u64,
            point_size,
            edl_k: if list {
                0.0
            } else {
                edl.map_or(0.0, |s| (300.0 * s) as f32)
            },
            chosen: vec![(0, cloud.len() as u32)],
            words: Vec::new(),
            list: list.then_some((vk::PipelineLayout::null(), vk::Pipeline::null())),
            path,
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

    /// Frame slot `i`'s buffers: the per-pixel depth-colour keys (both
    /// eyes), the drawn-points counter and its host copy, and the octree
    /// ranges to draw (one range of every point until an octree selects).
    /// What was made is freed when a later buffer fails.
    fn make_slot(&self, ctx: &Context, i: usize) -> Result<Slot> {
        let pixels = 2 * self.extent.width as u64 * self.extent.height as u64;
        let keys_usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        let keys = Buffer::new(
            ctx,
            &BufferDesc {
                name: &format!("point keys {i}"),
                size: 8 * pixels.max(1),
                usage: keys_usage,
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
                    usage: keys_usage | vk::BufferUsageFlags::TRANSFER_SRC,
                    location,
                    category: "per-frame",
                },
            )
        };
        let nodes = self.octree.as_ref().map_or(1, |t| t.nodes.len().max(1)) as u64;
        let made = [
            small(format!("points drawn {i}"), 4, MemoryLocation::GpuOnly),
            small(
                format!("points drawn (host) {i}"),
                4,
                MemoryLocation::GpuToCpu,
            ),
            small(
                format!("point ranges {i}"),
                8 * nodes,
                MemoryLocation::CpuToGpu,
            ),
        ];
        if made.iter().any(|b| b.is_err()) {
            keys.destroy(ctx);
            let mut err = None;
            for b in made {
                match b {
                    Ok(b) => b.destroy(ctx),
                    Err(e) => err = err.or(Some(e)),
                }
            }
            return Err(err.expect("one of them failed"));
        }
        let [drawn, drawn_host, mut ranges] = made.map(|b| b.expect("checked above"));
        // Without an octree the one range is every point.
        if let Err(e) = ranges.write(0, as_bytes(&[0u32, 0u32])) {
            for b in [keys, drawn, drawn_host, ranges] {
                b.destroy(ctx);
            }
            return Err(e);
        }
        Ok(Slot {
            keys,
            drawn,
            drawn_host,
            ranges,
            selected: self.count,
        })
    }

    /// Points a slot's descriptor set at the frame's uniforms, the point
    /// streams (unused bindings repeat the first) and the slot's buffers.
    fn write_set(&self, ctx: &Context, slot: &Slot, set: vk::DescriptorSet, frame: &Buffer) {
        let info = |b: &Buffer| {
            [vk::DescriptorBufferInfo::default()
                .buffer(b.buffer)
                .range(vk::WHOLE_SIZE)]
        };
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
                let ty = match b {
                    0 => vk::DescriptorType::UNIFORM_BUFFER,
                    _ => vk::DescriptorType::STORAGE_BUFFER,
                };
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(b as u32)
                    .descriptor_type(ty)
                    .buffer_info(i)
            })
            .collect();
        // SAFETY: the set is new and every buffer is live.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    fn build(&mut self, setup: &PipelineSetup, frames: &[&Buffer]) -> Result<()> {
        let ctx = setup.ctx;
        for i in 0..frames.len() {
            let slot = self.make_slot(ctx, i)?;
            self.slots.push(slot);
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
            self.write_set(ctx, slot, set, frame);
        }
        if self.list.is_some() {
            return self.build_list(setup);
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

    /// The point-list fallback: a layout over the renderer's set 0 with
    /// its own push constants, and the pipeline (the scene's depth test,
    /// one-pixel points).
    fn build_list(&mut self, setup: &PipelineSetup) -> Result<()> {
        let ctx = setup.ctx;
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX,
            offset: 0,
            size: 32,
        }];
        let sets = [setup.set_layout];
        // SAFETY: plain object creation; destroyed by `destroy`.
        let layout = unsafe {
            ctx.device.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&sets)
                    .push_constant_ranges(&ranges),
                None,
            )
        }
        .vk("creating the point-list layout")?;
        self.list = Some((layout, vk::Pipeline::null()));
        let (vs, fs) = (
            shaders::POINTS_LIST_VERT.words(),
            shaders::POINTS_LIST_FRAG.words(),
        );
        let pipeline = GraphicsPipelineDesc {
            name: "points list",
            bindings: vec![vk::VertexInputBindingDescription {
                binding: 0,
                stride: 16,
                input_rate: vk::VertexInputRate::VERTEX,
            }],
            attributes: vec![vk::VertexInputAttributeDescription {
                location: 0,
                binding: 0,
                format: vk::Format::R32G32B32A32_SFLOAT,
                offset: 0,
            }],
            specialization: Vec::new(),
            cull_mode: vk::CullModeFlags::NONE,
            layout,
            points: true,
            ..setup.scene_desc(&vs, &fs)
        }
        .build(ctx)?;
        self.list = Some((layout, pipeline));
        Ok(())
    }

    /// Which path draws the points ("compute (64-bit atomic max)", or the
    /// point-list pipeline and why).
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Whether the compute rasterizer runs (else the point-list fallback
    /// draws inside the scopes).
    pub fn computes(&self) -> bool {
        self.list.is_none()
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
        let d = self.origin - rig.head.position;
        self.offset = [d.x as f32, d.y as f32, d.z as f32];
        let Some(tree) = &self.octree else {
            return Ok(self.count);
        };
        let s = tree.select(self.origin, rig, near, budget);
        let mut words = std::mem::take(&mut self.words);
        words.clear();
        let mut at = 0u32;
        self.chosen.clear();
        for &i in &s.nodes {
            let n = &tree.nodes[i as usize];
            words.extend([at, n.first]);
            self.chosen.push((n.first, n.count));
            at += n.count;
        }
        if words.is_empty() {
            words.extend([0, 0]);
        }
        let written = self.slots[slot].ranges.write(0, as_bytes(&words));
        self.ranges = (words.len() / 2) as u32;
        self.words = words;
        written?;
        self.selected = s.points;
        self.slots[slot].selected = s.points;
        Ok(s.points)
    }

    /// `slot`'s key buffer (the composite's binding).
    pub fn keys(&self, slot: usize) -> vk::Buffer {
        self.slots[slot].keys.buffer
    }

    /// Records `points-raster` for `slot` with `views` views (the cloud
    /// placed by this frame's offset from [`PointsPass::select`]): clear,
    /// rasterize, and make the keys readable to the composite.
    pub fn record_raster(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        q: &mut Queries,
        (slot, views): (usize, u32),
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
                vk::PipelineStageFlags2::FRAGMENT_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
            )
            .dst_access_mask(
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::TRANSFER_READ,
            )];
        let to_host = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ)];
        let groups = self.selected.div_ceil(GROUP).max(1);
        let (x, y) = (groups.min(ROW) as u32, groups.div_ceil(ROW) as u32);
        let mut push = [0u32; 12];
        for (word, v) in push.iter_mut().zip(self.offset) {
            *word = v.to_bits();
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
            d.cmd_copy_buffer(
                cmd,
                s.drawn.buffer,
                s.drawn_host.buffer,
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: 4,
                }],
            );
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_host),
            );
        }
        q.end_pass(ctx, cmd);
    }

    /// Inside a forward scope over `extent`, before the meshes: the points
    /// of view `eye` — the compute rasterizer's keyed pixels with their
    /// depth, or with the fallback the chosen points as one-pixel
    /// primitives (placed by this frame's offset). Returns the draw calls.
    pub fn record_in_scope(&self, rec: &Recorder, eye: u32, extent: vk::Extent2D) -> u64 {
        let Some((layout, pipeline)) = self.list else {
            return self.record_composite(rec, eye);
        };
        let d = &rec.ctx.device;
        let mut push = [0u32; 8];
        for (word, v) in push.iter_mut().zip(self.offset) {
            *word = v.to_bits();
        }
        push[4] = eye;
        push[5] = extent.width;
        push[6] = extent.height;
        let mut calls = 0;
        // SAFETY: inside a rendering scope; the layout's set 0 is the
        // renderer's (the slot's set is compatible) and its push range is
        // the 32 bytes pushed; every vertex buffer is live.
        unsafe {
            d.cmd_bind_pipeline(rec.cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_bind_descriptor_sets(
                rec.cmd,
                vk::PipelineBindPoint::GRAPHICS,
                layout,
                0,
                &[rec.set],
                &[],
            );
            d.cmd_push_constants(
                rec.cmd,
                layout,
                vk::ShaderStageFlags::VERTEX,
                0,
                as_bytes(&push),
            );
            let mut bound = None;
            for &(first, count) in &self.chosen {
                // A range may cross from one point buffer into the next.
                let (mut at, end) = (first as u64, first as u64 + count as u64);
                while at < end {
                    let b = (at / self.per_buffer) as usize;
                    let stop = end.min((b as u64 + 1) * self.per_buffer);
                    if bound != Some(b) {
                        d.cmd_bind_vertex_buffers(rec.cmd, 0, &[self.points[b].buffer], &[0]);
                        bound = Some(b);
                    }
                    let local = (at - b as u64 * self.per_buffer) as u32;
                    d.cmd_draw(rec.cmd, (stop - at) as u32, 1, local, 0);
                    calls += 1;
                    at = stop;
                }
            }
        }
        // The renderer's set again under its own layout, for the meshes.
        rec.set_state(extent);
        calls
    }

    /// The compute rasterizer's keyed pixels of view `eye` with their
    /// depth. Returns the draw calls.
    fn record_composite(&self, rec: &Recorder, eye: u32) -> u64 {
        rec.bind(self.composite);
        rec.push([
            self.edl_k.to_bits(),
            eye,
            self.extent.width,
            self.extent.height,
        ]);
        rec.draw(3);
        1
    }

    /// The points `slot`'s last frame rasterized (counted once per view
    /// they landed in); its fence must have signalled.
    pub fn read(&mut self, slot: usize) -> Result<u64> {
        if self.list.is_some() {
            // The fallback counts on the CPU: every chosen point goes to
            // both views (the rasterizer clips those outside).
            return Ok(2 * self.slots[slot].selected);
        }
        let m = self.slots[slot]
            .drawn_host
            .mapped()
            .ok_or_else(|| Error::Gpu("the points counter is not mapped".into()))?;
        Ok(u32::from_le_bytes([m[0], m[1], m[2], m[3]]) as u64)
    }

    /// Destroys everything; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.raster, &self.composite]);
        if let Some((layout, pipeline)) = self.list {
            destroy_pipelines(ctx, [&pipeline]);
            // SAFETY: the device is idle; the layout belongs to `self`.
            unsafe { ctx.device.destroy_pipeline_layout(layout, None) };
        }
        self.sets.destroy(ctx);
        for s in self.slots {
            s.keys.destroy(ctx);
            s.drawn.destroy(ctx);
            s.drawn_host.destroy(ctx);
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
            usage: vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::VERTEX_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST,
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
            let (at, size) = (16 * start as u64, 16 * (end - start) as u64);
            crate::render::scene_gpu::copy_now(ctx, &staging, &dst, at, size)
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

/// Builds the pass for a scene with a point cloud (refused with the
/// techniques that do not draw one, [`crate::config::RenderConfig::refuse_for_points`]).
pub fn build(b: &technique::Build) -> Result<Option<Box<dyn Technique>>> {
    let Some((cloud, frames)) = b.points else {
        return Ok(None);
    };
    b.config.refuse_for_points()?;
    let c = b.config;
    let pass = PointsPass::new(
        b.setup,
        cloud,
        b.extent,
        frames,
        c.points.point_size as f32,
        c.points.points_pipeline,
        c.points.edl,
    )?;
    Ok(Some(Box::new(pass)))
}

impl Technique for PointsPass {
    fn name(&self) -> &'static str {
        "points"
    }

    fn plan(&self, input: &mut PlanInput) {
        input.points = true;
        input.points_compute = self.computes();
    }

    fn prepare(&mut self, p: &technique::Prepare, stats: &mut FrameStats) -> Result<()> {
        let c = p.config;
        stats.points_selected =
            Some(self.select(p.slot, p.rig, c.frame.near, c.points.points_budget)?);
        Ok(())
    }

    fn bind(&self, slot: usize, _: Option<&Attachments>, set: &mut SetContents) {
        set.points = Some(self.keys(slot));
    }

    fn before_scopes(&self, f: &FrameHook, q: &mut Queries) {
        if self.computes() && !f.floor {
            self.record_raster(f.rec.ctx, f.rec.cmd, q, (f.slot, 2));
        }
    }

    fn in_scope(&self, s: &ScopeHook) -> u64 {
        if s.floor {
            return 0;
        }
        self.record_in_scope(s.rec, s.eye, s.extent)
    }

    fn collect(&mut self, slot: usize, stats: &mut FrameStats) -> Result<()> {
        stats.points_drawn = Some(self.read(slot)?);
        Ok(())
    }

    fn report(&self, r: &mut RendererReport) {
        r.points_path = Some(self.path().to_string());
        r.points_total = Some(self.total());
    }

    fn destroy(self: Box<Self>, ctx: &Context) {
        PointsPass::destroy(*self, ctx);
    }
}
