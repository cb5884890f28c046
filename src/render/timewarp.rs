//! The timewarp simulation (`--opt timewarp=K` with `render --frames`):
//! a rendered frame (colour and depth of both eyes) reprojected to a newer
//! head pose on the GPU, as a runtime does when the application misses a
//! frame ([`crate::view::reproject`] has the math).
//!
//! Variants ([`Variant`]):
//! - `Rotation`: each new pixel samples the old image through the
//!   rotation-only homography (no depth; exact for a pure head turn);
//! - `Depth`: every old pixel is unprojected with its depth and scattered
//!   into the new image (nearest depth wins, by a 32-bit atomic max on
//!   reverse-Z depth, then a second pass writes the winner's colour);
//!   one-pixel cracks between hits at similar depth are closed, and the
//!   disocclusion holes left are counted and stay black;
//! - `Fill`: as `Depth`, with each hole filled from the farthest
//!   (background) hit along the four axes within 8 pixels.
//!
//! Pixels the old frame never covered (outside its image after the turn)
//! are black and counted as border. The warp's GPU time is measured by two
//! timestamps around its dispatches, the clear of its depth keys included.

use crate::error::{Error, Result};
use crate::gpu::barrier;
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc, Pod};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::view::reproject::{reprojection, rotation_only};
use crate::view::View;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// How the old frame is reprojected (the `--opt` switches set it).
pub use crate::config::TimewarpVariant as Variant;

/// What the timewarp measurement found (`timewarp` in stats.json).
#[derive(Clone, Debug, serde::Serialize)]
pub struct TimewarpStats {
    /// Every K-th frame is rendered and the source of the ones between.
    pub k: u32,
    /// How they were reprojected.
    pub variant: Variant,
    /// The head's turn rate (degrees per second, about the vertical axis).
    pub head_turn_deg_s: f64,
    /// Frames rendered (each one the truth its warp is compared with).
    pub frames_rendered: u32,
    /// Frames warped from a source.
    pub frames_warped: u32,
    /// Mean FLIP of the warped frames against their truth (both eyes).
    pub flip_mean: f64,
    /// The worst frame's FLIP mean.
    pub flip_max: f64,
    /// Disocclusion holes per warped frame, as a fraction of its pixels.
    pub holes_fraction: f64,
    /// Pixels outside the source image per warped frame (fraction).
    pub border_fraction: f64,
    /// Cracks closed per warped frame (fraction).
    pub cracks_fraction: f64,
    /// GPU ms of one warp (both eyes).
    pub warp_gpu_ms: crate::stats::Percentiles,
    /// GPU ms of one rendered frame along the same path.
    pub render_gpu_ms: crate::stats::Percentiles,
    /// Vulkan validation messages during the measurement.
    pub validation_messages: usize,
}

/// What one warp gives back.
pub struct WarpOutput {
    /// The warped images, left then right (RGBA8, sRGB bytes).
    pub images: [image::RgbaImage; 2],
    /// GPU milliseconds of the warp (both eyes).
    pub gpu_ms: f64,
    /// Disocclusion holes per eye (pixels).
    pub holes: [u64; 2],
    /// Pixels outside the old image per eye.
    pub border: [u64; 2],
    /// One-pixel cracks closed per eye.
    pub cracks: [u64; 2],
}

#[derive(Clone, Copy)]
#[repr(C)]
struct Push {
    size: [u32; 2],
    eye: u32,
    mode: u32,
}

// SAFETY: four u32, no padding.
unsafe impl Pod for Push {}

/// The per-eye matrices of `shaders/timewarp.glsl` (column-major f32).
#[derive(Clone, Copy)]
#[repr(C)]
struct Params {
    reproject: [[f32; 16]; 2],
    rotation_inverse: [[f32; 16]; 2],
}

// SAFETY: f32 arrays, no padding.
unsafe impl Pod for Params {}

struct Buffers {
    src_colour: Buffer,
    src_depth: Buffer,
    keys: Buffer,
    out: Buffer,
    counters: Buffer,
    params: Buffer,
    scatter: Buffer,
    staging: Buffer,
    readback: Buffer,
}

