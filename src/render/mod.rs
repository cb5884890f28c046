//! The stereo forward renderer. `Renderer::record_frame` takes a rig (views)
//! and an optional visible-instance list and records one frame (multiview or
//! two-pass); `Renderer::submit_frame` submits it without waiting. Up to
//! `frames_in_flight` frames run on the GPU while the CPU prepares the next;
//! a frame's statistics (with its GPU timestamps) come out of
//! `Renderer::take_completed` once its fence has signalled. `Renderer::render`
//! is the one-frame form: record, submit, wait, statistics. The loops use
//! [`driver::FrameDriver`], which adds culling and per-frame results.
//! Everything it needs is created in `Renderer::new`; nothing is compiled
//! inside a measured frame, and buffers grow only when the visible list
//! outgrows them (a few small per-frame allocations remain: barrier lists,
//! the per-pass timing names).
//!
//! The frame is a sequence of passes (`passes/`), each created only when
//! the configuration asks for it; this module owns the per-frame resources
//! (frame ring, and per slot the queries, uniform and visible-instance
//! buffers, descriptor sets). `create.rs` builds a renderer, `frame.rs`
//! prepares, records and submits a frame, `plan.rs` plans it and
//! `record.rs` records the plan's steps in the order the GPU runs them,
//! `slots.rs` waits for and collects the frames in flight.

pub mod attachments;
pub mod batches;
pub mod blended;
mod create;
pub mod culling;
pub mod descriptors;
pub mod distortion;
pub mod driver;
mod frame;
pub mod instance_updates;
pub mod passes;
pub mod plan;
mod record;
pub mod report;
pub mod scene_gpu;
pub mod shading_rate;
mod slots;
pub mod submission;
pub mod timewarp;
pub mod uniforms;

pub use crate::gpu::shaders::shader_modules;
pub use passes::floor::FloorKind;
pub use passes::output::{FrameOutput, OutputSpec};
pub use passes::stencil_mask::MAX_HIDDEN_VERTICES;

use crate::config::{RenderConfig, StereoMode};
use crate::error::{Error, Result};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc};
use crate::gpu::query::{PipelineStats, Queries};
use crate::gpu::ring::{FrameRing, Garbage};
use crate::gpu::Context;
use crate::scene::Scene;
use crate::view::foveation::Level;
use crate::view::StereoRig;
use ash::vk;
use attachments::{Attachments, SetOptions};
use batches::{Batcher, Batches};
use descriptors::{Descriptors, SetContents};
use gpu_allocator::MemoryLocation;
use passes::far_field::FarField;
pub use passes::gpu_cull::GpuCullStats;
use passes::gpu_cull::{FarSplit, GpuCull, LodFrame};
use passes::output::{OutputCopy, Readback};
use passes::{Passes, PipelineSetup, Recorder, VertexBindings};
use scene_gpu::SceneGpu;
use shading_rate::ShadingRate;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::Instant;
use submission::{DrawBinding, DrawRecords, ParallelRecording, ScopeFormat};
use uniforms::FrameUniforms;

const UBO_SIZE: u64 = uniforms::SIZE;

/// CPU time per phase of one frame, in milliseconds.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct CpuTimes {
    /// Building draw batches from the visible list.
    pub batch: f64,
    /// Recording the command buffer.
    pub record: f64,
    /// vkQueueSubmit.
    pub submit: f64,
    /// Waiting for the GPU (fence).
    pub wait: f64,
    /// With `--record-threads`: the recording threads' own times (part of
    /// `record`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub record_threads: Option<submission::ThreadTimes>,
}

/// Statistics of one rendered frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// The renderer's frame number (from 1, in submission order).
    #[serde(skip)]
    pub frame: u64,
    /// Draw calls recorded (over both eyes in two-pass mode).
    pub draw_calls: u64,
    /// Instance-primitive pairs drawn (per frame, not per eye; a monoscopic
    /// far field's pass counts as well, and so does a CPU-built inset's own
    /// list; with `gpu-cull` the inset draws the GPU's list, counted once).
    pub instances_drawn: u64,
    /// Triangles submitted per frame (not per eye; counted as
    /// `instances_drawn` is).
    pub triangles: u64,
    /// CPU times.
    pub cpu_ms: CpuTimes,
    /// GPU milliseconds per pass (timestamps).
    pub gpu_ms: BTreeMap<String, f64>,
    /// Pipeline statistics of the frame (both eyes).
    pub pipeline: Option<PipelineStats>,
    /// With `gpu-cull`: the compute cull's counters, read back with the
    /// draws (`draw_calls`, `instances_drawn` and `triangles` are then what
    /// the GPU drew).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_cull: Option<GpuCullStats>,
    /// In a scene with moving instances: what the frame uploaded of them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<instance_updates::UpdateStats>,
    /// Far cameras the monoscopic far field rendered this frame (0 to 2).
    #[serde(skip)]
    pub far_passes: u64,
    /// With a point cloud: the points the compute rasterizer placed in a
    /// view this frame, both eyes together (read back from the GPU).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_drawn: Option<u64>,
    /// With a point cloud: the points its octree's nodes chose for the
    /// frame within the budget (all points without an octree).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_selected: Option<u64>,
}

