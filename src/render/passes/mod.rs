//! The frame's passes, each created only when the configuration asks for
//! it, and what they share: the pipeline descriptions they derive their
//! pipelines from ([`PipelineSetup`]) and the recording helpers
//! ([`Recorder`]): one rendering scope (colour, depth and resolve
//! attachments, viewport, scissor, descriptor set) used by the forward
//! views and the far field alike, push constants, batched scene draws and
//! the sky.

pub mod depth_pyramid;
pub mod far_field;
pub mod floor;
pub mod forward;
pub mod gpu_cull;
pub mod inset;
pub mod inset_taa;
pub mod inset_wide;
pub mod lms;
pub mod output;
pub mod overlay;
pub mod points;
pub mod rdm;
pub mod rdm_in_place;
pub mod resolved_sky;
pub mod sampled;
pub mod stencil_mask;
pub mod technique;

use super::attachments::{AttachmentSet, Attachments, TargetViews, COLOR_FORMAT};
use super::batches::{Draw, PipelineKey};
use super::scene_gpu::{self, SceneGpu, STREAMS};
use super::submission::DrawBinding;
use crate::config::{PerDraw, RenderConfig};
use crate::error::Result;
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{as_bytes, Buffer, Image};
use crate::gpu::pipeline::{Blend, GraphicsPipelineDesc};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::scene::points::PointCloud;
use ash::vk;
use far_field::FarField;
use floor::Floor;
use forward::Forward;
use gpu_cull::GpuCull;
use overlay::Overlay;
use std::collections::HashMap;
use technique::Technique;

/// The passes a renderer records, each built only when its configuration
/// asks for it.
#[derive(Default)]
pub struct Passes {
    /// Scene and sky.
    pub forward: Forward,
    /// The raster floors.
    pub floor: Floor,
    /// Controllers, rays, arcs, markers and labels.
    pub overlay: Overlay,
    /// Monoscopic far field (`mffr`).
    pub far: Option<FarField>,
    /// GPU-driven culling (`gpu-cull`; built by the renderer, which has the
    /// scene).
    pub gpu_cull: Option<GpuCull>,
    /// Multi-resolution foveated rendering (`inset`): the wide view's
    /// targets and the composite.
    pub inset: Option<inset::InsetPass>,
    /// The wide views' one-sample pipelines (`inset-wide-1x` over MSAA).
    pub inset_wide: Option<inset_wide::WidePipelines>,
    /// Lens-matched shading (`lms`): the LMS targets and the resample.
    pub lms: Option<lms::LmsPass>,
    /// The hooked techniques the configuration asks for (stencil mask,
    /// sky after the resolve, RDM, point cloud), in
    /// [`technique::REGISTRY`]'s order.
    pub techniques: Vec<Box<dyn Technique>>,
}

impl Passes {
    /// Builds the passes `config` enables for eyes of `extent` with `slots`
    /// frame slots (and the pass of the scene's point cloud, drawn with the
    /// frame slots' uniform buffers); on failure, destroys what it built.
    pub fn new(
        setup: &PipelineSetup,
        config: &RenderConfig,
        (extent, slots): (vk::Extent2D, usize),
        points: Option<(&PointCloud, &[&Buffer])>,
    ) -> Result<Passes> {
        let mut p = Passes::default();
        let built = p.build(setup, config, extent).and_then(|()| {
            p.techniques = technique::build_all(&technique::Build {
                setup,
                config,
                extent,
                slots,
                inset: p.inset.as_ref(),
                lms: p.lms.as_ref(),
                points,
            })?;
            Ok(())
        });
        match built {
            Ok(()) => Ok(p),
            Err(e) => {
                p.destroy(setup.ctx);
                Err(e)
            }
        }
    }

