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
//! (frame ring, queries, uniform and visible-instance buffers, descriptor
//! sets) and records the passes in the order the GPU runs them
//! (`Renderer::record`).

pub mod attachments;
pub mod batches;
pub mod culling;
pub mod descriptors;
pub mod distortion;
pub mod driver;
pub mod instance_updates;
pub mod passes;
pub mod plan;
mod record;
pub mod scene_gpu;
pub mod shading_rate;
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
        .timewarp
        .is_some_and(|t| t.variant != crate::config::TimewarpVariant::Rotation);
    config.stencil_mask
        && config.rdm.is_none()
        && config.mffr.is_none()
        && !depth_out
        && !timewarp_depth
}

/// Whether the frame's draws test stencil (RDM's checkerboard, or the
/// stencil mask where it is not marked in depth, writes it).
fn tests_stencil(config: &RenderConfig, mask_in_depth: bool) -> bool {
    (config.stencil_mask && !mask_in_depth) || config.rdm.is_some()
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
    /// Creates a renderer for `scene` at `extent` pixels per eye.
    pub fn new(
        ctx: Arc<Context>,
        scene: &Scene,
        config: &RenderConfig,
        extent: vk::Extent2D,
    ) -> Result<Renderer> {
        Renderer::with_output(ctx, scene, config, extent, None)
    }

    /// Creates a renderer whose frames are also copied into images of
    /// `output` (see [`Renderer::submit_frame`]).
    pub fn with_output(
        ctx: Arc<Context>,
        scene: &Scene,
        config: &RenderConfig,
        extent: vk::Extent2D,
        output: Option<OutputSpec>,
    ) -> Result<Renderer> {
        config.validate()?;
        if config.rdm_auto || config.foveation == crate::view::foveation::Level::Lens(0) {
            return Err(Error::config(
                "--opt",
                "rdm=auto and foveation=auto need an HMD profile with a lens to derive their radii from (this path does not resolve them); give rdm=R or a foveation level",
            ));
        }
        if extent.width == 0 || extent.height == 0 || extent.width > 16384 || extent.height > 16384
        {
            return Err(Error::config(
                "image size",
                format!(
                    "{}x{} must be within 1..=16384",
                    extent.width, extent.height
                ),
            ));
        }
        if output.is_some_and(|o| o.quad) && config.inset.is_none() {
            return Err(Error::config(
                "output",
                "four views go out only with --opt inset (the runtime's view configuration is quad views)",
            ));
        }
        let samples = config.msaa.min(ctx.caps.max_samples);
        let slots = config.frames_in_flight as usize;
        // With aq every target is made once for the largest scale.
        let nominal = extent;
        let allocated = if config.aq {
            scaled(extent, crate::adaptive::MAX_SCALE)
        } else {
            extent
        };
        let extent = allocated;
        let (chains, cache) = match (config.lod, &scene.source) {
            (None, _) => (None, None),
            (Some(_), Some(source)) if config.lod_cache => {
                let (c, used) = crate::scene::lod_cache::load_or_build(scene, source);
                (Some(c), Some(used))
            }
            (Some(_), _) => (Some(crate::scene::lod::build(scene)), None),
        };
        let lod_report = chains.as_ref().map(|c| LodReport {
            levels: c.level_count(),
            index_bytes: c.index_bytes(),
            build_ms: c.build_ms,
            cache,
        });
        let scene_gpu = SceneGpu::new(&ctx, scene, chains.as_ref())?;
        drop(chains);
        let draw_records = match DrawRecords::new(&ctx, config.per_draw, slots) {
            Ok(r) => r,
            Err(e) => {
                scene_gpu.destroy(&ctx);
                return Err(e);
            }
        };
        let extra_set = draw_records.as_ref().map(DrawRecords::set_layout);
        let descriptors =
            match Descriptors::new(&ctx, scene_gpu.textures.len() as u32, slots, extra_set) {
                Ok(d) => d,
                Err(e) => {
                    if let Some(r) = draw_records {
                        r.destroy(&ctx);
                    }
                    scene_gpu.destroy(&ctx);
                    return Err(e);
                }
            };
        let depth_out = output.as_ref().is_some_and(|o| o.depth);
        let mask_in_depth = mask_in_depth(config, depth_out);
        let stencil = tests_stencil(config, mask_in_depth) || depth_out;
        let depth_format = match ctx.caps.depth_only_format {
            Some(f) if !stencil => f,
            _ => ctx.caps.depth_format,
        };
        let inset_choice = config
            .inset
            .map(|i| inset_path(i, config.stereo, ctx.caps.max_multiview_views, samples));
        let mut r = Renderer {
            ctx: ctx.clone(),
            depth_format,
            config: RenderConfig {
                msaa: samples,
                ..config.clone()
            },
            extent: nominal,
            nominal,
            allocated,
            inset_rect: crate::view::inset::PixelRect {
                x0: 0,
                y0: 0,
                x1: nominal.width,
                y1: nominal.height,
            },
            focus: None,
            quad: output.is_some_and(|o| o.quad),
            vertices: VertexBindings::new(&scene_gpu),
            scene: Some(scene_gpu),
            targets: None,
            descriptors,
            per_slot: Vec::with_capacity(slots),
            ring: None,
            slot: 0,
            slots,
            completed: VecDeque::with_capacity(slots + 1),
            slot_wait_ms: 0.0,
            batcher: Batcher::new(scene),
            sun: scene.sun,
            extras: uniforms::FrameExtras {
                section: config.section.map(culling::plane_of),
                overlay: Vec::new(),
            },
            batches: Batches::default(),
            pending: None,
            shading_rate: None,
            passes: Passes::default(),
            output: output.map(OutputCopy::new),
            readback: Readback::new(),
            frame_index: 0,
            mffr_fallbacks: 0,
            mffr_partition: !config.mffr.is_some_and(|m| m.no_split),
            foveation_path: "off".into(),
            inset_path: inset_choice.as_ref().map(|c| {
                if output.is_some_and(|o| o.quad) {
                    format!("{}, submitted as four views", c.1)
                } else {
                    c.1.clone()
                }
            }),
            mask_in_depth,
            four_view: inset_choice.is_some_and(|c| c.0),
            wide_region: crate::view::inset::PixelRect {
                x0: 0,
                y0: 0,
                x1: 0,
                y1: 0,
            },
            lod: lod_report,
            draw_records,
            parallel: None,
            updates: instance_updates::InstanceUpdates::new(slots),
            instance_count: scene.instances.len(),
        };
        // Made into the renderer, so a failure from here on drops it and
        // with it everything made so far.
        for i in 0..slots {
            let ubo = Buffer::new(
                &ctx,
                &BufferDesc {
                    name: &format!("frame data {i}"),
                    size: UBO_SIZE,
                    usage: vk::BufferUsageFlags::UNIFORM_BUFFER,
                    location: MemoryLocation::CpuToGpu,
                    category: "per-frame",
                },
            )?;
            // Secondary command buffers may run inside the frame's
            // statistics query only with inheritedQueries.
            let stats = config.record_threads.is_none() || ctx.caps.inherited_queries;
            let queries = Queries::new(&ctx, 32, stats);
            // The buffer joins the renderer before the queries' result is
            // looked at, so a failure drops (and destroys) it with the rest.
            r.per_slot.push(Slot {
                ubo,
                visible: None,
                queries: None,
                in_flight: None,
            });
            r.per_slot[i].queries = Some(queries?);
        }
        r.ring = Some(FrameRing::new(&ctx, slots)?);
        if let Some(n) = config.record_threads {
            r.parallel = Some(ParallelRecording::new(&ctx, n as usize, slots)?);
        }
        // Pipelines depend on the shading-rate attachment: foveation first.
        let (rates, path) = ShadingRate::new(&ctx, &r.config, extent)?;
        if rates.is_none() {
            r.config.foveation = Level::Off;
        }
        r.shading_rate = rates;
        r.foveation_path = path;
        match (&r.inset_path, config.inset) {
            (Some(path), Some(i)) if i.four_views && !r.four_view => {
                tracing::warn!("inset-views=4 falls back: {path}")
            }
            (Some(path), _) => tracing::info!("inset: {path}"),
            _ => {}
        }
        r.passes = Passes::new(&r.pipeline_setup(), config, extent, slots)?;
        if let Some(cloud) = scene.points.as_ref() {
            config.refuse_for_points()?;
            r.passes.points = Some(passes::points::PointsPass::new(
                &r.pipeline_setup(),
                cloud,
                extent,
                &r.ubos(),
                config.point_size as f32,
                config.points_pipeline,
                config.edl,
            )?);
        }
        r.targets = Some(Attachments::new(
            &ctx,
            extent,
            samples,
            config.stereo == StereoMode::Multiview,
            SetOptions {
                depth_format,
                // The depth variants of the timewarp read the frame's depth;
                // the rotation-only one does not.
                keep_depth: output.is_some_and(|o| o.depth)
                    || config
                        .timewarp
                        .is_some_and(|t| t.variant != crate::config::TimewarpVariant::Rotation),
                // With a quad output the runtime composites the inset: no
                // composed image.
                composed: (config.rdm.is_some() && config.rdm_fill)
                    || (config.inset.is_some() && !r.quad)
                    || config.lms.is_some(),
                sampled: false,
                storage_output: config.inset.is_some() && !r.quad,
                occlusion: config.occlusion,
                multiview_layers: if r.four_view { 4 } else { 2 },
                one_sample_depth: false,
            },
        )?);
        if let (Some(inset), Some(targets), false) =
            (r.passes.inset.as_mut(), r.targets.as_ref(), r.quad)
        {
            inset.bind(&ctx, targets)?;
        }
        if config.gpu_cull {
            let order = r.batcher.order().to_vec();
            let occlusion = config.occlusion.then(|| (r.targets(), config.near as f32));
            let gpu = GpuCull::new(
                &r.pipeline_setup(),
                scene,
                &order,
                &r.ubos(),
                occlusion,
                config.lod.is_some(),
                config.mffr.is_some(),
                config.inset.is_some() && !r.four_view,
            )?;
            r.passes.gpu_cull = Some(gpu);
        }
        // The list holds an id per (visible instance, primitive), and with
        // the inset its own list after that (`Batches::inset_start`): room
        // for an id per instance in each list, so that with one primitive
        // per mesh the first frames do not grow it (more primitives grow it
        // once, to what is visible: sizing for every primitive of every
        // instance would reserve far more than a view sees on large scenes).
        let lists = if config.inset.is_some() { 2 } else { 1 };
        let ids = scene.instances.len().max(1) * lists;
        for i in 0..slots {
            if r.passes.gpu_cull.is_some() {
                r.write_descriptors(i);
            } else {
                r.ensure_visible_capacity(i, ids)?;
            }
        }
        Ok(r)
    }

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
        match self.config.stereo {
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
            samples: self.config.msaa,
            view_mask: self.view_mask(),
            stencil_test: tests_stencil(&self.config, self.mask_in_depth),
            mask_in_depth: self.mask_in_depth,
            depth_format: self.depth_format,
            shading_rate: self.shading_rate.is_some(),
            scene: self.scene(),
            keys: &self.batcher.keys,
            per_draw: self.config.per_draw,
            w_scaling: self
                .config
                .lms
                .is_some_and(|l| !l.emulated && self.ctx.caps.clip_space_w_scaling),
            lms: self.config.lms.is_some(),
            resolved_sky: self.config.resolved_sky,
            set_layout: self.descriptors.set_layout,
        }
    }

    /// Every slot's uniform buffer, in slot order (what the passes that
    /// read the frame's view-projections bind).
    fn ubos(&self) -> Vec<&Buffer> {
        self.per_slot.iter().map(|s| &s.ubo).collect()
    }

    fn ensure_visible_capacity(&mut self, slot: usize, ids: usize) -> Result<()> {
        let need = (ids.max(1) * 4) as u64;
        if self.per_slot[slot]
            .visible
            .as_ref()
            .is_some_and(|b| b.size >= need)
        {
            return Ok(());
        }
        let size = need.next_power_of_two().max(1024);
        let buf = Buffer::new(
            &self.ctx,
            &BufferDesc {
                name: "visible instances",
                size,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                location: MemoryLocation::CpuToGpu,
                category: "per-frame",
            },
        )?;
        if let Some(old) = self.per_slot[slot].visible.replace(buf) {
            match self.ring.as_mut() {
                Some(r) => r.defer(Garbage::Buffer(old)),
                None => old.destroy(&self.ctx),
            }
        }
        self.write_descriptors(slot);
        Ok(())
    }

    fn write_descriptors(&self, slot: usize) {
        let visible = match (&self.passes.gpu_cull, &self.per_slot[slot].visible) {
            (Some(gpu), _) => gpu.visible(slot),
            (None, Some(v)) => v,
            (None, None) => return,
        };
        let contents = SetContents {
            frame: &self.per_slot[slot].ubo,
            scene: self.scene(),
            visible,
            hidden: self.passes.stencil_mask.as_ref().map(|m| m.buffer(slot)),
            filled: self
                .passes
                .rdm
                .as_ref()
                .zip(self.targets.as_ref())
                .and_then(|(rdm, targets)| rdm.filled_images(targets)),
            far_field: self.passes.far.as_ref().map(FarField::images).or(self
                .passes
                .lms
                .as_ref()
                .and_then(|l| l.images())),
            points: self.passes.points.as_ref().map(|p| p.keys(slot)),
        };
        self.descriptors.write(&self.ctx, slot, &contents);
    }

    fn frame_data(&self, rig: &StereoRig) -> FrameUniforms {
        // Views 2 and 3 are the far-field cameras; their near plane is the
        // split distance, so everything nearer is clipped from the far field.
        // With inset's four views they are the wide views: the eyes' poses
        // with the FOVs that put each eye on its region of the layer.
        let (far_views, far_near) = match (&self.passes.far, self.four_view_region()) {
            (Some(f), _) => f.cameras(self.config.near),
            (None, Some(region)) => {
                let wide = |v: &crate::view::View| crate::view::View {
                    fov: crate::view::inset::layer_fov(
                        &v.fov,
                        &region,
                        self.extent.width,
                        self.extent.height,
                    ),
                    ..*v
                };
                let left = &rig.views[0];
                let right = rig.views.get(1).unwrap_or(left);
                ([Some(wide(left)), Some(wide(right))], self.config.near)
            }
            (None, None) => ([None, None], self.config.near),
        };
        let mut u = FrameUniforms::new(rig, self.config.near, far_views, far_near);
        if let Some(sun) = &self.sun {
            u.sun_dir = sun.direction.as_vec3().extend(0.0);
            u.sun_color = glam::Vec3::from_array(sun.color).extend(0.0);
        }
        self.extras.apply(&mut u, rig.head.position);
        u
    }

    /// With `inset`'s four views: where the wide views lie in their layers
    /// this frame (around the inset).
    fn four_view_region(&self) -> Option<crate::view::inset::PixelRect> {
        self.four_view.then_some(self.wide_region)
    }

    /// With `inset` (two scopes), each eye's volume through this frame's
    /// inset rectangle: the inset views draw only what one of them keeps
    /// (the rectangle's pixels are all they rasterize); and, where this
    /// renderer composites, each eye's volume through the inset's core:
    /// the wide views skip what both contain (the wide views' hole,
    /// [`crate::view::inset_hole`]). The CPU batcher tests spheres against
    /// them, `gpu-cull` boxes.
    fn inset_volumes(&self, rig: &StereoRig) -> Option<InsetVolumes> {
        let inset = self.config.inset?;
        // Four views share one scope and so one list.
        if self.four_view {
            return None;
        }
        let (w, h) = (self.extent.width, self.extent.height);
        let (near, far) = (self.config.near, self.config.draw_distance);
        let volume = |v: &crate::view::View| {
            let t = crate::view::inset::rect_tangents(&v.fov, &self.inset_rect, w, h);
            crate::view::frustum::Frustum::from_tangents(&v.pose, t, near, far).ok()
        };
        let (left, right) = (rig.views.first()?, rig.views.get(1)?);
        // The runtime shows submitted wide views as it likes: no hole then.
        let core = match (&self.passes.inset, self.quad || inset.wide_all) {
            (Some(pass), false) => {
                let wide = pass.wide_extent(self.extent);
                crate::view::inset_hole::core_rect(
                    &self.inset_rect,
                    (w, h),
                    (wide.width, wide.height),
                    crate::view::inset::FEATHER_PX,
                    inset.read_reach(),
                )
                .and_then(|c| {
                    let vol = |v| crate::view::inset_hole::core_volume(v, &c, w, h, near, far);
                    Some([vol(left)?, vol(right)?])
                })
            }
            _ => None,
        };
        Some(InsetVolumes {
            inset: [volume(left)?, volume(right)?],
            core,
        })
    }

    /// Renders one stereo frame of `rig` drawing the instances in `visible`
    /// (None: all), waits for it and returns its statistics. With
    /// `readback`, the frame is copied for [`Renderer::read_images`].
    /// Statistics of earlier frames still waiting in
    /// [`Renderer::take_completed`] are dropped.
    pub fn render(
        &mut self,
        rig: &StereoRig,
        visible: Option<&[u32]>,
        readback: bool,
    ) -> Result<FrameStats> {
        self.record_frame(rig, visible)?;
        let frame = self.submit_frame(None, readback)?;
        let t = Instant::now();
        self.finish()?;
        let waited = ms(t, Instant::now());
        let mut mine = None;
        while let Some(s) = self.completed.pop_front() {
            if s.frame == frame {
                mine = Some(s);
            }
        }
        let mut stats =
            mine.ok_or_else(|| Error::Gpu("a finished frame has no statistics".into()))?;
        stats.cpu_ms.wait += waited;
        Ok(stats)
    }

    /// Frames in flight this renderer was built for.
    pub fn frames_in_flight(&self) -> usize {
        self.slots
    }

    /// The statistics of the oldest frame whose GPU work has finished and
    /// that was not taken yet (GPU times included). Polls the fences of the
    /// frames in flight, oldest first, without waiting.
    pub fn take_completed(&mut self) -> Option<FrameStats> {
        for k in 0..self.slots {
            let s = (self.slot + k) % self.slots;
            if self.per_slot[s].in_flight.is_none() {
                continue;
            }
            let ring = self.ring.as_ref().expect("ring present until drop");
            // A fence that cannot be polled is reported by the next wait.
            if !ring.is_done(&self.ctx, s).unwrap_or(false) || self.collect(s).is_err() {
                break;
            }
        }
        self.completed.pop_front()
    }

    /// Waits until the frame that last used the next frame's slot (frame
    /// n − N with N in flight) has finished, so that everything the next
    /// frame does (culling included) starts after it. Recording waits for
    /// it anyway; the loops call this first to keep culling out of the
    /// overlap with 1 frame in flight.
    pub fn wait_for_slot(&mut self) -> Result<()> {
        let t = Instant::now();
        let slot = self.slot;
        let pass = self.per_slot[slot]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .wait_current(&self.ctx)
            .map_err(|e| device_lost(e, "waiting for a frame slot", pass))?;
        self.collect(slot)?;
        self.slot_wait_ms += ms(t, Instant::now());
        Ok(())
    }

    /// Waits until every submitted frame has finished; their statistics
    /// join [`Renderer::take_completed`] in submission order.
    pub fn finish(&mut self) -> Result<()> {
        let newest = (self.slot + self.slots - 1) % self.slots;
        let pass = self.per_slot[newest]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .wait_all(&self.ctx)
            .map_err(|e| device_lost(e, "waiting for the frames in flight", pass))?;
        for k in 0..self.slots {
            self.collect((self.slot + k) % self.slots)?;
        }
        Ok(())
    }

    /// Waits for `slot`'s previous frame (the ring's fence), moves that
    /// frame's statistics with its GPU times to the completed queue, and
    /// begins the slot's command buffer.
    fn begin_slot(&mut self, slot: usize) -> Result<vk::CommandBuffer> {
        let pass = self.per_slot[slot]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        let cmd = self
            .ring
            .as_mut()
            .expect("ring present until drop")
            .begin(&self.ctx)
            .map_err(|e| device_lost(e, "waiting for a frame slot", pass))?;
        self.collect(slot)?;
        Ok(cmd)
    }

    /// After `slot`'s fence has signalled: reads its timestamps and
    /// statistics into the frame submitted from it.
    fn collect(&mut self, slot: usize) -> Result<()> {
        let Some(mut stats) = self.per_slot[slot].in_flight.take() else {
            return Ok(());
        };
        let queries = self.per_slot[slot]
            .queries
            .as_ref()
            .expect("queries present until drop");
        let (passes, pipeline) = queries.read(&self.ctx)?;
        for (name, ms) in passes {
            *stats.gpu_ms.entry(name.to_string()).or_insert(0.0) += ms;
        }
        stats.pipeline = pipeline;
        if let Some(gpu) = self.passes.gpu_cull.as_mut() {
            let drawn = gpu.read(slot)?;
            let view_sets = match self.config.stereo {
                StereoMode::Multiview => 1,
                StereoMode::TwoPass => 2,
            };
            stats.draw_calls += view_sets * drawn.draws + stats.far_passes * drawn.far_draws;
            stats.instances_drawn = drawn.instances;
            stats.triangles = drawn.triangles;
            stats.gpu_cull = Some(drawn.cull);
        }
        if let Some(p) = self.passes.points.as_mut() {
            stats.points_drawn = Some(p.read(slot)?);
        }
        self.completed.push_back(stats);
        Ok(())
    }

    /// Moves instances for the next recorded frame: each of `moved` (its
    /// transform, and its world bounds in `bounds`, one per entry) replaces
    /// the instance's record on the GPU (and its box with `gpu-cull`) by a
    /// copy at the start of that frame; the others are not touched.
    pub fn move_instances(
        &mut self,
        moved: &[crate::scene::motion::Moved],
        bounds: &[crate::scene::WorldBounds],
    ) -> Result<()> {
        if moved.len() != bounds.len() {
            return Err(Error::config(
                "scene motion",
                format!(
                    "{} moved instances with {} bounds",
                    moved.len(),
                    bounds.len()
                ),
            ));
        }
        for (m, b) in moved.iter().zip(bounds) {
            instance_updates::check_index(m.index, self.instance_count)?;
            self.batcher.move_instance(m.index, b.center, b.radius);
        }
        let gpu = self.passes.gpu_cull.as_ref();
        let boxes = |m: &crate::scene::motion::Moved, b: &crate::scene::WorldBounds| {
            gpu.map_or([0.0; instance_updates::BOX_FLOATS], |g| {
                g.box_of(m.mesh, b, &m.transform)
            })
        };
        self.updates
            .stage(moved, bounds, gpu.is_some().then_some(&boxes as _));
        Ok(())
    }

    /// Builds the scene pipelines that clip against the section plane (the
    /// first frame with a plane; later ones find them).
    fn ensure_section_pipelines(&mut self) -> Result<()> {
        let mut passes = std::mem::take(&mut self.passes);
        let setup = self.pipeline_setup();
        let mut built = passes.forward.ensure_clipped(&setup);
        if let (Ok(()), Some(wide)) = (&built, passes.inset_wide.as_mut()) {
            built = wide.ensure_clipped(&setup);
        }
        if let (Ok(()), Some(far)) = (&built, passes.far.as_mut()) {
            built = far.ensure_clipped(&setup);
        }
        self.passes = passes;
        built
    }

    /// Batches and records one stereo frame of `rig` (the command buffer
    /// stays open); [`Renderer::submit_frame`] completes it. With
    /// `gpu-cull` the GPU culls and `visible` must be None.
    pub fn record_frame(&mut self, rig: &StereoRig, visible: Option<&[u32]>) -> Result<()> {
        for v in &rig.views {
            v.pose
                .validate()
                .map_err(|m| Error::config("view pose", m))?;
            v.fov.validate().map_err(|m| Error::config("view fov", m))?;
        }
        if rig.views.len() != 2 {
            return Err(Error::config(
                "views",
                format!("the stereo renderer takes 2 views, got {}", rig.views.len()),
            ));
        }
        if self.pending.is_some() {
            return Err(Error::Gpu(
                "a frame was recorded but never submitted".into(),
            ));
        }
        if self.passes.gpu_cull.is_some() && visible.is_some() {
            return Err(Error::config(
                "--opt",
                "a gpu-cull renderer culls on the GPU and draws no CPU visible list (e.g. the bench's empty-frame floor): make a CPU-culled configuration the baseline",
            ));
        }
        if let Some(i) = self.config.inset {
            // Two views (checked above): no allocation in the frame.
            let fovs = [rig.views[0].fov, rig.views[1].fov];
            self.inset_rect = match &self.focus {
                Some(focus) => crate::view::inset::focus_rect(
                    &fovs,
                    focus,
                    self.extent.width,
                    self.extent.height,
                ),
                None => crate::view::inset::inset_rect(
                    &fovs,
                    self.config.gaze,
                    i.half_angle_deg,
                    self.extent.width,
                    self.extent.height,
                ),
            };
            if let Some(pass) = self.passes.inset.as_mut() {
                self.wide_region = pass.wide_region(&self.inset_rect, self.extent);
                pass.begin_frame([rig.views[0], rig.views[1]], self.config.near, self.extent);
            }
        }
        // The slot's previous frame must be done before its buffers are
        // written: with N frames in flight, this waits for frame n - N.
        let t_wait = Instant::now();
        let slot = self.slot;
        let cmd = self.begin_slot(slot)?;
        let mut stats = FrameStats::default();
        if self.extras.section.is_some() {
            self.ensure_section_pipelines()?;
        }
        if !self.updates.is_empty() {
            let instances = self.scene().instances.buffer;
            let boxes = self.passes.gpu_cull.as_ref().map(GpuCull::boxes);
            let ring = self.ring.as_mut().expect("ring present until drop");
            stats.motion = Some(
                self.updates
                    .record(&self.ctx, ring, slot, cmd, instances, boxes)?,
            );
        }
        // Released (the threads stop spinning) when this frame's recording
        // ends, whether it gets to the threads or not.
        let _woken = self.parallel.as_ref().map(ParallelRecording::wake);
        let t0 = Instant::now();
        stats.cpu_ms.wait = ms(t_wait, t0) + std::mem::take(&mut self.slot_wait_ms);
        let mut batches = std::mem::take(&mut self.batches);
        let gpu_cull = self.passes.gpu_cull.is_some();
        match self.passes.far.as_mut() {
            // The GPU splits near from far: only the plan is made here.
            Some(far) if gpu_cull => {
                batches = Batches::default();
                let split = if !far.plan(rig, self.extent.width, self.frame_index) {
                    self.mffr_fallbacks += 1;
                    FarSplit::AllNear
                } else if !self.mffr_partition {
                    FarSplit::Both
                } else {
                    far.split_axes(rig).map_or(FarSplit::AllNear, FarSplit::At)
                };
                if let Some(gpu) = self.passes.gpu_cull.as_mut() {
                    gpu.set_far_split(split);
                }
            }
            _ if gpu_cull => {
                batches = Batches::default();
                // The cull divides the instances between the wide views and
                // the inset as the batcher would.
                let lists = self
                    .inset_volumes(rig)
                    .map(|v| crate::cull::gpu::InsetLists {
                        inset: v.inset,
                        core: v.core,
                    });
                // The wide views' density: the larger of their axes' scales.
                let scale = self.passes.inset.as_ref().map_or(1.0, |pass| {
                    let w = pass.wide_extent(self.extent);
                    let (e, f) = (self.extent, |a: u32, b: u32| a as f64 / b.max(1) as f64);
                    f(w.width, e.width).max(f(w.height, e.height))
                });
                if let Some(gpu) = self.passes.gpu_cull.as_mut() {
                    gpu.set_inset_lists(lists, scale);
                }
            }
            Some(far) => {
                if !far.plan(rig, self.extent.width, self.frame_index) {
                    self.mffr_fallbacks += 1;
                }
                far.build_batches(
                    &mut self.batcher,
                    rig,
                    visible,
                    self.mffr_partition,
                    &mut batches,
                );
            }
            None => match self.inset_volumes(rig) {
                // The inset views draw what their narrower volumes keep;
                // the wide views all but what both cores contain.
                Some(v) => self.batcher.build_inset(
                    visible,
                    rig.head.position,
                    v.core.map(|core| {
                        move |c, r| !core.iter().all(|f| f.planes.contains_sphere(c, r))
                    }),
                    |c, r| v.inset.iter().any(|f| f.planes.keeps_sphere(c, r)),
                    &mut batches,
                ),
                None => self.batcher.build(visible, rig.head.position, &mut batches),
            },
        }
        // Counted once per pass family: with a far field its pass draws too
        // (the split batches already hold near + far; unsplit, the far pass
        // draws every batch again).
        let far_field = self
            .passes
            .far
            .as_ref()
            .is_some_and(|f| f.frame().is_some());
        let passes = if far_field && batches.far_start.is_none() {
            2
        } else {
            1
        };
        stats.instances_drawn = passes * batches.instances_drawn;
        stats.triangles = passes * batches.triangles;
        stats.far_passes = self
            .passes
            .far
            .as_ref()
            .and_then(|f| f.frame())
            .map_or(0, |f| f.render.iter().filter(|&&r| r).count() as u64);
        if let Some(gpu) = self.passes.gpu_cull.as_mut() {
            let strategy = self
                .config
                .cull
                .strategy()
                .ok_or_else(|| Error::config("--opt", "gpu-cull needs a culling strategy"))?;
            let params = crate::cull::CullParams {
                near: self.config.near,
                draw_distance: self.config.draw_distance,
                ..crate::cull::CullParams::default()
            };
            // The volumes relative to the frame uniform's render origin.
            let (data, _) = crate::cull::gpu::volume_data(
                strategy,
                rig,
                self.frame_index,
                &params,
                rig.head.position,
            )
            .map_err(|e| Error::config("view for culling", e.to_string()))?;
            let lod = match self.config.lod {
                Some(bound) => {
                    let e = (self.extent.width, self.extent.height);
                    let eyes: Vec<_> = rig.views.iter().map(|v| (v.fov, e)).collect();
                    let slack = rig
                        .views
                        .iter()
                        .map(|v| (v.pose.position - rig.head.position).length())
                        .fold(0.0, f64::max);
                    LodFrame {
                        k: crate::view::lod::pixel_density(&eyes) / bound,
                        eye_slack: slack,
                    }
                }
                None => LodFrame::default(),
            };
            gpu.upload(slot, data, lod, rig.head.position)?;
        } else {
            self.ensure_visible_capacity(slot, batches.ids.len())?;
            let ids: &[u8] = as_bytes(&batches.ids);
            self.per_slot[slot]
                .visible
                .as_mut()
                .expect("allocated above")
                .write(0, ids)?;
        }
        self.frame_index += 1;
        let data = self.frame_data(rig);
        self.per_slot[slot]
            .ubo
            .write(0, as_bytes(std::slice::from_ref(&data)))?;
        if let Some(mask) = self.passes.stencil_mask.as_mut() {
            mask.upload(slot, rig)?;
        }
        if let Some(p) = self.passes.points.as_mut() {
            let budget = self.config.points_budget;
            stats.points_selected = Some(p.select(slot, rig, self.config.near, budget)?);
        }
        let t1 = Instant::now();
        stats.cpu_ms.batch = ms(t0, t1);

        let mut queries = self.per_slot[slot]
            .queries
            .take()
            .expect("queries present until drop");
        // The per-draw records are written by whoever records the draws:
        // the recording threads their runs' records, else this thread.
        let mut records = self.draw_records.take();
        let recorded = (|| -> Result<(u64, Option<submission::ThreadTimes>)> {
            let binding = records
                .as_ref()
                .map_or(DrawBinding::push(), |r| r.binding(slot));
            let space = match records.as_mut() {
                Some(r) => {
                    let ring = self.ring.as_mut().expect("ring present until drop");
                    Some(r.space(&self.ctx, ring, slot, batches.draws.len())?)
                }
                None => None,
            };
            match &self.parallel {
                Some(par) => {
                    let stats_flags = queries.stats_flags();
                    let (n, times) =
                        self.record_secondaries(par, &batches, stats_flags, binding, space)?;
                    Ok((n, Some(times)))
                }
                None => {
                    if let Some(mut space) = space {
                        let ranges = &self.scene().ranges;
                        space.fill(&batches.draws, |d| ranges[d.primitive as usize].material);
                    }
                    Ok((0, None))
                }
            }
        })();
        self.draw_records = records;
        let secondary_calls = match recorded {
            Ok((n, times)) => {
                stats.cpu_ms.record_threads = times;
                n
            }
            Err(e) => {
                self.per_slot[slot].queries = Some(queries);
                self.batches = batches;
                return Err(e);
            }
        };
        queries.reset(&self.ctx, cmd);
        stats.draw_calls = secondary_calls + self.record(cmd, &batches, &mut queries, None);
        stats.cpu_ms.record = ms(t1, Instant::now());
        self.pending = Some(Pending {
            stats,
            queries,
            batches,
            cmd,
        });
        Ok(())
    }

    /// Completes the recorded frame: copies it into `output` (the images of
    /// the [`OutputSpec`] given at creation), optionally reads it back (from
    /// `output` when given) and submits it without waiting. Returns the
    /// frame's number ([`FrameStats::frame`]); its statistics come out of
    /// [`Renderer::take_completed`] once the GPU has finished it.
    pub fn submit_frame(&mut self, output: Option<&FrameOutput>, readback: bool) -> Result<u64> {
        let Some(Pending {
            mut stats,
            queries,
            batches,
            cmd,
        }) = self.pending.take()
        else {
            return Err(Error::Gpu("submit_frame without a recorded frame".into()));
        };
        let t1 = Instant::now();
        let slot = self.slot;
        self.per_slot[slot].queries = Some(queries);
        self.batches = batches;
        if let Some(out) = output {
            self.record_output(cmd, out)?;
        }
        if readback {
            self.record_readback(cmd, output)?;
        }
        let t2 = Instant::now();
        stats.cpu_ms.record += ms(t1, t2);
        let submit = self
            .ring
            .as_mut()
            .expect("ring present until drop")
            .submit(&self.ctx);
        let t3 = Instant::now();
        stats.cpu_ms.submit = ms(t2, t3);
        let last_pass = self.per_slot[slot]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        submit.map_err(|e| device_lost(e, "submitting a frame", last_pass))?;
        // Only a submitted slot moves on (the ring moves with it).
        self.slot = (slot + 1) % self.slots;
        if crate::gpu::fault::device_lost_frame() == Some(self.frame_index) {
            let injected = Error::Vulkan {
                context: "waiting for frames (injected by VERGENCE_INJECT_FAULT)".into(),
                result: vk::Result::ERROR_DEVICE_LOST,
            };
            return Err(device_lost(
                injected,
                "waiting for the frame to finish",
                last_pass,
            ));
        }
        stats.frame = self.frame_index;
        self.per_slot[slot].in_flight = Some(stats);
        Ok(self.frame_index)
    }

    /// Renders a floor frame (clear only, or one full-screen triangle with a
    /// trivial shader) and returns its GPU milliseconds.
    pub fn render_floor(&mut self, kind: FloorKind) -> Result<f64> {
        self.finish()?;
        let slot = self.slot;
        let cmd = self.begin_slot(slot)?;
        let mut queries = self.per_slot[slot]
            .queries
            .take()
            .expect("queries present until drop");
        queries.reset(&self.ctx, cmd);
        self.record(cmd, &Batches::default(), &mut queries, Some(kind));
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .submit(&self.ctx)?;
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .wait_all(&self.ctx)?;
        let (passes, _) = queries.read(&self.ctx)?;
        self.per_slot[slot].queries = Some(queries);
        self.slot = (slot + 1) % self.slots;
        Ok(passes.iter().map(|p| p.1).sum())
    }

    /// A recorder of this frame slot's draws into `cmd`.
    fn recorder(&self, cmd: vk::CommandBuffer) -> Recorder<'_> {
        let draw = self
            .draw_records
            .as_ref()
            .map_or(DrawBinding::push(), |r| r.binding(self.slot));
        self.recorder_with(cmd, draw)
    }

    /// A recorder of this frame slot's draws into `cmd` passing per-draw
    /// data as `draw` says.
    fn recorder_with(&self, cmd: vk::CommandBuffer, draw: DrawBinding) -> Recorder<'_> {
        Recorder {
            ctx: &self.ctx,
            cmd,
            layout: self.descriptors.layout,
            set: self.descriptors.sets[self.slot],
            scene: self.scene(),
            keys: &self.batcher.keys,
            vertices: &self.vertices,
            draw,
            section: self.extras.section.is_some(),
            lms: std::cell::Cell::new(None),
        }
    }

    /// Records the forward scopes' contents of this frame slot on the
    /// recording threads, each its run of the draws into its own secondary
    /// per scope (a scope's first run also the stencil mask and the RDM
    /// checkerboard, its last the overlay), for the frame's statistics
    /// query `stats`, passing per-draw data as `draw` says; each thread
    /// first writes its run's records into its part of `space`. Returns the
    /// draw calls and the threads' timing.
    fn record_secondaries(
        &self,
        par: &ParallelRecording,
        batches: &Batches,
        stats: Option<vk::QueryPipelineStatisticFlags>,
        draw: DrawBinding,
        space: Option<submission::RecordSpace>,
    ) -> Result<(u64, submission::ThreadTimes)> {
        // (view mask, eye) per scope.
        let scopes: &[(u32, u32)] = match self.config.stereo {
            StereoMode::Multiview => &[(0b11, 0)],
            StereoMode::TwoPass => &[(0, 0), (0, 1)],
        };
        let format = |&(view_mask, _): &(u32, u32)| ScopeFormat {
            view_mask,
            color: attachments::COLOR_FORMAT,
            depth: self.depth_format,
            samples: self.config.msaa,
            stats,
        };
        let formats: Vec<ScopeFormat> = scopes.iter().map(format).collect();
        debug_assert!(batches.far_start.is_none(), "refused with mffr");
        let draws = batches.near_draws();
        // Where the sky goes, found once for every thread.
        let sky = passes::sky_slot(&self.batcher.keys, draws);
        let passes = &self.passes;
        let boxes = self.extras.overlay.len();
        let (extent, slot) = (self.extent, self.slot);
        let spaces: Vec<std::sync::Mutex<submission::RecordSpace>> = space
            .map(|s| s.split(par.threads()))
            .unwrap_or_default()
            .into_iter()
            .map(std::sync::Mutex::new)
            .collect();
        let ranges = &self.scene().ranges;
        par.record(&self.ctx, slot, &formats, draws.len(), |chunk, cmd| {
            if let (0, Some(space)) = (chunk.scope, spaces.get(chunk.thread)) {
                let mut space = space.lock().unwrap_or_else(|e| e.into_inner());
                space.fill(&draws[chunk.run.clone()], |d| {
                    ranges[d.primitive as usize].material
                });
            }
            let rec = self.recorder_with(cmd, draw);
            rec.set_state(extent);
            let eye = scopes[chunk.scope].1;
            let mut calls = 0;
            if chunk.first {
                if let Some(mask) = &passes.stencil_mask {
                    calls += mask.record(&rec, slot, eye);
                }
                if let Some(rdm) = &passes.rdm {
                    calls += rdm.record(&rec, extent, eye);
                }
            }
            let run = chunk.run.clone();
            calls += passes
                .forward
                .record_run(&rec, draws, run, sky, chunk.last, eye);
            if chunk.last {
                calls += passes.overlay.record(&rec, boxes, eye);
            }
            calls
        })
    }

    fn record_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        output: Option<&FrameOutput>,
    ) -> Result<()> {
        if let (true, Some(out)) = (self.quad, output) {
            let sizes = (self.output_extent(), self.inset_extent());
            let ring = self.ring.as_mut().expect("ring present until drop");
            return self.readback.record_quad(&self.ctx, ring, cmd, out, sizes);
        }
        let ring = self.ring.as_mut().expect("ring present until drop");
        let targets = self.targets.as_ref().expect("targets present until drop");
        self.readback.record(
            &self.ctx,
            ring,
            cmd,
            targets,
            (self.extent, self.allocated),
            output,
        )
    }

    /// Copies the resolved colour (and depth) of every set into `out`'s
    /// images, leaving them in the attachment layouts the runtime expects.
    fn record_output(&mut self, cmd: vk::CommandBuffer, out: &FrameOutput) -> Result<()> {
        let copy = self
            .output
            .as_ref()
            .ok_or_else(|| Error::Gpu("the renderer was created without an output".into()))?;
        if self.quad {
            let targets = self.targets();
            let wide = match self.passes.inset.as_ref() {
                Some(p) if p.four_view() => targets
                    .sets
                    .iter()
                    .map(|s| (s.resolve.image, 2, s.resolve.layers))
                    .collect(),
                Some(p) => p
                    .wide
                    .sets
                    .iter()
                    .map(|s| (s.resolve.image, 0, s.resolve.layers))
                    .collect(),
                None => return Err(Error::Gpu("a quad output without the inset pass".into())),
            };
            let src = passes::output::QuadSource {
                wide,
                region: self.wide_region,
                rect: self.inset_rect,
            };
            return copy.record_quad(&self.ctx, cmd, targets, &src, out);
        }
        copy.record(&self.ctx, cmd, self.targets(), self.extent, out)
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

    /// Whether this device offers per-view render areas
    /// Which path draws the scene's points (None: no cloud).
    pub fn points_path(&self) -> Option<String> {
        self.passes.points.as_ref().map(|p| p.path().to_string())
    }

    /// Points in the scene's cloud (None: no cloud).
    pub fn points_total(&self) -> Option<u64> {
        self.passes.points.as_ref().map(|p| p.total())
    }

    /// With `lms`: which path scaled w, the coefficients and the LMS
    /// image's size.
    pub fn lms_report(&self) -> Option<passes::lms::LmsReport> {
        self.passes.lms.as_ref().map(|l| l.report())
    }

    /// Whether the device offers per-view render areas
    /// (VK_QCOM_multiview_per_view_render_areas), and that vergence does not
    /// use them, for stats: see [`per_view_render_areas`].
    pub fn per_view_render_areas(&self) -> String {
        per_view_render_areas(self.ctx.caps.per_view_render_areas, &self.ctx.device_name)
    }

    /// Whether the transient attachments use lazily allocated memory.
    pub fn lazily_allocated(&self) -> bool {
        self.targets.as_ref().is_some_and(|t| t.lazily_allocated())
    }
}

/// What building the LOD chains made (`lod`), for stats.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
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

/// The stats line on VK_QCOM_multiview_per_view_render_areas: whether
/// `device` offers it (`offered`, from the device's extension list), and
/// that vergence does not use it, with the reason.
pub fn per_view_render_areas(offered: bool, device: &str) -> String {
    format!(
        "{} by {device}; unused: each view has its own projection over its whole image, so there is no padding to skip",
        if offered { "offered" } else { "not offered" }
    )
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
