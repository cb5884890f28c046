//! The stereo forward renderer. `Renderer::render` takes a rig (views) and
//! an optional visible-instance list, records one frame (multiview or
//! two-pass), submits it, waits, and returns the frame's statistics.
//! Everything it needs is created in `Renderer::new`; nothing is compiled or
//! allocated inside a measured frame except growing the visible buffer.

pub mod attachments;
pub mod batches;
pub mod descriptors;
pub mod scene_gpu;
pub mod uniforms;

pub use crate::gpu::shaders::shader_modules;

use crate::config::{RenderConfig, StereoMode};
use crate::error::{Error, Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc, Image, ImageDesc};
use crate::gpu::pipeline::GraphicsPipelineDesc;
use crate::gpu::query::{PipelineStats, Queries};
use crate::gpu::ring::{FrameRing, Garbage};
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::scene::Scene;
use crate::view::{foveation, HiddenArea, StereoRig};
use ash::vk;
use attachments::{Attachments, COLOR_FORMAT};
use batches::{Batcher, Batches, PipelineKey};
use descriptors::{Descriptors, SetContents};
use gpu_allocator::MemoryLocation;
use scene_gpu::{SceneGpu, STREAMS};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Instant;
use uniforms::FrameUniforms;

const FRAMES_IN_FLIGHT: usize = 2;
const UBO_SIZE: u64 = uniforms::SIZE;
/// Most hidden-area vertices per view (a triangle list).
pub const MAX_HIDDEN_VERTICES: usize = 3 * 4096;

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
}

/// Statistics of one rendered frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// Draw calls recorded (over both eyes in two-pass mode).
    pub draw_calls: u64,
    /// Instance-primitive pairs drawn (per frame, not per eye; a monoscopic
    /// far field's pass counts as well).
    pub instances_drawn: u64,
    /// Triangles submitted per frame (not per eye; a monoscopic far field's
    /// pass counts as well).
    pub triangles: u64,
    /// CPU times.
    pub cpu_ms: CpuTimes,
    /// GPU milliseconds per pass (timestamps).
    pub gpu_ms: BTreeMap<String, f64>,
    /// Pipeline statistics of the frame (both eyes).
    pub pipeline: Option<PipelineStats>,
}

/// What the floor measurements draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FloorKind {
    /// Clear the attachments only.
    Clear,
    /// One full-screen triangle with a trivial fragment shader.
    FullscreenTriangle,
}

/// What a frame is delivered to besides the renderer's own targets (an
/// OpenXR session's swapchains), fixed when the renderer is created.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputSpec {
    /// Format of the colour images (copied when it is the renderer's own
    /// format, blitted otherwise).
    pub color_format: vk::Format,
    /// Whether depth images receive the frame's depth (same format as the
    /// renderer's depth).
    pub depth: bool,
}

/// The images one frame is copied into: one per attachment set (a 2-layer
/// image under multiview, one image per eye in two-pass). Colour images
/// arrive and are left in COLOR_ATTACHMENT_OPTIMAL, depth images in
/// DEPTH_STENCIL_ATTACHMENT_OPTIMAL, as XR_KHR_vulkan_enable2 requires.
#[derive(Clone, Debug, Default)]
pub struct FrameOutput {
    /// Colour images, per set.
    pub color: Vec<vk::Image>,
    /// Depth images, per set (empty without a depth output).
    pub depth: Vec<vk::Image>,
}

struct Pending {
    stats: FrameStats,
    queries: Queries,
    batches: Batches,
    cmd: vk::CommandBuffer,
}

/// The stereo renderer.
pub struct Renderer {
    ctx: Arc<Context>,
    /// The configuration it was built for.
    pub config: RenderConfig,
    extent: vk::Extent2D,
    scene: Option<SceneGpu>,
    targets: Option<Attachments>,
    descriptors: Descriptors,
    ubos: Vec<Buffer>,
    visible: Vec<Option<Buffer>>,
    pipelines: HashMap<PipelineKey, vk::Pipeline>,
    sky: vk::Pipeline,
    flat: vk::Pipeline,
    ring: Option<FrameRing>,
    queries: Vec<Option<Queries>>,
    slot: usize,
    readback: Option<Buffer>,
    batcher: Batcher,
    batches: Batches,
    output: Option<OutputSpec>,
    pending: Option<Pending>,
    hidden_pipeline: vk::Pipeline,
    hidden: Vec<HiddenSlot>,
    rates: Vec<Image>,
    rdm_pipeline: vk::Pipeline,
    fill_pipeline: vk::Pipeline,
    fill_sampler: vk::Sampler,
    far: Option<FarField>,
    /// Vertex buffer per stream (the defaults buffer for absent streams)
    /// and offsets, fixed at creation.
    vertex_buffers: Vec<vk::Buffer>,
    vertex_offsets: Vec<u64>,
    /// This frame's monoscopic far field: split distance, and which of the
    /// (up to two) far images are rendered this frame.
    mffr_frame: Option<(f64, [bool; 2])>,
    /// The view each far image was (or is being) rendered from (UBO views
    /// 2 and 3).
    far_views: [Option<crate::view::View>; 2],
    frame_index: u64,
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
}

/// The monoscopic far field's own target, pipelines (no view mask) and
/// composite.
struct FarField {
    /// One far image, or one per eye (alternate eye).
    sets: Vec<attachments::AttachmentSet>,
    extent: vk::Extent2D,
    pipelines: HashMap<PipelineKey, vk::Pipeline>,
    sky: vk::Pipeline,
    composite: vk::Pipeline,
    sampler: vk::Sampler,
}

/// Far-field image width relative to an eye's: the centre camera's union
/// FOV is wider than one eye's by the other eye's extra coverage.
const FAR_WIDTH_SCALE: f64 = 1.25;