    /// The passes that shape the frame's scopes (the hooked techniques
    /// come after: RDM's fill goes into the inset's or LMS's images).
    fn build(
        &mut self,
        setup: &PipelineSetup,
        config: &RenderConfig,
        extent: vk::Extent2D,
    ) -> Result<()> {
        self.forward = Forward::new(setup)?;
        self.floor = Floor::new(setup)?;
        self.overlay = Overlay::new(setup)?;
        if let Some(m) = config.effort.mffr {
            self.far = Some(FarField::new(setup, m, extent, config.effort.resolved_sky)?);
        }
        if let Some(i) = config.effort.inset {
            // With inset-wide-1x over MSAA the wide views have one sample
            // and their own pipelines.
            let wide_1x = i.wide_1x && setup.samples > 1;
            // aq's MSAA rung: the wide views' targets can also be drawn at
            // one sample, frame by frame (two scopes, over MSAA, and the
            // inset's rungs not left out; not with occlusion, whose depth
            // pyramid reads the wide views' multisampled depth).
            let msaa_rung = config.effort.aq
                && !config.effort.aq_scale_only
                && !config.culling.occlusion
                && config.effort.rdm.is_none()
                && config.effort.mffr.is_none()
                && !wide_1x
                && setup.samples > 1
                && setup.view_mask != 0b1111;
            let mut pass = inset::InsetPass::new(
                setup,
                extent,
                i.wide_scale,
                inset::WideOptions {
                    samples: if wide_1x { 1 } else { setup.samples },
                    msaa_rung,
                    occlusion: config.culling.occlusion,
                    rdm: config.effort.rdm.is_some() && config.effort.rdm_fill,
                },
                config.frame.stereo == crate::config::StereoMode::Multiview,
                i.taa.map(|alpha| inset_taa::TaaSettings {
                    alpha,
                    jitter: i.taa_jitter,
                    upsample: i.taau,
                    lanczos: i.taau_lanczos,
                }),
            )?;
            pass.catmull_rom = i.catmull_rom;
            pass.sharpen = i.sharpen.unwrap_or(0.0) as f32;
            self.inset = Some(pass);
            if wide_1x || msaa_rung {
                self.inset_wide = Some(inset_wide::WidePipelines::new(
                    setup,
                    config.effort.stencil_mask,
                )?);
            }
        }
        if let Some(l) = config.effort.lms {
            let path = if setup.w_scaling {
                "nv-clip-space-w-scaling".to_string()
            } else if l.emulated {
                "vertex-shader (lms-emulated)".to_string()
            } else {
                let p = "vertex-shader (VK_NV_clip_space_w_scaling not offered)".to_string();
                crate::error::warn_once(&format!("lms falls back to {p}"));
                p
            };
            self.lms = Some(lms::LmsPass::new(
                setup,
                extent,
                setup.samples,
                config.frame.stereo == crate::config::StereoMode::Multiview,
                l.coefficients(),
                (path, config.effort.rdm.is_some() && config.effort.rdm_fill),
            )?);
        }
        Ok(())
    }

    /// Destroys every pass; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        self.forward.destroy(ctx);
        self.floor.destroy(ctx);
        self.overlay.destroy(ctx);
        for t in self.techniques {
            t.destroy(ctx);
        }
        if let Some(p) = self.far {
            p.destroy(ctx);
        }
        if let Some(p) = self.gpu_cull {
            p.destroy(ctx);
        }
        if let Some(p) = self.inset {
            p.destroy(ctx);
        }
        if let Some(p) = self.inset_wide {
            p.destroy(ctx);
        }
        if let Some(p) = self.lms {
            p.destroy(ctx);
        }
    }
}

/// What every pass pipeline shares, fixed at creation.
#[derive(Clone, Copy)]
pub struct PipelineSetup<'a> {
    /// The device.
    pub ctx: &'a Context,
    /// The pipeline layout (descriptor set 0 and the push constants).
    pub layout: vk::PipelineLayout,
    /// MSAA samples of the frame's attachments.
    pub samples: u32,
    /// Multiview mask of the forward views (0 in two-pass; 0b1111 for
    /// `inset`'s four views in one scope, else 0b11).
    pub view_mask: u32,
    /// Whether draws test stencil (RDM, or the stencil mask kept in
    /// stencil).
    pub stencil_test: bool,
    /// The stencil mask marks the hidden area in depth at the near plane
    /// and writes its colour (not stencil).
    pub mask_in_depth: bool,
    /// The depth attachments' format (with a stencil aspect when
    /// `stencil_test` or the frame's depth output needs one).
    pub depth_format: vk::Format,
    /// Whether the forward views have a fragment-shading-rate attachment.
    pub shading_rate: bool,
    /// The scene (vertex streams in use, texture count, features).
    pub scene: &'a SceneGpu,
    /// Pipeline key per primitive.
    pub keys: &'a [PipelineKey],
    /// How the forward draws pass their per-draw data (picks the scene
    /// vertex shader).
    pub per_draw: PerDraw,
    /// Whether the forward views scale clip-space w in the rasterizer
    /// (`lms` on VK_NV_clip_space_w_scaling): their pipelines take the
    /// coefficients as dynamic state.
    pub w_scaling: bool,
    /// Whether the forward views are LMS quadrants (`lms`, either path):
    /// the sky is drawn per quadrant (`sky_lms.vert`).
    pub lms: bool,
    /// Whether the sky is drawn after the resolve (`resolved-sky`): the
    /// forward scope's colour starts transparent.
    pub resolved_sky: bool,
    /// The renderer's set 0 layout (for passes with their own push
    /// constants over the same set).
    pub set_layout: vk::DescriptorSetLayout,
}