struct Pending {
    stats: FrameStats,
    queries: Queries,
    batches: Batches,
    cmd: vk::CommandBuffer,
}

/// With `inset`'s own lists, this frame's culling volumes per eye (see
/// `Renderer::inset_volumes`).
struct InsetVolumes {
    /// Through the inset rectangle: what the inset views draw.
    inset: [crate::view::frustum::Frustum; 2],
    /// Through the inset's core, where the wide views have a hole: what
    /// the wide views skip when both contain it.
    core: Option<[crate::view::frustum::Frustum; 2]>,
}

/// What one frame slot (of the frames in flight) owns.
struct Slot {
    /// The frame's uniform block.
    ubo: Buffer,
    /// The visible-instance list of the CPU's culling (grown on demand).
    visible: Option<Buffer>,
    /// Its timestamp and statistics queries (taken out while recording).
    queries: Option<Queries>,
    /// The statistics of the frame submitted from it whose fence has not
    /// been waited on yet (its GPU times are still to be read).
    in_flight: Option<FrameStats>,
}

/// The stereo renderer.
pub struct Renderer {
    ctx: Arc<Context>,
    /// The configuration it was built for.
    pub config: RenderConfig,
    extent: vk::Extent2D,
    /// The size asked for (`aq`'s scale 1), and the size the targets were
    /// made at (the largest scale with `aq`, else the same).
    nominal: vk::Extent2D,
    allocated: vk::Extent2D,
    /// With `inset`: this frame's inset rectangle (both eyes').
    inset_rect: crate::view::inset::PixelRect,
    /// With `inset`: where this frame's wide view lies in its frame
    /// ([`passes::inset::InsetPass::wide_region`]), found with the
    /// rectangle once a frame.
    wide_region: crate::view::inset::PixelRect,
    /// With `inset` and a runtime's focus views: their FOVs, which place
    /// the inset instead of the gaze and half-angle.
    focus: Option<[crate::view::Fov; 2]>,
    /// The output takes the four views as they are (no composite).
    quad: bool,
    /// The depth attachments' format: the device's depth-stencil format
    /// when a pass uses stencil (stencil mask, RDM) or the frame's depth
    /// goes out to a depth swapchain, else a depth-only one where offered.
    depth_format: vk::Format,
    scene: Option<SceneGpu>,
    targets: Option<Attachments>,
    descriptors: Descriptors,
    /// What each frame slot owns.
    per_slot: Vec<Slot>,
    ring: Option<FrameRing>,
    slot: usize,
    /// Frame slots (frames in flight), from the configuration.
    slots: usize,
    /// Frames whose fence has signalled, oldest first, until taken.
    completed: VecDeque<FrameStats>,
    /// Milliseconds [`Renderer::wait_for_slot`] waited before this frame's
    /// recording began (added to its `cpu_ms.wait`).
    slot_wait_ms: f64,
    batcher: Batcher,
    /// With `gpu-cull`: the blended instances, culled and sorted on the CPU.
    blended: Option<blended::GpuBlended>,
    batches: Batches,
    pending: Option<Pending>,
    vertices: VertexBindings,
    /// Foveation's rate images (None: foveation off).
    shading_rate: Option<ShadingRate>,
    passes: Passes,
    output: Option<OutputCopy>,
    readback: Readback,
    frame_index: u64,
    /// The scene's own sun (a glTF directional light), else the default.
    sun: Option<crate::scene::Sun>,
    /// The section plane and overlay boxes of the next frames.
    pub extras: uniforms::FrameExtras,
    /// Frames where MFFR fell back to stereo (no finite centre camera).
    pub mffr_fallbacks: u64,
    /// Whether the monoscopic far field splits the visible instances by
    /// depth (near passes draw only what reaches nearer than the split, the
    /// far pass only what reaches beyond it). On by default; off draws every
    /// visible instance in both, for comparison (`mffr-no-split` sets it at
    /// creation).
    pub mffr_partition: bool,
    /// Which foveation path runs (for stats), e.g. "off" or
    /// "vk-khr-fragment-shading-rate (16x16 texels)".
    pub foveation_path: String,
    /// With `inset`: how its views are drawn (for stats), "four-view
    /// multiview" or "two scopes (why)".
    pub inset_path: Option<String>,
    /// `inset`'s four views in one multiview scope (the eyes in layers 0
    /// and 1, the wide views in 2 and 3).
    four_view: bool,
    /// The stencil mask marks the hidden area in depth ([`mask_in_depth`]).
    mask_in_depth: bool,
    /// With `lod`: what building the chains made and cost.
    pub lod: Option<LodReport>,
    /// `--per-draw ubo|ssbo`: the per-draw records and their set 1.
    draw_records: Option<DrawRecords>,
    /// `--record-threads N`: the recording threads and their secondaries.
    parallel: Option<ParallelRecording>,
    /// Moved instances staged for the next recorded frame.
    updates: instance_updates::InstanceUpdates,
    /// Instances in the scene.
    instance_count: usize,
}