/// The timewarp of one eye-image size.
pub struct Timewarp {
    ctx: Arc<Context>,
    variant: Variant,
    extent: vk::Extent2D,
    buffers: Option<Buffers>,
    binding: DescriptorSets,
    layout: vk::PipelineLayout,
    set: vk::DescriptorSet,
    scatter: vk::Pipeline,
    resolve: vk::Pipeline,
    rotate: vk::Pipeline,
    queries: vk::QueryPool,
}

const COUNTERS: u64 = 6 * 4;

impl Buffers {
    /// The warp's buffers for two eyes of `extent`: the source colour and
    /// depth, the scatter keys and targets, the output, the counters and
    /// parameters, and the upload and read-back buffers.
    fn new(ctx: &Context, extent: vk::Extent2D) -> Result<Buffers> {
        let pixels = extent.width as u64 * extent.height as u64 * 2;
        let buffer = |name, size, usage, location| {
            Buffer::new(
                ctx,
                &BufferDesc {
                    name,
                    size,
                    usage,
                    location,
                    category: "timewarp",
                },
            )
        };
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let dst = vk::BufferUsageFlags::TRANSFER_DST;
        let src = vk::BufferUsageFlags::TRANSFER_SRC;
        let gpu = MemoryLocation::GpuOnly;
        Ok(Buffers {
            src_colour: buffer("timewarp colour", pixels * 4, storage | dst, gpu)?,
            src_depth: buffer("timewarp depth", pixels * 4, storage | dst, gpu)?,
            keys: buffer("timewarp keys", pixels * 4, storage | dst, gpu)?,
            out: buffer("timewarp out", pixels * 4, storage | src, gpu)?,
            counters: buffer("timewarp counters", COUNTERS, storage | dst | src, gpu)?,
            params: buffer(
                "timewarp params",
                std::mem::size_of::<Params>() as u64,
                storage | dst,
                gpu,
            )?,
            scatter: buffer("timewarp scatter", pixels * 8, storage, gpu)?,
            staging: buffer("timewarp upload", pixels * 8, src, MemoryLocation::CpuToGpu)?,
            readback: buffer(
                "timewarp readback",
                pixels * 4 + COUNTERS,
                dst,
                MemoryLocation::GpuToCpu,
            )?,
        })
    }

    /// Points the warp's descriptor set at its seven storage buffers.
    fn write_set(&self, ctx: &Context, set: vk::DescriptorSet) {
        let b = self;
        let all = [
            &b.src_colour,
            &b.src_depth,
            &b.keys,
            &b.out,
            &b.counters,
            &b.params,
            &b.scatter,
        ];
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = all
            .iter()
            .map(|buf| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(buf.buffer)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(i, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i as u32)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info)
            })
            .collect();
        // SAFETY: every write names a live buffer of this warp and the
        // binding's own set.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }
}

impl Timewarp {
    /// Builds the warp for eye images of `extent` pixels.
    pub fn new(ctx: &Arc<Context>, extent: vk::Extent2D, variant: Variant) -> Result<Timewarp> {
        let buffers = Buffers::new(ctx, extent)?;
        let storage = (
            vk::DescriptorType::STORAGE_BUFFER,
            1,
            vk::ShaderStageFlags::COMPUTE,
        );
        let binding = DescriptorSets::new(
            ctx,
            &[storage; 7],
            vk::ShaderStageFlags::COMPUTE,
            std::mem::size_of::<Push>() as u32,
            1,
            "timewarp",
        )?;
        let (layout, set) = (binding.layout, binding.sets[0]);
        buffers.write_set(ctx, set);
        let scatter = compute_pipeline(
            ctx,
            layout,
            &shaders::TIMEWARP_SCATTER_COMP.words(),
            "timewarp scatter",
        )?;
        let resolve = compute_pipeline(
            ctx,
            layout,
            &shaders::TIMEWARP_RESOLVE_COMP.words(),
            "timewarp resolve",
        )?;
        let rotate = compute_pipeline(
            ctx,
            layout,
            &shaders::TIMEWARP_ROTATE_COMP.words(),
            "timewarp rotate",
        )?;
        let queries = crate::gpu::query::timestamp_pair(ctx)?;
        Ok(Timewarp {
            ctx: ctx.clone(),
            variant,
            extent,
            buffers: Some(buffers),
            binding,
            layout,
            set,
            scatter,
            resolve,
            rotate,
            queries,
        })
    }