impl PipelineSetup<'_> {
    /// The scene pipeline over the scene's vertex streams, drawn into the
    /// forward views: reverse-Z depth test and write, back faces culled,
    /// and with the stencil mask kept in stencil (bit 0) or RDM (bit 1)
    /// on, passing only where neither wrote stencil (a mask marked in
    /// depth needs no stencil test: depth 1 fails GREATER).
    pub fn scene_desc<'s>(
        &self,
        vertex: &'s [u32],
        fragment: &'s [u32],
    ) -> GraphicsPipelineDesc<'s> {
        let used = scene_gpu::used_streams(&self.scene.features);
        let formats = [
            vk::Format::R32G32B32_SFLOAT,
            vk::Format::R32G32B32_SFLOAT,
            vk::Format::R32G32B32A32_SFLOAT,
            vk::Format::R32G32_SFLOAT,
            vk::Format::R32G32_SFLOAT,
            vk::Format::R32G32B32A32_SFLOAT,
        ];
        let bindings = (0..6)
            .map(|i| vk::VertexInputBindingDescription {
                binding: i as u32,
                stride: if used[i] { STREAMS[i].1 } else { 0 },
                input_rate: vk::VertexInputRate::VERTEX,
            })
            .collect();
        let attributes = (0..6)
            .map(|i| vk::VertexInputAttributeDescription {
                location: i as u32,
                binding: i as u32,
                format: formats[i],
                offset: 0,
            })
            .collect();
        GraphicsPipelineDesc {
            name: "scene",
            vertex,
            fragment,
            specialization: Vec::new(),
            bindings,
            attributes,
            cull_mode: vk::CullModeFlags::BACK,
            depth_test: true,
            depth_write: true,
            depth_compare: vk::CompareOp::GREATER,
            stencil: self.stencil_test.then_some(vk::StencilOpState {
                fail_op: vk::StencilOp::KEEP,
                pass_op: vk::StencilOp::KEEP,
                depth_fail_op: vk::StencilOp::KEEP,
                compare_op: vk::CompareOp::EQUAL,
                compare_mask: 3,
                write_mask: 0,
                reference: 0,
            }),
            blend: Blend::Off,
            color_write: vk::ColorComponentFlags::RGBA,
            samples: vk::SampleCountFlags::from_raw(self.samples),
            color_format: COLOR_FORMAT,
            depth_format: self.depth_format,
            view_mask: self.view_mask,
            layout: self.layout,
            shading_rate_attachment: self.shading_rate,
            w_scaling: self.w_scaling,
            points: false,
        }
    }

    /// A pass writing a composed output image (RDM's fill, LMS's
    /// resample): a full-screen triangle (`vertex`: `floor.vert`'s) and
    /// `fragment`, one sample, no depth, stencil or shading-rate
    /// attachment.
    pub fn composed_desc<'s>(
        &self,
        name: &'s str,
        vertex: &'s [u32],
        fragment: &'s [u32],
    ) -> GraphicsPipelineDesc<'s> {
        GraphicsPipelineDesc {
            depth_test: false,
            depth_write: false,
            stencil: None,
            samples: vk::SampleCountFlags::TYPE_1,
            depth_format: vk::Format::UNDEFINED,
            shading_rate_attachment: false,
            w_scaling: false,
            ..self.fullscreen_desc(name, vertex, fragment)
        }
    }

    /// A full-screen pipeline named `name` (no vertex buffers, no culling,
    /// depth tested at GREATER_OR_EQUAL and not written) drawn into the
    /// forward views.
    pub fn fullscreen_desc<'s>(
        &self,
        name: &'s str,
        vertex: &'s [u32],
        fragment: &'s [u32],
    ) -> GraphicsPipelineDesc<'s> {
        GraphicsPipelineDesc {
            name,
            bindings: Vec::new(),
            attributes: Vec::new(),
            cull_mode: vk::CullModeFlags::NONE,
            depth_write: false,
            depth_compare: vk::CompareOp::GREATER_OR_EQUAL,
            ..self.scene_desc(vertex, fragment)
        }
    }

    /// One scene pipeline per pipeline key the scene uses, derived from
    /// `base` (a [`PipelineSetup::scene_desc`]): alpha-mask primitives get
    /// `base`'s fragment shader (late tests, it discards), the others the
    /// early-test variant.
    pub fn scene_pipelines(
        &self,
        base: &GraphicsPipelineDesc,
    ) -> Result<HashMap<PipelineKey, vk::Pipeline>> {
        let early = shaders::SCENE_EARLY_FRAG.words();
        let mut keys = self.keys.to_vec();
        keys.sort();
        keys.dedup();
        let mut out = HashMap::new();
        for key in keys {
            let name = format!(
                "scene alpha={} double_sided={} unlit={}",
                key.alpha, key.double_sided, key.unlit
            );
            let desc = GraphicsPipelineDesc {
                name: &name,
                fragment: if key.alpha == 1 {
                    base.fragment
                } else {
                    &early
                },
                specialization: vec![
                    (0, self.scene.textures.len() as u32),
                    (1, key.alpha as u32),
                    (2, self.scene.features.tangents as u32),
                    (3, key.unlit as u32),
                ],
                cull_mode: if key.double_sided {
                    vk::CullModeFlags::NONE
                } else {
                    vk::CullModeFlags::BACK
                },
                depth_write: key.alpha < 2,
                blend: if key.alpha == 2 {
                    Blend::Over
                } else {
                    Blend::Off
                },
                ..base.clone()
            };
            out.insert(key, desc.build(self.ctx)?);
        }
        Ok(out)
    }
}