/// Whether the stencil mask marks the hidden area in depth (at the near
/// plane, its colour opaque black) rather than in stencil: always but with
/// RDM (whose checkerboard shares the stencil test), MFFR (its far-field
/// composite is drawn untested before the near geometry and relies on the
/// stencil test to stay out of the hidden area), and when the frame's
/// depth is handed on (to a depth swapchain, or to timewarp's depth
/// variants, which would carry the near-plane mask across the image). Marked in
/// depth, the frame needs neither a stencil aspect (0.86 ms a frame at 4×
/// on the H200) nor a colour clear (2.56 ms): the mask writes the colour
/// of the hidden samples and the sky the rest
/// (`bench/results/2026-12-03-h200-raster-floors.md`).
fn mask_in_depth(config: &RenderConfig, depth_out: bool) -> bool {
    let timewarp_depth = config
        .simulator
        .timewarp
        .is_some_and(|t| t.variant != crate::config::TimewarpVariant::Rotation);
    config.effort.stencil_mask
        && config.effort.rdm.is_none()
        && config.effort.mffr.is_none()
        && !depth_out
        && !timewarp_depth
}

/// Whether the frame's draws test stencil (RDM's checkerboard, or the
/// stencil mask where it is not marked in depth, writes it).
fn tests_stencil(config: &RenderConfig, mask_in_depth: bool) -> bool {
    (config.effort.stencil_mask && !mask_in_depth) || config.effort.rdm.is_some()
}

/// The render area of pixel rectangle `r`.
fn pixel_area(r: &crate::view::inset::PixelRect) -> vk::Rect2D {
    vk::Rect2D {
        offset: vk::Offset2D {
            x: r.x0 as i32,
            y: r.y0 as i32,
        },
        extent: vk::Extent2D {
            width: r.width(),
            height: r.height(),
        },
    }
}

/// How `inset`'s four views are drawn: in one multiview scope (true) when
/// `inset-views=4` asked for it, the frame is multiview and the device
/// draws at least four views in a scope; else in two scopes. The string
/// says which, and why two (for stats), and with `inset-wide-1x` over
/// MSAA that the wide views have one sample.
fn inset_path(
    inset: crate::config::Inset,
    stereo: StereoMode,
    max_views: u32,
    msaa: u32,
) -> (bool, String) {
    let one = if inset.wide_1x && msaa > 1 {
        ", wide views at 1 sample"
    } else {
        ""
    };
    let why = if !inset.four_views {
        "the default; inset-views=4 draws all four in one"
    } else if stereo != StereoMode::Multiview {
        "two-pass"
    } else if max_views < 4 {
        "the device's maxMultiviewViewCount is below 4"
    } else {
        return (true, "four-view multiview".into());
    };
    (false, format!("two scopes ({why}){one}"))
}