/// One frame slot's hidden-area vertices (HMD stencil mask).
struct HiddenSlot {
    buffer: Buffer,
    source: Option<Arc<Vec<HiddenArea>>>,
    /// Vertices per view (the stride between views in the buffer).
    per_view: u32,
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
        let samples = config.msaa.min(ctx.caps.max_samples);
        let scene_gpu = SceneGpu::new(&ctx, scene)?;
        let descriptors =
            Descriptors::new(&ctx, scene_gpu.textures.len() as u32, FRAMES_IN_FLIGHT)?;
        let d = &ctx.device;
        let mut ubos = Vec::new();
        for i in 0..FRAMES_IN_FLIGHT {
            ubos.push(Buffer::new(
                &ctx,
                &BufferDesc {
                    name: &format!("frame data {i}"),
                    size: UBO_SIZE,
                    usage: vk::BufferUsageFlags::UNIFORM_BUFFER,
                    location: MemoryLocation::CpuToGpu,
                    category: "per-frame",
                },
            )?);
        }
        let mut hidden = Vec::new();
        for i in 0..FRAMES_IN_FLIGHT {
            let size = if config.stencil_mask {
                (2 * MAX_HIDDEN_VERTICES * 8) as u64
            } else {
                64
            };
            hidden.push(HiddenSlot {
                buffer: Buffer::new(
                    &ctx,
                    &BufferDesc {
                        name: &format!("hidden area {i}"),
                        size,
                        usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                        location: MemoryLocation::CpuToGpu,
                        category: "per-frame",
                    },
                )?,
                source: None,
                per_view: 0,
            });
        }
        let ring = FrameRing::new(&ctx, FRAMES_IN_FLIGHT)?;
        let mut queries = Vec::new();
        for _ in 0..FRAMES_IN_FLIGHT {
            queries.push(Some(Queries::new(&ctx, 8)?));
        }
        let batcher = Batcher::new(scene);
        let vertex_buffers: Vec<vk::Buffer> = scene_gpu
            .streams
            .iter()
            .map(|s| s.as_ref().map_or(scene_gpu.defaults.buffer, |b| b.buffer))
            .collect();
        let vertex_offsets: Vec<u64> = scene_gpu
            .streams
            .iter()
            .enumerate()
            .map(|(i, s)| if s.is_some() { 0 } else { default_offset(i) })
            .collect();
        let mut r = Renderer {
            ctx: ctx.clone(),
            config: RenderConfig {
                msaa: samples,
                ..config.clone()
            },
            extent,
            scene: Some(scene_gpu),
            targets: None,
            descriptors,
            ubos,
            visible: (0..FRAMES_IN_FLIGHT).map(|_| None).collect(),
            pipelines: HashMap::new(),
            sky: vk::Pipeline::null(),
            flat: vk::Pipeline::null(),
            ring: Some(ring),
            queries,
            slot: 0,
            readback: None,
            batcher,
            batches: Batches::default(),
            output,
            pending: None,
            hidden_pipeline: vk::Pipeline::null(),
            hidden,
            rates: Vec::new(),
            rdm_pipeline: vk::Pipeline::null(),
            fill_pipeline: vk::Pipeline::null(),
            fill_sampler: vk::Sampler::null(),
            far: None,
            vertex_buffers,
            vertex_offsets,
            mffr_frame: None,
            far_views: [None, None],
            frame_index: 0,
            mffr_fallbacks: 0,
            mffr_partition: !config.mffr.is_some_and(|m| m.no_split),
            foveation_path: "off".into(),
        };
        if config.mffr.is_some() {
            let far_extent = vk::Extent2D {
                width: ((extent.width as f64 * FAR_WIDTH_SCALE).ceil() as u32).min(16384),
                height: extent.height,
            };
            let count = if config.mffr.is_some_and(|m| m.alternate_eye) {
                2
            } else {
                1
            };
            let mut far_sets = Vec::new();
            for _ in 0..count {
                far_sets.push(attachments::AttachmentSet::new(
                    &ctx, far_extent, samples, 1, false, false, true,
                )?);
            }
            let info = vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::LINEAR)
                .min_filter(vk::Filter::LINEAR)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE);
            // SAFETY: plain object creation; destroyed in Drop.
            let sampler =
                unsafe { d.create_sampler(&info, None) }.vk("creating the far-field sampler")?;
            r.far = Some(FarField {
                sets: far_sets,
                extent: far_extent,
                pipelines: HashMap::new(),
                sky: vk::Pipeline::null(),
                composite: vk::Pipeline::null(),
                sampler,
            });
        }
        if config.rdm.is_some() && config.rdm_fill {
            let info = vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE);
            // SAFETY: plain object creation; destroyed in Drop.
            r.fill_sampler =
                unsafe { d.create_sampler(&info, None) }.vk("creating the RDM fill sampler")?;
        }
        r.setup_foveation()?;
        r.targets = Some(Attachments::new(
            &ctx,
            extent,
            samples,
            config.stereo == StereoMode::Multiview,
            output.is_some_and(|o| o.depth),
            config.rdm.is_some() && config.rdm_fill,
        )?);
        r.build_pipelines()?;
        for i in 0..FRAMES_IN_FLIGHT {
            r.ensure_visible_capacity(i, scene.instances.len().max(1))?;
        }
        Ok(r)
    }

    /// The device context.
    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// Per-eye image size.
    pub fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    fn view_mask(&self) -> u32 {
        match self.config.stereo {
            StereoMode::Multiview => 0b11,
            StereoMode::TwoPass => 0,
        }
    }

    fn build_pipelines(&mut self) -> Result<()> {
        let ctx = &self.ctx;
        let scene = self.scene.as_ref().expect("scene present until drop");
        let features = scene.features;
        let vs = shaders::SCENE_VERT.words();
        let fs = shaders::SCENE_FRAG.words();
        let fs_early = shaders::SCENE_EARLY_FRAG.words();
        let hidden_vs = shaders::HIDDEN_VERT.words();
        let composite_fs = shaders::MFFR_COMPOSITE_FRAG.words();
        let rdm_fs = shaders::RDM_FRAG.words();
        let fill_fs = shaders::RDM_FILL_FRAG.words();
        let full = shaders::FULLSCREEN_VERT.words();
        let sky = shaders::SKY_FRAG.words();
        let floor_vs = shaders::FLOOR_VERT.words();
        let flat = shaders::FLAT_FRAG.words();
        let used = scene_gpu::used_streams(&features);
        let formats = [
            vk::Format::R32G32B32_SFLOAT,
            vk::Format::R32G32B32_SFLOAT,
            vk::Format::R32G32B32A32_SFLOAT,
            vk::Format::R32G32_SFLOAT,
            vk::Format::R32G32_SFLOAT,
            vk::Format::R32G32B32A32_SFLOAT,
        ];
        let bindings: Vec<_> = (0..6)
            .map(|i| vk::VertexInputBindingDescription {
                binding: i as u32,
                stride: if used[i] { STREAMS[i].1 } else { 0 },
                input_rate: vk::VertexInputRate::VERTEX,
            })
            .collect();
        let attributes: Vec<_> = (0..6)
            .map(|i| vk::VertexInputAttributeDescription {
                location: i as u32,
                binding: i as u32,
                format: formats[i],
                offset: 0,
            })
            .collect();
        let base = GraphicsPipelineDesc {
            name: "scene",
            vertex: &vs,
            fragment: &fs,
            specialization: Vec::new(),
            bindings,
            attributes,
            cull_mode: vk::CullModeFlags::BACK,
            depth_test: true,
            depth_write: true,
            depth_compare: vk::CompareOp::GREATER,
            // With the stencil mask (bit 0) or RDM (bit 1), every draw passes
            // only where neither pass wrote stencil.
            stencil: (self.config.stencil_mask || self.config.rdm.is_some()).then_some(
                vk::StencilOpState {
                    fail_op: vk::StencilOp::KEEP,
                    pass_op: vk::StencilOp::KEEP,
                    depth_fail_op: vk::StencilOp::KEEP,
                    compare_op: vk::CompareOp::EQUAL,
                    compare_mask: 3,
                    write_mask: 0,
                    reference: 0,
                },
            ),
            blend: false,
            color_write: true,
            samples: vk::SampleCountFlags::from_raw(self.config.msaa),
            color_format: COLOR_FORMAT,
            depth_format: ctx.caps.depth_format,
            view_mask: self.view_mask(),
            layout: self.descriptors.layout,
            shading_rate_attachment: !self.rates.is_empty(),
        };
        let mut keys: Vec<PipelineKey> = self.batcher.keys.clone();
        keys.sort();
        keys.dedup();
        let scene_set =
            |base: &GraphicsPipelineDesc| -> Result<HashMap<PipelineKey, vk::Pipeline>> {
                let mut out = HashMap::new();
                for &key in &keys {
                    let name = format!(
                        "scene alpha={} double_sided={} unlit={}",
                        key.alpha, key.double_sided, key.unlit
                    );
                    let desc = GraphicsPipelineDesc {
                        name: &name,
                        fragment: if key.alpha == 1 { &fs } else { &fs_early },
                        specialization: vec![
                            (0, scene.textures.len() as u32),
                            (1, key.alpha as u32),
                            (2, features.tangents as u32),
                            (3, key.unlit as u32),
                        ],
                        cull_mode: if key.double_sided {
                            vk::CullModeFlags::NONE
                        } else {
                            vk::CullModeFlags::BACK
                        },
                        depth_write: key.alpha < 2,
                        blend: key.alpha == 2,
                        ..base.clone()
                    };
                    out.insert(key, desc.build(ctx)?);
                }
                Ok(out)
            };
        self.pipelines = scene_set(&base)?;
        let far_base = GraphicsPipelineDesc {
            view_mask: 0,
            shading_rate_attachment: false,
            ..base.clone()
        };
        if let Some(far) = self.far.as_mut() {
            far.pipelines = scene_set(&far_base)?;
        }
        let fullscreen = GraphicsPipelineDesc {
            name: "sky",
            vertex: &full,
            fragment: &sky,
            bindings: Vec::new(),
            attributes: Vec::new(),
            cull_mode: vk::CullModeFlags::NONE,
            depth_write: false,
            depth_compare: vk::CompareOp::GREATER_OR_EQUAL,
            ..base.clone()
        };
        self.sky = fullscreen.build(ctx)?;
        self.flat = GraphicsPipelineDesc {
            name: "raster floor",
            vertex: &floor_vs,
            fragment: &flat,
            depth_test: false,
            ..fullscreen.clone()
        }
        .build(ctx)?;
        if let Some(far) = self.far.as_mut() {
            far.sky = GraphicsPipelineDesc {
                name: "far-field sky",
                view_mask: 0,
                shading_rate_attachment: false,
                ..fullscreen.clone()
            }
            .build(ctx)?;
            far.composite = GraphicsPipelineDesc {
                name: "far-field composite",
                vertex: &full,
                fragment: &composite_fs,
                depth_test: false,
                depth_write: false,
                ..fullscreen.clone()
            }
            .build(ctx)?;
        }
        if self.config.rdm.is_some() {
            self.rdm_pipeline = GraphicsPipelineDesc {
                name: "rdm checkerboard stencil",
                vertex: &floor_vs,
                fragment: &rdm_fs,
                depth_test: false,
                depth_write: false,
                color_write: false,
                stencil: Some(stencil_write(2)),
                ..fullscreen.clone()
            }
            .build(ctx)?;
        }
        if self.config.rdm.is_some() && self.config.rdm_fill {
            self.fill_pipeline = GraphicsPipelineDesc {
                name: "rdm fill",
                vertex: &floor_vs,
                fragment: &fill_fs,
                depth_test: false,
                depth_write: false,
                stencil: None,
                samples: vk::SampleCountFlags::TYPE_1,
                depth_format: vk::Format::UNDEFINED,
                shading_rate_attachment: false,
                ..fullscreen.clone()
            }
            .build(ctx)?;
        }
        if self.config.stencil_mask {
            self.hidden_pipeline = GraphicsPipelineDesc {
                name: "hidden-area stencil",
                vertex: &hidden_vs,
                fragment: &flat,
                depth_test: false,
                depth_write: false,
                color_write: false,
                stencil: Some(stencil_write(1)),
                ..fullscreen
            }
            .build(ctx)?;
        }
        Ok(())
    }

    /// Chooses the foveation path by capability and, for the
    /// fragment-shading-rate path, builds and uploads the rate images.
    fn setup_foveation(&mut self) -> Result<()> {
        use foveation::Level;
        if self.config.foveation == Level::Off {
            return Ok(());
        }
        let Some(texel) = self.ctx.caps.shading_rate_texel else {
            let path = format!(
                "off: {} offers no VK_KHR_fragment_shading_rate attachment{}, and XR_FB_foveation is not in use",
                self.ctx.device_name,
                if self.ctx.caps.fragment_density_map {
                    " (VK_EXT_fragment_density_map is offered but not implemented yet)"
                } else {
                    " nor VK_EXT_fragment_density_map"
                }
            );
            tracing::warn!("foveation {:?} requested; {path}", self.config.foveation);
            eprintln!("warning: foveation falls back to {path}");
            self.foveation_path = path;
            self.config.foveation = Level::Off;
            return Ok(());
        };
        let (tw, th, data) = foveation::rate_image(
            self.config.foveation,
            self.config.gaze,
            self.extent.width,
            self.extent.height,
            texel,
        );
        let layers = if self.config.stereo == StereoMode::Multiview {
            2
        } else {
            1
        };
        let sets = if layers == 2 { 1 } else { 2 };
        let mut staging = Buffer::new(
            &self.ctx,
            &BufferDesc {
                name: "shading rate staging",
                size: (data.len() * layers as usize) as u64,
                usage: vk::BufferUsageFlags::TRANSFER_SRC,
                location: MemoryLocation::CpuToGpu,
                category: "staging",
            },
        )?;
        for l in 0..layers as usize {
            staging.write(l * data.len(), &data)?;
        }
        for _ in 0..sets {
            self.rates.push(Image::new(
                &self.ctx,
                &ImageDesc {
                    name: "shading rate",
                    format: vk::Format::R8_UINT,
                    extent: vk::Extent2D {
                        width: tw,
                        height: th,
                    },
                    layers,
                    mips: 1,
                    samples: vk::SampleCountFlags::TYPE_1,
                    usage: vk::ImageUsageFlags::FRAGMENT_SHADING_RATE_ATTACHMENT_KHR
                        | vk::ImageUsageFlags::TRANSFER_DST,
                    aspect: vk::ImageAspectFlags::COLOR,
                    category: "render target",
                },
            )?);
        }
        let d = &self.ctx.device;
        let rates = &self.rates;
        let buf = staging.buffer;
        let upload = self.ctx.one_shot(|cmd| {
            for img in rates {
                let color = vk::ImageAspectFlags::COLOR;
                let to_dst = [barrier::image(
                    img.image,
                    color,
                    layers,
                    Use::TRANSFER_DST.discarded(),
                    Use::TRANSFER_DST,
                )];
                let copy = barrier::color_copy(0, layers, tw, th);
                let to_rate = [barrier::image(
                    img.image,
                    color,
                    layers,
                    Use::TRANSFER_DST,
                    Use::SHADING_RATE,
                )];
                // SAFETY: recording into the one-shot command buffer; the
                // staging buffer holds `layers` copies of the rate image.
                unsafe {
                    d.cmd_pipeline_barrier2(
                        cmd,
                        &vk::DependencyInfo::default().image_memory_barriers(&to_dst),
                    );
                    d.cmd_copy_buffer_to_image(
                        cmd,
                        buf,
                        img.image,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &[copy],
                    );
                    d.cmd_pipeline_barrier2(
                        cmd,
                        &vk::DependencyInfo::default().image_memory_barriers(&to_rate),
                    );
                }
            }
        });
        staging.destroy(&self.ctx);
        upload?;
        self.foveation_path = format!(
            "vk-khr-fragment-shading-rate ({}x{} texels, {:.0} % of full-rate shading)",
            texel.0,
            texel.1,
            100.0
                * foveation::shaded_fraction(
                    self.config.foveation,
                    self.config.gaze,
                    self.extent.width,
                    self.extent.height,
                    texel
                )
        );
        Ok(())
    }

    fn ensure_visible_capacity(&mut self, slot: usize, ids: usize) -> Result<()> {
        let need = (ids.max(1) * 4) as u64;
        if self.visible[slot].as_ref().is_some_and(|b| b.size >= need) {
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
        if let Some(old) = self.visible[slot].replace(buf) {
            match self.ring.as_mut() {
                Some(r) => r.defer(Garbage::Buffer(old)),
                None => old.destroy(&self.ctx),
            }
        }
        self.write_descriptors(slot);
        Ok(())
    }

    fn write_descriptors(&self, slot: usize) {
        let Some(visible) = &self.visible[slot] else {
            return;
        };
        let filled = self.targets.as_ref().and_then(|t| {
            let mut views = t.sets.iter().filter_map(|s| s.filled.as_ref().map(|f| f.1));
            let first = views.next()?;
            let info = |image_view| vk::DescriptorImageInfo {
                sampler: self.fill_sampler,
                image_view,
                image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            };
            Some([info(first), info(views.next().unwrap_or(first))])
        });
        let far_field = self.far.as_ref().map(|f| {
            std::array::from_fn(|i| vk::DescriptorImageInfo {
                sampler: f.sampler,
                image_view: f.sets.get(i).unwrap_or(&f.sets[0]).resolve.view,
                image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            })
        });
        let contents = SetContents {
            frame: &self.ubos[slot],
            scene: self.scene.as_ref().expect("scene present until drop"),
            visible,
            hidden: Some(self.hidden[slot].buffer.buffer),
            filled,
            far_field,
        };
        self.descriptors.write(&self.ctx, slot, &contents);
    }

    fn frame_data(&self, rig: &StereoRig) -> FrameUniforms {
        // Views 2 and 3 are the far-field cameras; their near plane is the
        // split distance, so everything nearer is clipped from the far field.
        let far_near = self.mffr_frame.as_ref().map_or(self.config.near, |m| m.0);
        FrameUniforms::new(rig, self.config.near, self.far_views, far_near)
    }

    /// Renders one stereo frame of `rig` drawing the instances in `visible`
    /// (None: all), waits for it and returns its statistics. With
    /// `readback`, the frame is copied for [`Renderer::read_images`].
    pub fn render(
        &mut self,
        rig: &StereoRig,
        visible: Option<&[u32]>,
        readback: bool,
    ) -> Result<FrameStats> {
        self.record_frame(rig, visible)?;
        self.submit_frame(None, readback)
    }

    /// Batches and records one stereo frame of `rig` (the command buffer
    /// stays open); [`Renderer::submit_frame`] completes it.
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
        let mut stats = FrameStats::default();
        let t0 = Instant::now();
        self.mffr_frame = match self.config.mffr {
            Some(m) => {
                let split = m
                    .split
                    .unwrap_or_else(|| crate::view::mffr::auto_split(rig, self.extent.width));
                match crate::view::mffr::centre_view(rig) {
                    Some(centre) if m.alternate_eye => {
                        // Eye p's far image is re-rendered this frame (both
                        // on the first); each from its eye, covering the
                        // centre camera's union FOV.
                        let p = (self.frame_index % 2) as usize;
                        let mut render = [false; 2];
                        for (i, v) in rig.views.iter().take(2).enumerate() {
                            if i == p || self.far_views[i].is_none() {
                                self.far_views[i] = Some(crate::view::View {
                                    pose: crate::view::Pose {
                                        position: v.pose.position,
                                        orientation: centre.pose.orientation,
                                    },
                                    fov: centre.fov,
                                });
                                render[i] = true;
                            }
                        }
                        Some((split, render))
                    }
                    Some(centre) => {
                        self.far_views = [Some(centre), None];
                        Some((split, [true, false]))
                    }
                    None => {
                        self.mffr_fallbacks += 1;
                        self.far_views = [None, None];
                        None
                    }
                }
            }
            None => None,
        };
        let mut batches = std::mem::take(&mut self.batches);
        match &self.mffr_frame {
            Some((split, render)) if self.mffr_partition => {
                // Conservative per-instance split by view depth (the near
                // field is cut at depth D in each eye, the far field starts
                // at depth D from its camera): a bounding sphere whose
                // nearest depth in some eye is before D feeds the near
                // field, one whose farthest depth from some far camera is
                // beyond D the far field. Margins cover f32 rounding.
                let d = *split;
                let margin = 1e-3 * d + 1e-3;
                // Fixed-size: the frame allocates nothing (two views are
                // checked above; at most two far cameras).
                let axis = |v: &crate::view::View| (v.pose.position, v.pose.forward());
                let eyes = [axis(&rig.views[0]), axis(&rig.views[1])];
                let mut fars = [None; 2];
                for i in (0..2).filter(|&i| render[i]) {
                    fars[i] = self.far_views[i].as_ref().map(axis);
                }
                self.batcher.build_split(
                    visible,
                    rig.head.position,
                    |c, r| eyes.iter().any(|(p, f)| (c - *p).dot(*f) - r < d + margin),
                    |c, r| {
                        fars.iter()
                            .flatten()
                            .any(|(p, f)| (c - *p).dot(*f) + r > d - margin)
                    },
                    &mut batches,
                );
            }
            _ => self.batcher.build(visible, rig.head.position, &mut batches),
        }
        // Counted once per pass family: with a far field its pass draws too
        // (the split batches already hold near + far; unsplit, the far pass
        // draws every batch again).
        let passes = if self.mffr_frame.is_some() && batches.far_start.is_none() {
            2
        } else {
            1
        };
        stats.instances_drawn = passes * batches.instances_drawn;
        stats.triangles = passes * batches.triangles;
        let slot = self.slot;
        let cmd = self
            .ring
            .as_mut()
            .expect("ring present until drop")
            .begin(&self.ctx)?;
        self.ensure_visible_capacity(slot, batches.ids.len())?;
        let ids: &[u8] = as_bytes(&batches.ids);
        self.visible[slot]
            .as_mut()
            .expect("allocated above")
            .write(0, ids)?;
        self.frame_index += 1;
        let data = self.frame_data(rig);
        self.ubos[slot].write(0, as_bytes(std::slice::from_ref(&data)))?;
        if self.config.stencil_mask {
            self.upload_hidden(slot, rig)?;
        }
        let t1 = Instant::now();
        stats.cpu_ms.batch = ms(t0, t1);

        let mut queries = self.queries[slot]
            .take()
            .expect("queries present until drop");
        queries.reset(&self.ctx, cmd);
        stats.draw_calls = self.record(cmd, &batches, &mut queries, None);
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
    /// `output` when given), submits, waits and returns the statistics.
    pub fn submit_frame(
        &mut self,
        output: Option<&FrameOutput>,
        readback: bool,
    ) -> Result<FrameStats> {
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
        self.queries[slot] = Some(queries);
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
        self.slot = (slot + 1) % FRAMES_IN_FLIGHT;
        let last_pass = self.queries[slot]
            .as_ref()
            .map_or("none", |q| q.last_pass());
        let lost = |e: Error, context: &str| match e {
            Error::Vulkan {
                result: vk::Result::ERROR_DEVICE_LOST,
                ..
            } => Error::DeviceLost {
                context: context.to_string(),
                pass: last_pass.to_string(),
            },
            other => other,
        };
        submit.map_err(|e| lost(e, "submitting a frame"))?;
        let waited = if crate::gpu::fault::device_lost_frame() == Some(self.frame_index) {
            Err(Error::Vulkan {
                context: "waiting for frames (injected by VERGENCE_INJECT_FAULT)".into(),
                result: vk::Result::ERROR_DEVICE_LOST,
            })
        } else {
            self.ring
                .as_mut()
                .expect("ring present until drop")
                .wait_all(&self.ctx)
        };
        waited.map_err(|e| lost(e, "waiting for the frame to finish"))?;
        let t4 = Instant::now();
        stats.cpu_ms.wait = ms(t3, t4);
        let queries = self.queries[slot]
            .as_ref()
            .expect("queries present until drop");
        let (passes, pipeline) = queries.read(&self.ctx)?;
        for (name, ms) in passes {
            *stats.gpu_ms.entry(name.to_string()).or_insert(0.0) += ms;
        }
        stats.pipeline = pipeline;
        Ok(stats)
    }

    /// Writes `rig`'s hidden-area meshes (expanded to triangle lists) into
    /// `slot`'s buffer when they changed since that slot last saw them.
    fn upload_hidden(&mut self, slot: usize, rig: &StereoRig) -> Result<()> {
        let areas = rig.hidden_area.clone().ok_or_else(|| {
            Error::config(
                "--opt stencil-mask",
                "needs a hidden-area mesh (from the OpenXR runtime or the HMD profile)",
            )
        })?;
        let h = &mut self.hidden[slot];
        if h.source
            .as_ref()
            .is_some_and(|s| Arc::ptr_eq(s, &areas) || **s == *areas)
        {
            return Ok(());
        }
        let lists: Vec<Vec<[f32; 2]>> = (0..2)
            .map(|v| {
                areas.get(v).map_or(Vec::new(), |a| {
                    a.indices
                        .chunks_exact(3)
                        .filter(|t| t.iter().all(|&i| (i as usize) < a.vertices.len()))
                        .flatten()
                        .map(|&i| a.vertices[i as usize])
                        .collect()
                })
            })
            .collect();
        let per_view = lists.iter().map(Vec::len).max().unwrap_or(0);
        if per_view > MAX_HIDDEN_VERTICES {
            return Err(Error::config(
                "hidden-area mesh",
                format!("{per_view} vertices per view; at most {MAX_HIDDEN_VERTICES}"),
            ));
        }
        let mut data = vec![0.0f32; 2 * per_view * 2];
        for (v, list) in lists.iter().enumerate() {
            for (i, p) in list.iter().enumerate() {
                data[(v * per_view + i) * 2] = p[0];
                data[(v * per_view + i) * 2 + 1] = p[1];
            }
        }
        if !data.is_empty() {
            h.buffer.write(0, as_bytes(&data))?;
        }
        h.per_view = per_view as u32;
        h.source = Some(areas);
        Ok(())
    }

    /// Renders a floor frame (clear only, or one full-screen triangle with a
    /// trivial shader) and returns its GPU milliseconds.
    pub fn render_floor(&mut self, kind: FloorKind) -> Result<f64> {
        let slot = self.slot;
        let cmd = self
            .ring
            .as_mut()
            .expect("ring present until drop")
            .begin(&self.ctx)?;
        let mut queries = self.queries[slot]
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
        self.queries[slot] = Some(queries);
        self.slot = (slot + 1) % FRAMES_IN_FLIGHT;
        Ok(passes.iter().map(|p| p.1).sum())
    }

    fn record(
        &self,
        cmd: vk::CommandBuffer,
        batches: &Batches,
        q: &mut Queries,
        floor: Option<FloorKind>,
    ) -> u64 {
        let ctx = &self.ctx;
        let d = &ctx.device;
        let targets = self.targets.as_ref().expect("targets present until drop");
        let scene = self.scene.as_ref().expect("scene present until drop");
        let barriers = targets.begin_barriers();
        let mut draw_calls = 0u64;
        // SAFETY: recording into a command buffer begun by the ring; every
        // handle is owned by this renderer and outlives the submission.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&barriers),
            );
            q.begin_stats(ctx, cmd);
            // With a monoscopic far field, the near field's depth starts at
            // the split plane (reverse-Z: near / D), so only geometry nearer
            // than D passes the depth test.
            let near_clear = match (&self.mffr_frame, floor) {
                (Some((split, _)), None) => (self.config.near / split).min(1.0) as f32,
                _ => 0.0,
            };
            if let (Some(far), None, Some((_, render))) = (&self.far, floor, &self.mffr_frame) {
                draw_calls += self.record_far(cmd, q, batches, far, render);
            }
            // (views, view mask, eye, pass name); an array, not a Vec: no
            // allocation while recording.
            let passes = match self.config.stereo {
                StereoMode::Multiview => {
                    [Some((targets.sets[0].views(), 0b11, 0, "forward")), None]
                }
                StereoMode::TwoPass => [
                    Some((targets.sets[0].views(), 0, 0, "forward")),
                    Some((targets.sets[1].views(), 0, 1, "forward")),
                ],
            };
            for (views, mask, eye, name) in passes.into_iter().flatten() {
                q.begin_pass(ctx, cmd, name);
                let clear_color = vk::ClearValue {
                    color: vk::ClearColorValue {
                        float32: [0.0, 0.0, 0.0, 1.0],
                    },
                };
                let mut color = vk::RenderingAttachmentInfo::default()
                    .image_view(views.color)
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(clear_color);
                if let Some(r) = views.resolve {
                    color = color
                        .store_op(vk::AttachmentStoreOp::DONT_CARE)
                        .resolve_mode(vk::ResolveModeFlags::AVERAGE)
                        .resolve_image_view(r)
                        .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
                }
                let mut depth = vk::RenderingAttachmentInfo::default()
                    .image_view(views.depth)
                    .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(if views.store_depth {
                        vk::AttachmentStoreOp::STORE
                    } else {
                        vk::AttachmentStoreOp::DONT_CARE
                    })
                    .clear_value(vk::ClearValue {
                        depth_stencil: vk::ClearDepthStencilValue {
                            depth: near_clear,
                            stencil: 0,
                        },
                    });
                if let Some(r) = views.depth_resolve {
                    // Sample zero: the one depth resolve every device has
                    // (Vulkan 1.2 requires it for depth and stencil alike).
                    depth = depth
                        .resolve_mode(vk::ResolveModeFlags::SAMPLE_ZERO)
                        .resolve_image_view(r)
                        .resolve_image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
                }
                let colors = [color];
                let mut rate_info = self.rates.get(eye as usize).map(|img| {
                    let texel = ctx.caps.shading_rate_texel.unwrap_or((1, 1));
                    vk::RenderingFragmentShadingRateAttachmentInfoKHR::default()
                        .image_view(img.view)
                        .image_layout(vk::ImageLayout::FRAGMENT_SHADING_RATE_ATTACHMENT_OPTIMAL_KHR)
                        .shading_rate_attachment_texel_size(vk::Extent2D {
                            width: texel.0,
                            height: texel.1,
                        })
                });
                let mut info = vk::RenderingInfo::default()
                    .render_area(vk::Rect2D {
                        offset: vk::Offset2D::default(),
                        extent: self.extent,
                    })
                    .layer_count(1)
                    .view_mask(mask)
                    .color_attachments(&colors)
                    .depth_attachment(&depth)
                    .stencil_attachment(&depth);
                if let Some(r) = rate_info.as_mut() {
                    info = info.push_next(r);
                }
                d.cmd_begin_rendering(cmd, &info);
                let (w, h) = (self.extent.width as f32, self.extent.height as f32);
                d.cmd_set_viewport(
                    cmd,
                    0,
                    &[vk::Viewport {
                        x: 0.0,
                        y: 0.0,
                        width: w,
                        height: h,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    }],
                );
                d.cmd_set_scissor(
                    cmd,
                    0,
                    &[vk::Rect2D {
                        offset: vk::Offset2D::default(),
                        extent: self.extent,
                    }],
                );
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.descriptors.layout,
                    0,
                    &[self.descriptors.sets[self.slot]],
                    &[],
                );
                let hidden = &self.hidden[self.slot];
                if self.config.stencil_mask && hidden.per_view > 0 {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.hidden_pipeline);
                    let pc = [0, eye, hidden.per_view, 0];
                    self.push_constants(cmd, pc);
                    d.cmd_draw(cmd, hidden.per_view, 1, 0, 0);
                    draw_calls += 1;
                }
                if let Some(radius) = self.config.rdm {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.rdm_pipeline);
                    let size = self.extent.width | self.extent.height << 16;
                    let pc = [0, eye, size, radius.to_bits()];
                    self.push_constants(cmd, pc);
                    d.cmd_draw(cmd, 3, 1, 0, 0);
                    draw_calls += 1;
                }
                let push = |material: u32| {
                    let pc = [material, eye, 0, 0];
                    self.push_constants(cmd, pc);
                };
                match floor {
                    Some(FloorKind::Clear) => {}
                    Some(FloorKind::FullscreenTriangle) => {
                        d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.flat);
                        push(0);
                        d.cmd_bind_index_buffer(
                            cmd,
                            scene.indices.buffer,
                            0,
                            vk::IndexType::UINT32,
                        );
                        d.cmd_draw_indexed(cmd, 3, 1, scene.fullscreen_first_index, 0, 0);
                        draw_calls += 1;
                    }
                    None => {
                        if let (Some((split, _)), Some(far)) = (&self.mffr_frame, &self.far) {
                            let m = self.config.mffr.unwrap_or_default();
                            let flags = m.depth_shift as u32 | (m.alternate_eye as u32) << 1;
                            d.cmd_bind_pipeline(
                                cmd,
                                vk::PipelineBindPoint::GRAPHICS,
                                far.composite,
                            );
                            let pc = [flags, eye, 0, (*split as f32).to_bits()];
                            self.push_constants(cmd, pc);
                            d.cmd_draw(cmd, 3, 1, 0, 0);
                            draw_calls += 1;
                            // The sky lies beyond the split: the far field has it.
                            draw_calls += self.draw_scene(
                                cmd,
                                batches.near_draws(),
                                &self.pipelines,
                                None,
                                eye,
                            );
                        } else {
                            draw_calls += self.draw_scene(
                                cmd,
                                batches.near_draws(),
                                &self.pipelines,
                                Some(self.sky),
                                eye,
                            );
                        }
                    }
                }
                d.cmd_end_rendering(cmd);
                q.end_pass(ctx, cmd);
            }
            if let Some(radius) = self.config.rdm.filter(|_| self.config.rdm_fill) {
                // Every set is transitioned before any fill draws: the fill
                // shader indexes the array of both sets' frames.
                self.record_fill(cmd, q, targets, radius);
                draw_calls += targets.sets.len() as u64;
            }
            q.end_stats(ctx, cmd);
        }
        draw_calls
    }

    /// The RDM reconstruction: each set's resolved frame is sampled and
    /// written, with the skipped quads filled, into its `filled` image.
    fn record_fill(
        &self,
        cmd: vk::CommandBuffer,
        q: &mut Queries,
        targets: &attachments::Attachments,
        radius: f32,
    ) {
        let ctx = &self.ctx;
        let d = &ctx.device;
        let to_read: Vec<vk::ImageMemoryBarrier2> = targets
            .sets
            .iter()
            .map(|set| to_sampled(&set.resolve))
            .collect();
        // SAFETY: recording after the rendering scopes; the resolve images
        // are transitioned for sampling and `filled` images are attachments.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_read),
            );
            q.begin_pass(ctx, cmd, "rdm-fill");
            for (eye, set) in targets.sets.iter().enumerate() {
                let Some((filled, _)) = &set.filled else {
                    continue;
                };
                let color = [vk::RenderingAttachmentInfo::default()
                    .image_view(filled.view)
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .load_op(vk::AttachmentLoadOp::DONT_CARE)
                    .store_op(vk::AttachmentStoreOp::STORE)];
                let info = vk::RenderingInfo::default()
                    .render_area(vk::Rect2D {
                        offset: vk::Offset2D::default(),
                        extent: self.extent,
                    })
                    .layer_count(1)
                    .view_mask(self.view_mask())
                    .color_attachments(&color);
                let pc = [0, eye as u32, 0, radius.to_bits()];
                d.cmd_begin_rendering(cmd, &info);
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.fill_pipeline);
                self.push_constants(cmd, pc);
                d.cmd_draw(cmd, 3, 1, 0, 0);
                d.cmd_end_rendering(cmd);
            }
            q.end_pass(ctx, cmd);
        }
    }

    /// Pushes the four push-constant words (material or flags, view offset,
    /// two extra words) for the following draws.
    fn push_constants(&self, cmd: vk::CommandBuffer, pc: [u32; 4]) {
        // SAFETY: called while recording `cmd`; the range matches the layout.
        unsafe {
            self.ctx.device.cmd_push_constants(
                cmd,
                self.descriptors.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                as_bytes(&pc),
            )
        };
    }

    /// Draws the batches with `pipelines` for view `eye` (the push-constant
    /// view offset), and the sky with `sky` (before the first blended batch)
    /// when given. Returns the draw calls.
    fn draw_scene(
        &self,
        cmd: vk::CommandBuffer,
        draws: &[batches::Draw],
        pipelines: &HashMap<PipelineKey, vk::Pipeline>,
        sky: Option<vk::Pipeline>,
        eye: u32,
    ) -> u64 {
        let d = &self.ctx.device;
        let scene = self.scene.as_ref().expect("scene present until drop");
        let push = |material: u32| self.push_constants(cmd, [material, eye, 0, 0]);
        let mut draw_calls = 0;
        // SAFETY: inside a rendering scope begun by the caller; every handle
        // is owned by this renderer.
        unsafe {
            d.cmd_bind_vertex_buffers(cmd, 0, &self.vertex_buffers, &self.vertex_offsets);
            d.cmd_bind_index_buffer(cmd, scene.indices.buffer, 0, vk::IndexType::UINT32);
            let mut bound = None;
            let mut sky_drawn = sky.is_none();
            for draw in draws {
                let key = self.batcher.keys[draw.primitive as usize];
                if key.alpha == 2 && !sky_drawn {
                    self.draw_sky(cmd, sky.expect("sky pending"), &push);
                    draw_calls += 1;
                    sky_drawn = true;
                    bound = None;
                }
                if bound != Some(key) {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipelines[&key]);
                    bound = Some(key);
                }
                let r = scene.ranges[draw.primitive as usize];
                push(r.material);
                d.cmd_draw_indexed(
                    cmd,
                    r.index_count,
                    draw.count,
                    r.first_index,
                    r.vertex_offset,
                    draw.first,
                );
                draw_calls += 1;
            }
            if !sky_drawn {
                self.draw_sky(cmd, sky.expect("sky pending"), &push);
                draw_calls += 1;
            }
        }
        draw_calls
    }

    /// The far field: the batches rendered once from the centre camera
    /// (view 2, near plane at the split distance) into the far target, which
    /// is then made readable for the composite.
    fn record_far(
        &self,
        cmd: vk::CommandBuffer,
        q: &mut Queries,
        batches: &Batches,
        far: &FarField,
        render: &[bool; 2],
    ) -> u64 {
        let ctx = &self.ctx;
        let d = &ctx.device;
        let mut draws = 0;
        q.begin_pass(ctx, cmd, "mffr-far");
        for i in (0..2).filter(|&i| render[i]) {
            let set = &far.sets[i];
            let barriers = attachments::begin_barriers(std::slice::from_ref(set));
            let views = set.views();
            let mut color = vk::RenderingAttachmentInfo::default()
                .image_view(views.color)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    color: vk::ClearColorValue {
                        float32: [0.0, 0.0, 0.0, 1.0],
                    },
                });
            if let Some(r) = views.resolve {
                color = color
                    .store_op(vk::AttachmentStoreOp::DONT_CARE)
                    .resolve_mode(vk::ResolveModeFlags::AVERAGE)
                    .resolve_image_view(r)
                    .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
            }
            let depth = vk::RenderingAttachmentInfo::default()
                .image_view(views.depth)
                .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        depth: 0.0,
                        stencil: 0,
                    },
                });
            let colors = [color];
            let area = vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent: far.extent,
            };
            let info = vk::RenderingInfo::default()
                .render_area(area)
                .layer_count(1)
                .color_attachments(&colors)
                .depth_attachment(&depth)
                .stencil_attachment(&depth);
            let to_read = [to_sampled(&set.resolve)];
            // SAFETY: recording into the frame's command buffer; the far
            // targets belong to this renderer.
            unsafe {
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&barriers),
                );
                d.cmd_begin_rendering(cmd, &info);
                d.cmd_set_viewport(
                    cmd,
                    0,
                    &[vk::Viewport {
                        x: 0.0,
                        y: 0.0,
                        width: far.extent.width as f32,
                        height: far.extent.height as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    }],
                );
                d.cmd_set_scissor(cmd, 0, &[area]);
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.descriptors.layout,
                    0,
                    &[self.descriptors.sets[self.slot]],
                    &[],
                );
                draws += self.draw_scene(
                    cmd,
                    batches.far_draws(),
                    &far.pipelines,
                    Some(far.sky),
                    2 + i as u32,
                );
                d.cmd_end_rendering(cmd);
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&to_read),
                );
            }
        }
        q.end_pass(ctx, cmd);
        draws
    }

    fn draw_sky(&self, cmd: vk::CommandBuffer, sky: vk::Pipeline, push: &dyn Fn(u32)) {
        // SAFETY: inside a rendering scope begun by `record`.
        unsafe {
            self.ctx
                .device
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, sky);
            push(0);
            let first = self
                .scene
                .as_ref()
                .expect("scene present until drop")
                .fullscreen_first_index;
            self.ctx.device.cmd_draw_indexed(cmd, 3, 1, first, 0, 0);
        }
    }

    fn record_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        output: Option<&FrameOutput>,
    ) -> Result<()> {
        let (w, h) = (self.extent.width as u64, self.extent.height as u64);
        let size = w * h * 4 * 2;
        if self.readback.as_ref().is_none_or(|b| b.size < size) {
            if let Some(old) = self.readback.take() {
                self.ring
                    .as_mut()
                    .expect("ring present until drop")
                    .defer(Garbage::Buffer(old));
            }
            self.readback = Some(Buffer::new(
                &self.ctx,
                &BufferDesc {
                    name: "readback",
                    size,
                    usage: vk::BufferUsageFlags::TRANSFER_DST,
                    location: MemoryLocation::GpuToCpu,
                    category: "readback",
                },
            )?);
        }
        let targets = self.targets.as_ref().expect("targets present until drop");
        let buf = self.readback.as_ref().expect("created above").buffer;
        let d = &self.ctx.device;
        let mut to_src = Vec::new();
        let mut copies = Vec::new();
        let mut back = Vec::new();
        let mut offset = 0u64;
        for (i, set) in targets.sets.iter().enumerate() {
            let layers = set.resolve.layers;
            // The frame was last written by the output copy (swapchain
            // image) or by rendering (own image); both end in the colour
            // attachment layout.
            let (image, src_access) = match output.and_then(|o| o.color.get(i)) {
                Some(&img) => (img, vk::AccessFlags2::TRANSFER_WRITE),
                None => (
                    set.output_image().image,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                ),
            };
            let written = Use {
                layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT
                    | vk::PipelineStageFlags2::ALL_TRANSFER,
                access: src_access,
            };
            let read = Use {
                layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                stage: vk::PipelineStageFlags2::COPY,
                access: vk::AccessFlags2::TRANSFER_READ,
            };
            let c = vk::ImageAspectFlags::COLOR;
            to_src.push(barrier::image(image, c, layers, written, read));
            if output.is_some() {
                let done = Use {
                    access: vk::AccessFlags2::NONE,
                    ..read
                };
                let handed_back = Use {
                    access: vk::AccessFlags2::NONE,
                    ..Use::COLOR_ATTACHMENT
                };
                back.push(barrier::image(image, c, layers, done, handed_back));
            }
            let copy = barrier::color_copy(offset, layers, w as u32, h as u32);
            copies.push((image, copy));
            offset += w * h * 4 * layers as u64;
        }
        let to_host = [vk::BufferMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ)
            .buffer(buf)
            .size(vk::WHOLE_SIZE)];
        // SAFETY: recording after the rendering scope; buffer large enough for both layers.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_src),
            );
            for (image, copy) in copies {
                d.cmd_copy_image_to_buffer(
                    cmd,
                    image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    buf,
                    &[copy],
                );
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default()
                    .buffer_memory_barriers(&to_host)
                    .image_memory_barriers(&back),
            );
        }
        Ok(())
    }

    /// Copies the resolved colour (and depth) of every set into `out`'s
    /// images, leaving them in the attachment layouts the runtime expects.
    fn record_output(&mut self, cmd: vk::CommandBuffer, out: &FrameOutput) -> Result<()> {
        let spec = self
            .output
            .ok_or_else(|| Error::Gpu("the renderer was created without an output".into()))?;
        let targets = self.targets.as_ref().expect("targets present until drop");
        if out.color.len() != targets.sets.len()
            || (spec.depth && out.depth.len() != targets.sets.len())
        {
            return Err(Error::Gpu(format!(
                "frame output has {} colour / {} depth images for {} attachment sets",
                out.color.len(),
                out.depth.len(),
                targets.sets.len()
            )));
        }
        let ctx = self.ctx.clone();
        let d = &ctx.device;
        let (w, h) = (self.extent.width, self.extent.height);
        let ds = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
        let barrier = barrier::image;
        let color_out = Use::COLOR_ATTACHMENT;
        let depth_out = Use {
            layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
            stage: vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS
                | vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
            access: vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
                | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
        };
        let (src, dst) = (Use::TRANSFER_SRC, Use::TRANSFER_DST);
        let mut before = Vec::new();
        let mut after = Vec::new();
        for (i, set) in targets.sets.iter().enumerate() {
            let layers = set.resolve.layers;
            let c = vk::ImageAspectFlags::COLOR;
            before.push(barrier(set.output_image().image, c, layers, color_out, src));
            before.push(barrier(out.color[i], c, layers, color_out.discarded(), dst));
            after.push(barrier(out.color[i], c, layers, dst, color_out));
            if let (true, Some(depth)) = (spec.depth, set.depth_output()) {
                before.push(barrier(depth.image, ds, layers, depth_out, src));
                before.push(barrier(
                    out.depth[i],
                    ds,
                    layers,
                    depth_out.discarded(),
                    dst,
                ));
                after.push(barrier(out.depth[i], ds, layers, dst, depth_out));
            }
        }
        // SAFETY: recording after the rendering scope into the open command
        // buffer; the output images belong to the session and are acquired.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&before),
            );
            for (i, set) in targets.sets.iter().enumerate() {
                let layers = set.resolve.layers;
                let sub = |aspect| vk::ImageSubresourceLayers {
                    aspect_mask: aspect,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: layers,
                };
                let extent = vk::Extent3D {
                    width: w,
                    height: h,
                    depth: 1,
                };
                let c = vk::ImageAspectFlags::COLOR;
                if spec.color_format == COLOR_FORMAT {
                    let region = vk::ImageCopy::default()
                        .src_subresource(sub(c))
                        .dst_subresource(sub(c))
                        .extent(extent);
                    d.cmd_copy_image(
                        cmd,
                        set.output_image().image,
                        src.layout,
                        out.color[i],
                        dst.layout,
                        &[region],
                    );
                } else {
                    let corner = vk::Offset3D {
                        x: w as i32,
                        y: h as i32,
                        z: 1,
                    };
                    let region = vk::ImageBlit::default()
                        .src_subresource(sub(c))
                        .dst_subresource(sub(c))
                        .src_offsets([vk::Offset3D::default(), corner])
                        .dst_offsets([vk::Offset3D::default(), corner]);
                    d.cmd_blit_image(
                        cmd,
                        set.output_image().image,
                        src.layout,
                        out.color[i],
                        dst.layout,
                        &[region],
                        vk::Filter::NEAREST,
                    );
                }
                if let (true, Some(depth)) = (spec.depth, set.depth_output()) {
                    let region = vk::ImageCopy::default()
                        .src_subresource(sub(vk::ImageAspectFlags::DEPTH))
                        .dst_subresource(sub(vk::ImageAspectFlags::DEPTH))
                        .extent(extent);
                    d.cmd_copy_image(
                        cmd,
                        depth.image,
                        src.layout,
                        out.depth[i],
                        dst.layout,
                        &[region],
                    );
                }
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&after),
            );
        }
        Ok(())
    }

    /// The last read-back frame as two RGBA8 (sRGB) images, left then right.
    pub fn read_images(&mut self) -> Result<[image::RgbaImage; 2]> {
        let (w, h) = (self.extent.width, self.extent.height);
        let layer = (w * h * 4) as usize;
        let buf = self
            .readback
            .as_mut()
            .ok_or_else(|| Error::Gpu("no frame was read back".into()))?;
        let data = buf
            .mapped()
            .ok_or_else(|| Error::Gpu("readback buffer is not mapped".into()))?;
        let left = image::RgbaImage::from_raw(w, h, data[..layer].to_vec());
        let right = image::RgbaImage::from_raw(w, h, data[layer..2 * layer].to_vec());
        match (left, right) {
            (Some(l), Some(r)) => Ok([l, r]),
            _ => Err(Error::Gpu("readback buffer too small".into())),
        }
    }

    /// What happened to per-view render areas
    /// (VK_QCOM_multiview_per_view_render_areas), for stats.
    pub fn per_view_render_areas(&self) -> String {
        if self.ctx.caps.per_view_render_areas {
            "offered, not needed: each view has its own asymmetric projection over the whole image, so there is no symmetric-FOV padding to skip".into()
        } else {
            format!(
                "not offered (VK_QCOM_multiview_per_view_render_areas is absent on {})",
                self.ctx.device_name
            )
        }
    }

    /// Whether the transient attachments use lazily allocated memory.
    pub fn lazily_allocated(&self) -> bool {
        self.targets.as_ref().is_some_and(|t| t.lazily_allocated())
    }
}