/// The scene pipelines of one pass: without the section plane's clip
/// distance, and — built the first time a frame has a plane — with it.
/// A clip-distance output costs even when it never cuts (see
/// `shaders/scene_vert_body.glsl`), so frames without a plane draw with
/// the plain ones.
#[derive(Default)]
pub struct ScenePipelines {
    plain: HashMap<PipelineKey, vk::Pipeline>,
    clipped: HashMap<PipelineKey, vk::Pipeline>,
}

impl ScenePipelines {
    /// The plain pipelines (the clipped ones come with [`Self::set_clipped`]).
    pub fn new(plain: HashMap<PipelineKey, vk::Pipeline>) -> ScenePipelines {
        ScenePipelines {
            plain,
            clipped: HashMap::new(),
        }
    }

    /// Whether the clipped pipelines exist.
    pub fn has_clipped(&self) -> bool {
        !self.clipped.is_empty() || self.plain.is_empty()
    }

    /// Adds the clipped pipelines.
    pub fn set_clipped(&mut self, clipped: HashMap<PipelineKey, vk::Pipeline>) {
        self.clipped = clipped;
    }

    /// The pipelines a frame with (`section`) or without a plane draws
    /// with; the clipped ones must have been built for a frame with one.
    pub fn get(&self, section: bool) -> &HashMap<PipelineKey, vk::Pipeline> {
        if section {
            &self.clipped
        } else {
            &self.plain
        }
    }

    /// Every pipeline, for destruction.
    pub fn all(&self) -> impl Iterator<Item = &vk::Pipeline> {
        self.plain.values().chain(self.clipped.values())
    }
}

/// The viewport and scissor covering all of `extent` (depth 0 to 1).
pub fn whole(extent: vk::Extent2D) -> (vk::Viewport, vk::Rect2D) {
    (
        vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        },
        vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        },
    )
}

/// Where the sky goes in `draws` (primitives keyed by `keys`): before the
/// first blended draw, else after the last.
pub fn sky_slot(keys: &[PipelineKey], draws: &[Draw]) -> usize {
    draws
        .iter()
        .position(|d| keys[d.primitive as usize].alpha == 2)
        .unwrap_or(draws.len())
}