impl Renderer {
    /// The device context.
    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Per-eye image size of the next frame (with `aq`, the nominal size
    /// times the current render scale).
    pub fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    /// The size the targets were made at (with `aq` the nominal size at
    /// the largest scale): what an output image must hold.
    pub fn allocated_extent(&self) -> vk::Extent2D {
        self.allocated
    }

    /// Renders the following frames as `aq`'s ladder `level` says: its
    /// render scale, and with `inset` its wide view's factor and samples
    /// ([`Renderer::set_render_scale`], [`Renderer::set_inset_wide_factor`],
    /// [`Renderer::set_inset_wide_one_sample`]).
    pub fn set_aq_level(&mut self, level: &crate::adaptive::Level) {
        self.set_render_scale(level.scale);
        self.set_inset_wide_factor(level.wide_factor);
        self.set_inset_wide_one_sample(level.wide_one_sample);
    }

    /// Renders the following frames at `scale` times the nominal size per
    /// axis (within the targets; `aq`). Nothing is reallocated: only the
    /// viewport, scissor and render area change.
    pub fn set_render_scale(&mut self, scale: f64) {
        let e = scaled(self.nominal, scale);
        self.extent = vk::Extent2D {
            width: e.width.min(self.allocated.width),
            height: e.height.min(self.allocated.height),
        };
        if let Some(far) = self.passes.far.as_mut() {
            far.set_eye_size(self.extent);
        }
        if let Some(lms) = self.passes.lms.as_mut() {
            lms.set_eye_size(self.extent);
        }
    }

    /// With `inset` and `aq`'s MSAA rung (see
    /// [`passes::inset::InsetPass::has_msaa_rung`]), draws the following
    /// frames' wide views at one sample (`true`) or at the frame's MSAA.
    pub fn set_inset_wide_one_sample(&mut self, one: bool) {
        if let Some(inset) = self.passes.inset.as_mut() {
            inset.set_one_sample(one);
        }
    }

    /// Whether `aq` has the MSAA rung: the inset's wide targets can be
    /// drawn at one sample frame by frame.
    pub fn has_inset_msaa_rung(&self) -> bool {
        self.passes
            .inset
            .as_ref()
            .is_some_and(|i| i.has_msaa_rung())
    }

    /// With `inset`, draws the following frames' wide views at `factor`
    /// (clamped to (0, 1]) times the inset's scale F (`aq`'s inset rung):
    /// inside the wide targets, nothing is reallocated.
    pub fn set_inset_wide_factor(&mut self, factor: f64) {
        if let Some(inset) = self.passes.inset.as_mut() {
            inset.set_wide_factor(factor);
        }
    }

    fn view_mask(&self) -> u32 {
        match self.config.frame.stereo {
            StereoMode::Multiview if self.four_view => 0b1111,
            StereoMode::Multiview => 0b11,
            StereoMode::TwoPass => 0,
        }
    }

    fn scene(&self) -> &SceneGpu {
        self.scene.as_ref().expect("scene present until drop")
    }

    fn targets(&self) -> &Attachments {
        self.targets.as_ref().expect("targets present until drop")
    }

    /// What the pass pipelines share (see [`PipelineSetup`]).
    fn pipeline_setup(&self) -> PipelineSetup<'_> {
        PipelineSetup {
            ctx: &self.ctx,
            layout: self.descriptors.layout,
            samples: self.config.frame.msaa,
            view_mask: self.view_mask(),
            stencil_test: tests_stencil(&self.config, self.mask_in_depth),
            mask_in_depth: self.mask_in_depth,
            depth_format: self.depth_format,
            shading_rate: self.shading_rate.is_some(),
            scene: self.scene(),
            keys: &self.batcher.keys,
            per_draw: self.config.submission.per_draw,
            w_scaling: self
                .config
                .effort
                .lms
                .is_some_and(|l| !l.emulated && self.ctx.caps.clip_space_w_scaling),
            lms: self.config.effort.lms.is_some(),
            resolved_sky: self.config.effort.resolved_sky,
            set_layout: self.descriptors.set_layout,
        }
    }

    /// Every slot's uniform buffer, in slot order (what the passes that
    /// read the frame's view-projections bind).
    fn ubos(&self) -> Vec<&Buffer> {
        self.per_slot.iter().map(|s| &s.ubo).collect()
    }

    /// The size of the images this frame goes out as: with a quad output
    /// the wide views' (the insets' is [`Renderer::inset_extent`]), else
    /// the eyes' ([`Renderer::extent`]).
    pub fn output_extent(&self) -> vk::Extent2D {
        match (self.quad, self.passes.inset.as_ref()) {
            (true, Some(_)) => vk::Extent2D {
                width: self.wide_region.width(),
                height: self.wide_region.height(),
            },
            _ => self.extent,
        }
    }

    /// The last recorded frame's inset rectangle's size (the insets' images
    /// of a quad output).
    pub fn inset_extent(&self) -> vk::Extent2D {
        vk::Extent2D {
            width: self.inset_rect.width(),
            height: self.inset_rect.height(),
        }
    }

    /// The last recorded frame's inset rectangle in the eye image (with
    /// `inset`).
    pub fn inset_rect(&self) -> crate::view::inset::PixelRect {
        self.inset_rect
    }