    fn buffers(&self) -> &Buffers {
        self.buffers.as_ref().expect("buffers live until drop")
    }

    /// The frame's depth, read back from `renderer` when `variant` uses it;
    /// the rotation-only variant reads none (the renderer keeps none for
    /// it) and gets zeros of the right size.
    pub fn source_depth(
        renderer: &mut crate::render::Renderer,
        variant: crate::config::TimewarpVariant,
    ) -> Result<[Vec<f32>; 2]> {
        if variant == crate::config::TimewarpVariant::Rotation {
            let e = renderer.extent();
            let n = e.width as usize * e.height as usize;
            return Ok([vec![0.0; n], vec![0.0; n]]);
        }
        renderer.read_depth()
    }

    /// Warps the frame rendered at `old` (colour and reverse-Z depth per
    /// eye, left then right) to the eyes `new`.
    pub fn warp(
        &mut self,
        colour: &[image::RgbaImage; 2],
        depth: &[Vec<f32>; 2],
        old: [&View; 2],
        new: [&View; 2],
        near: f64,
    ) -> Result<WarpOutput> {
        let (w, h) = (self.extent.width, self.extent.height);
        let layer = w as usize * h as usize;
        for (c, z) in colour.iter().zip(depth) {
            if c.dimensions() != (w, h) || z.len() != layer {
                return Err(Error::Gpu(format!(
                    "timewarp: a {}x{} frame with {} depths is not the {w}x{h} it was built for",
                    c.width(),
                    c.height(),
                    z.len()
                )));
            }
        }
        {
            let staging = &mut self
                .buffers
                .as_mut()
                .expect("buffers live until drop")
                .staging;
            for (i, (c, z)) in colour.iter().zip(depth).enumerate() {
                staging.write(i * layer * 4, c.as_raw())?;
                staging.write((2 + i) * layer * 4, as_bytes(z))?;
            }
        }
        let f = |m: glam::DMat4| m.as_mat4().to_cols_array();
        let params = Params {
            reproject: [0, 1].map(|e| f(reprojection(old[e], new[e], near))),
            rotation_inverse: [0, 1].map(|e| f(rotation_only(old[e], new[e], near).inverse())),
        };
        self.ctx.one_shot(|cmd| self.record(cmd, &params))?;
        let gpu_ms = crate::gpu::query::timestamp_pair_ms(&self.ctx, self.queries)?;
        let data = self
            .buffers
            .as_mut()
            .expect("buffers live until drop")
            .readback
            .mapped()
            .ok_or_else(|| Error::Gpu("timewarp readback is not mapped".into()))?;
        let bytes = layer * 4;
        let image = |i: usize| {
            image::RgbaImage::from_raw(w, h, data[i * bytes..(i + 1) * bytes].to_vec())
                .ok_or_else(|| Error::Gpu("timewarp readback too small".into()))
        };
        let images = [image(0)?, image(1)?];
        let counter = |k: usize| {
            let o = 2 * bytes + 4 * k;
            u32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]]) as u64
        };
        Ok(WarpOutput {
            images,
            gpu_ms,
            holes: [counter(0), counter(3)],
            border: [counter(1), counter(4)],
            cracks: [counter(2), counter(5)],
        })
    }

    /// Records one warp: the source images and parameters in, the
    /// variant's dispatches between two timestamps, the warped images and
    /// counters out to the read-back buffer.
    fn record(&self, cmd: vk::CommandBuffer, params: &Params) {
        let d = &self.ctx.device;
        let b = self.buffers();
        let layer = self.extent.width as u64 * self.extent.height as u64 * 4;
        let region = |src_offset, dst_offset, size| vk::BufferCopy {
            src_offset,
            dst_offset,
            size,
        };
        // SAFETY: recording into the one-time command buffer; every buffer
        // belongs to this warp and is idle (the previous warp was waited for).
        unsafe {
            d.cmd_copy_buffer(
                cmd,
                b.staging.buffer,
                b.src_colour.buffer,
                &[region(0, 0, 2 * layer)],
            );
            d.cmd_copy_buffer(
                cmd,
                b.staging.buffer,
                b.src_depth.buffer,
                &[region(2 * layer, 0, 2 * layer)],
            );
            d.cmd_update_buffer(cmd, b.params.buffer, 0, as_bytes(&[*params]));
            d.cmd_fill_buffer(cmd, b.counters.buffer, 0, vk::WHOLE_SIZE, 0);
            d.cmd_reset_query_pool(cmd, self.queries, 0, 2);
            d.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.queries, 0);
            d.cmd_fill_buffer(cmd, b.keys.buffer, 0, vk::WHOLE_SIZE, 0);
        }
        self.compute_barrier(cmd);
        self.record_dispatches(cmd);
        let to_copy = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COPY)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)];
        let to_host = [barrier::copies_to_host()];
        // SAFETY: as above.
        unsafe {
            d.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, self.queries, 1);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_copy),
            );
            d.cmd_copy_buffer(
                cmd,
                b.out.buffer,
                b.readback.buffer,
                &[region(0, 0, 2 * layer)],
            );
            let counters = region(0, 2 * layer, COUNTERS);
            d.cmd_copy_buffer(cmd, b.counters.buffer, b.readback.buffer, &[counters]);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_host),
            );
        }
    }

    /// The variant's dispatches per eye: rotation's one pass, or the depth
    /// warp's two scatter passes (each followed by a barrier) and its
    /// resolve (filling holes with `timewarp-fill`).
    fn record_dispatches(&self, cmd: vk::CommandBuffer) {
        if self.variant == Variant::Rotation {
            for eye in 0..2 {
                self.dispatch(cmd, self.rotate, eye, 0);
            }
            return;
        }
        for mode in 0..2 {
            for eye in 0..2 {
                self.dispatch(cmd, self.scatter, eye, mode);
            }
            self.compute_barrier(cmd);
        }
        let fill = u32::from(self.variant == Variant::Fill);
        for eye in 0..2 {
            self.dispatch(cmd, self.resolve, eye, fill);
        }
    }

    /// Compute and transfer writes before the next compute reads.
    fn compute_barrier(&self, cmd: vk::CommandBuffer) {
        let m = [vk::MemoryBarrier2::default()
            .src_stage_mask(
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::ALL_TRANSFER,
            )
            .src_access_mask(vk::AccessFlags2::SHADER_WRITE | vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(vk::AccessFlags2::SHADER_READ | vk::AccessFlags2::SHADER_WRITE)];
        // SAFETY: a barrier in the open command buffer.
        unsafe {
            self.ctx
                .device
                .cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&m))
        };
    }

    /// One dispatch of `pipeline` over an eye's pixels.
    fn dispatch(&self, cmd: vk::CommandBuffer, pipeline: vk::Pipeline, eye: u32, mode: u32) {
        let d = &self.ctx.device;
        let push = Push {
            size: [self.extent.width, self.extent.height],
            eye,
            mode,
        };
        let bind = vk::PipelineBindPoint::COMPUTE;
        // SAFETY: recording a dispatch with this warp's pipeline and set.
        unsafe {
            d.cmd_bind_pipeline(cmd, bind, pipeline);
            d.cmd_bind_descriptor_sets(cmd, bind, self.layout, 0, &[self.set], &[]);
            d.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(&[push]),
            );
            d.cmd_dispatch(
                cmd,
                self.extent.width.div_ceil(8),
                self.extent.height.div_ceil(8),
                1,
            );
        }
    }
}

impl Drop for Timewarp {
    fn drop(&mut self) {
        let ctx = self.ctx.clone();
        let d = &ctx.device;
        // SAFETY: every submission was waited for; nothing is in use.
        unsafe {
            let _ = d.device_wait_idle();
            d.destroy_query_pool(self.queries, None);
            for p in [self.scatter, self.resolve, self.rotate] {
                d.destroy_pipeline(p, None);
            }
        }
        self.binding.destroy(&ctx);
        if let Some(b) = self.buffers.take() {
            for buf in [
                b.src_colour,
                b.src_depth,
                b.keys,
                b.out,
                b.counters,
                b.params,
                b.scatter,
                b.staging,
                b.readback,
            ] {
                buf.destroy(&ctx);
            }
        }
    }
}