/// Destroys `pipelines`, skipping null handles; the device must be idle.
pub fn destroy_pipelines<'p>(ctx: &Context, pipelines: impl IntoIterator<Item = &'p vk::Pipeline>) {
    for &p in pipelines {
        if p != vk::Pipeline::null() {
            // SAFETY: the device is idle and the pipeline belongs to the caller.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}

/// Stencil state that sets `bits` wherever the pipeline rasterizes (the
/// hidden-area and RDM masks).
pub fn stencil_write(bits: u32) -> vk::StencilOpState {
    vk::StencilOpState {
        fail_op: vk::StencilOp::KEEP,
        pass_op: vk::StencilOp::REPLACE,
        depth_fail_op: vk::StencilOp::REPLACE,
        compare_op: vk::CompareOp::ALWAYS,
        compare_mask: bits,
        write_mask: bits,
        reference: bits,
    }
}

/// Makes a rendered colour image readable by fragment shaders.
pub fn to_sampled(image: &Image) -> vk::ImageMemoryBarrier2<'static> {
    barrier::image(
        image.image,
        vk::ImageAspectFlags::COLOR,
        image.layers,
        Use::COLOR_ATTACHMENT,
        Use::SAMPLED,
    )
}

/// A pass that writes each attachment set's composed output image from
/// sampled frames (RDM's fill, LMS's resample), timed as `name`:
/// `sources` are made readable first (all of them: the shaders index
/// arrays of every set's frames), then per set one full-screen triangle of
/// `pipeline` with the push constants `push(eye)` over `extent`. Returns
/// the draw calls.
#[allow(clippy::too_many_arguments)]
pub fn record_composed<'a>(
    rec: &Recorder,
    q: &mut Queries,
    name: &'static str,
    targets: &Attachments,
    sources: impl Iterator<Item = &'a AttachmentSet>,
    (extent, view_mask): (vk::Extent2D, u32),
    pipeline: vk::Pipeline,
    push: impl Fn(u32) -> [u32; 4],
) -> u64 {
    let to_read: Vec<vk::ImageMemoryBarrier2> =
        sources.map(|set| to_sampled(&set.resolve)).collect();
    rec.barriers(&to_read);
    record_per_set(
        rec,
        q,
        name,
        &targets.sets,
        (extent, view_mask, [0.0; 2]),
        (pipeline, crate::gpu::rendering::Load::Discard),
        |set| set.filled.as_ref().map(|(composed, _)| composed.view),
        push,
    )
}

/// Inside the GPU pass `name`, per attachment set of `targets` one
/// full-screen triangle of `pipeline` with the push constants `push(eye)`
/// over `extent` (its viewport moved by `jitter` pixels, as the scopes it
/// follows were), into the colour image `target(set)` picks (a set without
/// one is skipped), started as `load` says; the caller has made what the
/// pipeline reads readable and the targets writable. The full-screen passes
/// (composites, the resolved sky) share it. Returns the draw calls.
#[allow(clippy::too_many_arguments)]
pub fn record_per_set(
    rec: &Recorder,
    q: &mut Queries,
    name: &'static str,
    targets: &[AttachmentSet],
    (extent, view_mask, jitter): (vk::Extent2D, u32, [f32; 2]),
    (pipeline, load): (vk::Pipeline, crate::gpu::rendering::Load),
    target: impl Fn(&AttachmentSet) -> Option<vk::ImageView>,
    push: impl Fn(u32) -> [u32; 4],
) -> u64 {
    q.begin_pass(rec.ctx, rec.cmd, name);
    let mut calls = 0;
    for (eye, set) in targets.iter().enumerate() {
        let Some(view) = target(set) else {
            continue;
        };
        rec.begin_color(view, extent, view_mask, load);
        // Its own viewport, scissor and sets: it follows other scopes (or
        // executed secondaries) whose state it must not rely on.
        rec.set_state(extent);
        rec.jitter(extent, jitter);
        rec.bind(pipeline);
        rec.push(push(eye as u32));
        rec.draw(3);
        rec.end_scope();
        calls += 1;
    }
    q.end_pass(rec.ctx, rec.cmd);
    calls
}

/// The scene's vertex buffer per stream (the defaults buffer, read at
/// stride 0, for streams the scene lacks) and their offsets, fixed at
/// creation.
pub struct VertexBindings {
    buffers: Vec<vk::Buffer>,
    offsets: Vec<u64>,
}

impl VertexBindings {
    /// The bindings of `scene`.
    pub fn new(scene: &SceneGpu) -> VertexBindings {
        // Offset of each stream's default value inside the defaults buffer.
        let default_offset = |stream: usize| match stream {
            2 => 0,
            3 | 4 => 16,
            5 => 32,
            _ => 48,
        };
        VertexBindings {
            buffers: scene
                .streams
                .iter()
                .map(|s| s.as_ref().map_or(scene.defaults.buffer, |b| b.buffer))
                .collect(),
            offsets: scene
                .streams
                .iter()
                .enumerate()
                .map(|(i, s)| if s.is_some() { 0 } else { default_offset(i) })
                .collect(),
        }
    }
}

pub use super::plan::ScopePart;

/// One rendering scope: where it draws and how it starts.
pub struct Scope {
    /// Which part of the frame's drawing it holds.
    pub part: ScopePart,
    /// The attachments.
    pub views: TargetViews,
    /// Viewport (from the origin), and render area and scissor unless
    /// `area` narrows them.
    pub extent: vk::Extent2D,
    /// A render area and scissor inside the extent (the inset); None: the
    /// whole extent.
    pub area: Option<vk::Rect2D>,
    /// Multiview mask (0: one view).
    pub view_mask: u32,
    /// Depth clear value (reverse-Z: 0 is infinitely far).
    pub depth_clear: f32,
    /// A fragment-shading-rate attachment and its texel size.
    pub shading_rate: Option<(vk::ImageView, (u32, u32))>,
    /// The scope's draws come from secondary command buffers
    /// (`--record-threads`): the primary only executes them, and each
    /// secondary sets its own state ([`Recorder::set_state`]).
    pub secondaries: bool,
    /// The sky is drawn after the resolve (`resolved-sky`): colour clears
    /// to transparent black so the resolved alpha is each pixel's
    /// coverage ([`resolved_sky`]).
    pub sky_after_resolve: bool,
    /// The scope's draws write every sample's colour (the sky, drawn at
    /// the far plane inside the frame's scopes, fills what geometry
    /// leaves, and no stencil keeps it out), so the colour is not cleared
    /// but started as don't-care. On the H200 at 4x the colour clear is
    /// 2.56 ms of an empty frame's 6.68
    /// (`bench/results/2026-12-03-h200-raster-floors.md`).
    pub colour_covered: bool,
    /// The viewport's sub-pixel offset, pixels (`inset-taa`'s jitter of
    /// the wide views; zero otherwise). The render area and scissor stay
    /// on whole pixels.
    pub jitter: [f32; 2],
}

/// Records a frame's commands: the command buffer, the device, this frame
/// slot's descriptor set and the scene's geometry.
pub struct Recorder<'a> {
    /// The device.
    pub ctx: &'a Context,
    /// The frame's command buffer (begun by the ring, not yet submitted).
    pub cmd: vk::CommandBuffer,
    /// The pipeline layout.
    pub layout: vk::PipelineLayout,
    /// This frame slot's descriptor set.
    pub set: vk::DescriptorSet,
    /// The scene.
    pub scene: &'a SceneGpu,
    /// Pipeline key per primitive.
    pub keys: &'a [PipelineKey],
    /// The scene's vertex buffers.
    pub vertices: &'a VertexBindings,
    /// How scene draws pass their per-draw data.
    pub draw: DrawBinding,
    /// Whether the frame has a section plane (its draws clip against it).
    pub section: bool,
    /// Inside an LMS scope: the quadrant the draws go to and the w-scaling
    /// pair the vertex shaders apply (zero on the native path, which
    /// scales in the rasterizer); None outside.
    pub lms: std::cell::Cell<Option<(u32, [f32; 2])>>,
}