    /// Moves the gaze the inset is centred on (NDC, +y down, both eyes)
    /// from the next frame on: a gaze that moves during a run (the bench's
    /// gaze paths). Foveation's shading-rate images keep the gaze they were
    /// made with.
    pub fn set_gaze(&mut self, ndc: [f32; 2]) {
        self.config.effort.gaze = ndc;
    }

    /// Places the following frames' inset on the runtime's focus views
    /// (their FOVs, left and right, in the eyes' poses;
    /// [`crate::view::inset::focus_rect`]) instead of around the gaze, or
    /// again around the gaze with None.
    pub fn set_focus(&mut self, focus: Option<[crate::view::Fov; 2]>) {
        self.focus = focus;
    }

    /// The last read-back frame of a quad output: the wide views left and
    /// right, then the insets (waits for the frames in flight first).
    pub fn read_quad_images(&mut self) -> Result<[image::RgbaImage; 4]> {
        self.finish()?;
        self.readback.quad_images()
    }

    /// The last read-back frame as two RGBA8 (sRGB) images, left then right
    /// (waits for the frames in flight first).
    pub fn read_images(&mut self) -> Result<[image::RgbaImage; 2]> {
        self.finish()?;
        self.readback.images(self.readback.extent())
    }

    /// The last read-back frame's depth per eye (reverse-Z), when the
    /// renderer keeps its depth (`timewarp`) and renders headless.
    pub fn read_depth(&mut self) -> Result<[Vec<f32>; 2]> {
        self.finish()?;
        self.readback
            .depth(self.readback.extent(), self.depth_format)
    }

    /// Points in the scene's cloud (None: no cloud).
    pub fn points_total(&self) -> Option<u64> {
        self.report().points_total
    }

    /// Whether the transient attachments use lazily allocated memory.
    pub fn lazily_allocated(&self) -> bool {
        self.targets.as_ref().is_some_and(|t| t.lazily_allocated())
    }
}

/// What building the LOD chains made (`lod`), for stats.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LodReport {
    /// Simplified levels built over all primitives.
    pub levels: usize,
    /// Bytes of their index lists (GPU memory, in the index buffer).
    pub index_bytes: u64,
    /// Wall-clock ms of the build (or of reading the cache).
    pub build_ms: f64,
    /// With `lod-cache`: whether the chains came from the cache file or
    /// were built and written to it (None: no cache, or the scene was not
    /// loaded from a file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cache: Option<crate::scene::lod_cache::CacheUse>,
}

/// A device loss while `context` becomes [`Error::DeviceLost`] naming the
/// last pass recorded in the frame concerned; other errors pass through.
fn device_lost(e: Error, context: &str, pass: &str) -> Error {
    match e {
        Error::Vulkan {
            result: vk::Result::ERROR_DEVICE_LOST,
            ..
        } => Error::DeviceLost {
            context: context.to_string(),
            pass: pass.to_string(),
        },
        other => other,
    }
}

fn ms(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}

impl Drop for Renderer {
    fn drop(&mut self) {
        let ctx = self.ctx.clone();
        // SAFETY: wait for the GPU, then destroy in reverse creation order.
        unsafe {
            let _ = ctx.device.device_wait_idle();
        }
        if let Some(r) = self.ring.take() {
            r.destroy(&ctx);
        }
        for q in self.per_slot.iter_mut().filter_map(|s| s.queries.take()) {
            q.destroy(&ctx);
        }
        std::mem::take(&mut self.passes).destroy(&ctx);
        self.descriptors.destroy(&ctx);
        for slot in self.per_slot.drain(..) {
            for b in slot.visible.into_iter().chain([slot.ubo]) {
                b.destroy(&ctx);
            }
        }
        std::mem::take(&mut self.readback).destroy(&ctx);
        if let Some(t) = self.targets.take() {
            t.destroy(&ctx);
        }
        if let Some(s) = self.shading_rate.take() {
            s.destroy(&ctx);
        }
        if let Some(s) = self.scene.take() {
            s.destroy(&ctx);
        }
        if let Some(r) = self.draw_records.take() {
            r.destroy(&ctx);
        }
        if let Some(p) = self.parallel.take() {
            p.destroy(&ctx);
        }
        self.updates.destroy(&ctx);
    }
}

/// `extent` times `scale` per axis, rounded, at least one pixel.
pub fn scaled(extent: vk::Extent2D, scale: f64) -> vk::Extent2D {
    let f = |v: u32| ((v as f64 * scale).round() as u32).max(1);
    vk::Extent2D {
        width: f(extent.width),
        height: f(extent.height),
    }
}