/// Stencil state that sets `bits` wherever the pipeline rasterizes (the
/// hidden-area and RDM masks).
fn stencil_write(bits: u32) -> vk::StencilOpState {
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
fn to_sampled(image: &Image) -> vk::ImageMemoryBarrier2<'static> {
    barrier::image(
        image.image,
        vk::ImageAspectFlags::COLOR,
        image.layers,
        Use::COLOR_ATTACHMENT,
        Use::SAMPLED,
    )
}

/// Offset of each stream's default value inside the defaults buffer.
fn default_offset(stream: usize) -> u64 {
    match stream {
        2 => 0,
        3 | 4 => 16,
        5 => 32,
        _ => 48,
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
        for q in self.queries.drain(..).flatten() {
            q.destroy(&ctx);
        }
        // SAFETY: the device is idle; these objects belong to this renderer.
        unsafe {
            for p in self.pipelines.values().chain([
                &self.sky,
                &self.flat,
                &self.hidden_pipeline,
                &self.rdm_pipeline,
                &self.fill_pipeline,
            ]) {
                if *p != vk::Pipeline::null() {
                    ctx.device.destroy_pipeline(*p, None);
                }
            }
            if self.fill_sampler != vk::Sampler::null() {
                ctx.device.destroy_sampler(self.fill_sampler, None);
            }
        }
        self.descriptors.destroy(&ctx);
        for b in self
            .visible
            .drain(..)
            .flatten()
            .chain(self.ubos.drain(..))
            .chain(self.hidden.drain(..).map(|h| h.buffer))
            .chain(self.readback.take())
        {
            b.destroy(&ctx);
        }
        if let Some(t) = self.targets.take() {
            t.destroy(&ctx);
        }
        for img in self.rates.drain(..) {
            img.destroy(&ctx);
        }
        if let Some(far) = self.far.take() {
            // SAFETY: the device is idle; these objects belong to this renderer.
            unsafe {
                for p in far.pipelines.values().chain([&far.sky, &far.composite]) {
                    if *p != vk::Pipeline::null() {
                        ctx.device.destroy_pipeline(*p, None);
                    }
                }
                ctx.device.destroy_sampler(far.sampler, None);
            }
            for set in far.sets {
                set.destroy(&ctx);
            }
        }
        if let Some(s) = self.scene.take() {
            s.destroy(&ctx);
        }
    }
}