impl Recorder<'_> {
    /// Binds compute `pipeline` and the descriptor sets of `sets` (from
    /// set 0 of its layout) for the dispatches that follow.
    pub fn bind_compute(
        &self,
        pipeline: vk::Pipeline,
        sets: &crate::gpu::pipeline::DescriptorSets,
    ) {
        let d = &self.ctx.device;
        // SAFETY: recording outside any rendering scope into the frame's
        // open command buffer; the pipeline was made with the sets' layout
        // and the sets were written before the frame.
        unsafe {
            d.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
            d.cmd_bind_descriptor_sets(
                self.cmd,
                vk::PipelineBindPoint::COMPUTE,
                sets.layout,
                0,
                &sets.sets,
                &[],
            );
        }
    }

    /// Pushes `words` to the compute stage of `layout` and dispatches
    /// `groups` workgroups (after [`Recorder::bind_compute`]).
    pub fn dispatch(&self, layout: vk::PipelineLayout, words: &[u32], groups: [u32; 3]) {
        let d = &self.ctx.device;
        // SAFETY: a compute pipeline of `layout` is bound; the words fit
        // its push-constant range.
        unsafe {
            d.cmd_push_constants(
                self.cmd,
                layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(words),
            );
            d.cmd_dispatch(self.cmd, groups[0], groups[1], groups[2]);
        }
    }

    /// Records global memory `barriers`.
    pub fn memory_barriers(&self, barriers: &[vk::MemoryBarrier2]) {
        // SAFETY: recording into the frame's open command buffer, outside
        // any rendering scope.
        unsafe {
            self.ctx.device.cmd_pipeline_barrier2(
                self.cmd,
                &vk::DependencyInfo::default().memory_barriers(barriers),
            )
        };
    }

    /// Records `barriers`.
    pub fn barriers(&self, barriers: &[vk::ImageMemoryBarrier2]) {
        // SAFETY: recording into the frame's open command buffer, outside
        // any rendering scope; the images belong to the renderer.
        unsafe {
            self.ctx.device.cmd_pipeline_barrier2(
                self.cmd,
                &vk::DependencyInfo::default().image_memory_barriers(barriers),
            )
        };
    }

    /// Begins the rendering scope `scope`: colour cleared to black (or to
    /// transparent black for `resolved-sky`, or started as don't-care when
    /// [`Scope::colour_covered`]) and stored (resolved by averaging at more
    /// than one sample), depth (and stencil, when the format has it)
    /// cleared (stored or resolved from sample zero only when the
    /// frame keeps its depth), the shading-rate attachment when given; then,
    /// unless the scope's contents come from secondaries (which set their
    /// own), sets the viewport and scissor to the whole extent and binds the
    /// descriptor sets ([`Recorder::set_state`]).
    pub fn begin_scope(&self, scope: &Scope) {
        let views = scope.views;
        let load = if scope.part == ScopePart::Second {
            vk::AttachmentLoadOp::LOAD
        } else {
            vk::AttachmentLoadOp::CLEAR
        };
        let colour_load = match load {
            vk::AttachmentLoadOp::CLEAR if scope.colour_covered => vk::AttachmentLoadOp::DONT_CARE,
            l => l,
        };
        let mut color = vk::RenderingAttachmentInfo::default()
            .image_view(views.color)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(colour_load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue {
                    float32: if scope.sky_after_resolve {
                        resolved_sky::CLEAR
                    } else {
                        [0.0, 0.0, 0.0, 1.0]
                    },
                },
            });
        let first = scope.part == ScopePart::First;
        if let Some(r) = views.resolve.filter(|_| !first) {
            color = color
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .resolve_mode(vk::ResolveModeFlags::AVERAGE)
                .resolve_image_view(r)
                .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        }
        let mut depth = vk::RenderingAttachmentInfo::default()
            .image_view(views.depth)
            .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .load_op(load)
            .store_op(if views.store_depth || first {
                vk::AttachmentStoreOp::STORE
            } else {
                vk::AttachmentStoreOp::DONT_CARE
            })
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: scope.depth_clear,
                    stencil: 0,
                },
            });
        if let Some(r) = views.depth_resolve.filter(|_| !first) {
            // Sample zero: the one depth resolve every device has
            // (Vulkan 1.2 requires it for depth and stencil alike).
            depth = depth
                .resolve_mode(vk::ResolveModeFlags::SAMPLE_ZERO)
                .resolve_image_view(r)
                .resolve_image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
        }
        let colors = [color];
        let mut rate_info = scope.shading_rate.map(|(view, texel)| {
            vk::RenderingFragmentShadingRateAttachmentInfoKHR::default()
                .image_view(view)
                .image_layout(vk::ImageLayout::FRAGMENT_SHADING_RATE_ATTACHMENT_OPTIMAL_KHR)
                .shading_rate_attachment_texel_size(vk::Extent2D {
                    width: texel.0,
                    height: texel.1,
                })
        });
        let area = scope.area.unwrap_or(vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: scope.extent,
        });
        let flags = if scope.secondaries {
            vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS
        } else {
            vk::RenderingFlags::empty()
        };
        let mut info = vk::RenderingInfo::default()
            .flags(flags)
            .render_area(area)
            .layer_count(1)
            .view_mask(scope.view_mask)
            .color_attachments(&colors)
            .depth_attachment(&depth);
        if views.stencil {
            info = info.stencil_attachment(&depth);
        }
        if let Some(r) = rate_info.as_mut() {
            info = info.push_next(r);
        }
        // SAFETY: recording into the frame's open command buffer outside any
        // rendering scope; the attachments were made writable by the
        // frame's begin barriers and belong to the renderer.
        unsafe { self.ctx.device.cmd_begin_rendering(self.cmd, &info) };
        if !scope.secondaries {
            self.set_state(scope.extent);
            self.jitter(scope.extent, scope.jitter);
            if let Some(a) = scope.area {
                // SAFETY: inside the scope just begun; the rectangle lies in
                // its render area.
                unsafe { self.ctx.device.cmd_set_scissor(self.cmd, 0, &[a]) };
            }
        }
    }

    /// Moves the viewport over `extent` by `jitter` pixels (`inset-taa`'s
    /// sub-pixel jitter); nothing when it is zero.
    pub fn jitter(&self, extent: vk::Extent2D, jitter: [f32; 2]) {
        if jitter == [0.0; 2] {
            return;
        }
        let (mut viewport, _) = whole(extent);
        viewport.x = jitter[0];
        viewport.y = jitter[1];
        // SAFETY: inside a rendering scope of `extent`.
        unsafe { self.ctx.device.cmd_set_viewport(self.cmd, 0, &[viewport]) };
    }

    /// Sets what draws inside a rendering scope need and a command buffer
    /// does not inherit: viewport and scissor over `extent`, the frame
    /// slot's descriptor set, and for `--per-draw ssbo` the record set.
    pub fn set_state(&self, extent: vk::Extent2D) {
        let (viewport, area) = whole(extent);
        let d = &self.ctx.device;
        // SAFETY: recording into an open command buffer inside (or
        // continuing) a rendering scope; the sets belong to the renderer and
        // match its pipeline layout.
        unsafe {
            d.cmd_set_viewport(self.cmd, 0, &[viewport]);
            d.cmd_set_scissor(self.cmd, 0, &[area]);
            d.cmd_bind_descriptor_sets(
                self.cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.layout,
                0,
                &[self.set],
                &[],
            );
            if self.draw.mode == PerDraw::Ssbo {
                d.cmd_bind_descriptor_sets(
                    self.cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.layout,
                    1,
                    &[self.draw.set],
                    &[],
                );
            }
        }
    }

    /// Begins a rendering scope of one colour attachment (started as `load`
    /// says, stored) over `extent`, with no depth; the caller has made the
    /// attachment's earlier writes visible to colour-attachment access.
    pub fn begin_color(
        &self,
        view: vk::ImageView,
        extent: vk::Extent2D,
        view_mask: u32,
        load: crate::gpu::rendering::Load,
    ) {
        // SAFETY: recording into the frame's open command buffer outside any
        // rendering scope; the attachment is in the colour attachment layout.
        unsafe {
            crate::gpu::rendering::begin_color(
                &self.ctx.device,
                self.cmd,
                view,
                extent,
                load,
                view_mask,
            )
        };
    }

    /// Ends the rendering scope begun last.
    pub fn end_scope(&self) {
        // SAFETY: a rendering scope of this command buffer is open.
        unsafe { self.ctx.device.cmd_end_rendering(self.cmd) };
    }

    /// Binds a graphics pipeline.
    pub fn bind(&self, pipeline: vk::Pipeline) {
        // SAFETY: recording into the open command buffer; the pipeline
        // belongs to the renderer and uses its layout.
        unsafe {
            self.ctx
                .device
                .cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::GRAPHICS, pipeline)
        };
    }

    /// Pushes the four push-constant words (material or flags, view offset,
    /// two extra words) for the following draws.
    pub fn push(&self, pc: [u32; 4]) {
        // SAFETY: recording into the open command buffer; the range matches
        // the pipeline layout's.
        unsafe {
            self.ctx.device.cmd_push_constants(
                self.cmd,
                self.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                as_bytes(&pc),
            )
        };
    }

    /// Pushes a geometry draw's words: its material, the view offset `eye`
    /// and the vertex shaders' w-scaling pair (zero outside an emulated
    /// LMS quadrant).
    pub fn push_draw(&self, material: u32, eye: u32) {
        let s = self.lms.get().map_or([0.0, 0.0], |q| q.1);
        self.push([material, eye, s[0].to_bits(), s[1].to_bits()]);
    }

    /// Draws `vertices` vertices of one instance without buffers (the
    /// shaders make their own positions).
    pub fn draw(&self, vertices: u32) {
        // SAFETY: inside a rendering scope with a pipeline bound.
        unsafe { self.ctx.device.cmd_draw(self.cmd, vertices, 1, 0, 0) };
    }

    /// Binds the scene's index buffer.
    pub fn bind_indices(&self) {
        // SAFETY: recording into the open command buffer; the buffer
        // belongs to the scene.
        unsafe {
            self.ctx.device.cmd_bind_index_buffer(
                self.cmd,
                self.scene.indices.buffer,
                0,
                vk::IndexType::UINT32,
            )
        };
    }

    /// Draws the full-screen triangle (indices 0, 1, 2 in the scene's index
    /// buffer, which must be bound) with `pipeline` for view `eye`; inside
    /// an LMS quadrant, the quadrant's two triangles (`sky_lms.vert`).
    pub fn draw_fullscreen(&self, pipeline: vk::Pipeline, eye: u32) {
        self.bind(pipeline);
        if let Some((q, _)) = self.lms.get() {
            self.push_draw(q, eye);
            self.draw(6);
            return;
        }
        self.push([0, eye, 0, 0]);
        let first = self.scene.fullscreen_first_index;
        // SAFETY: inside a rendering scope with the index buffer bound.
        unsafe {
            self.ctx
                .device
                .cmd_draw_indexed(self.cmd, 3, 1, first, 0, 0)
        };
    }

    /// Binds the scene's vertex streams and index buffer.
    pub fn bind_scene_geometry(&self) {
        let vb = self.vertices;
        // SAFETY: recording into the open command buffer; the buffers
        // belong to the scene.
        unsafe {
            self.ctx
                .device
                .cmd_bind_vertex_buffers(self.cmd, 0, &vb.buffers, &vb.offsets)
        };
        self.bind_indices();
    }

    /// Where the sky goes in `draws`: before the first blended draw, else
    /// after the last (reverse-Z: the sky fills only what opaque and masked
    /// draws left at depth 0, and blended draws must see it behind them).
    pub fn sky_slot(&self, draws: &[Draw]) -> usize {
        sky_slot(self.keys, draws)
    }

    /// Draws `draws`, whose first is draw `base` of the frame's list (its
    /// per-draw record), with `pipelines` for view `eye` (the push-constant
    /// view offset), and with `sky` = (pipeline, i) the sky just before
    /// `draws[i]` (i = len: after the last). Returns the draw calls.
    pub fn draw_batches(
        &self,
        draws: &[Draw],
        base: u32,
        pipelines: &HashMap<PipelineKey, vk::Pipeline>,
        sky: Option<(vk::Pipeline, usize)>,
        eye: u32,
    ) -> u64 {
        let d = &self.ctx.device;
        self.bind_scene_geometry();
        let mode = self.draw.mode;
        if mode != PerDraw::Push {
            // The material comes with the record; only the view offset is
            // pushed, once.
            self.push_draw(0, eye);
        }
        let mut draw_calls = 0;
        let mut bound = None;
        for (i, draw) in draws.iter().enumerate() {
            if let Some((sky, _)) = sky.filter(|&(_, at)| at == i) {
                self.draw_fullscreen(sky, eye);
                draw_calls += 1;
                bound = None;
            }
            let key = self.keys[draw.primitive as usize];
            if bound != Some(key) {
                self.bind(pipelines[&key]);
                bound = Some(key);
            }
            let r = self.scene.ranges[draw.primitive as usize];
            let record = base + i as u32;
            let first_instance = match mode {
                PerDraw::Push => {
                    self.push_draw(r.material, eye);
                    draw.first
                }
                PerDraw::Ubo => {
                    // SAFETY: recording inside a rendering scope; set 1 is
                    // the slot's record set and the offset lies inside its
                    // buffer (written for every draw of the frame).
                    unsafe {
                        d.cmd_bind_descriptor_sets(
                            self.cmd,
                            vk::PipelineBindPoint::GRAPHICS,
                            self.layout,
                            1,
                            &[self.draw.set],
                            &[record * self.draw.stride],
                        )
                    };
                    0
                }
                PerDraw::Ssbo => record,
            };
            // SAFETY: inside a rendering scope with a scene pipeline and the
            // scene's buffers bound; the range lies in the index buffer.
            unsafe {
                d.cmd_draw_indexed(
                    self.cmd,
                    r.index_count,
                    draw.count,
                    r.first_index,
                    r.vertex_offset,
                    first_instance,
                )
            };
            draw_calls += 1;
        }
        if let Some((sky, _)) = sky.filter(|&(_, at)| at >= draws.len()) {
            self.draw_fullscreen(sky, eye);
            draw_calls += 1;
        }
        draw_calls
    }
}
