//! The distortion preview (`render --preview distorted`): what the HMD's
//! panels show of a rendered eye pair, barrel distortion and per-channel
//! chromatic aberration included ([`crate::view::distortion`]).
//!
//! The preview runs after the frame, on its own: the two eye images are
//! uploaded into a sampled two-layer image, and each eye's panel image is
//! drawn by one of three methods, the three a Vulkan VR simulator compared:
//! - [`Method::Fragment`]: a full-screen triangle, the lens evaluated per
//!   panel pixel and channel;
//! - [`Method::Grid`]: a grid over the eye image warped onto the panel in
//!   the vertex shader (the inverse map by safeguarded Newton steps),
//!   aberration in the fragment shader;
//! - [`Method::Mesh`]: a mesh baked on the CPU
//!   ([`crate::view::distortion::mesh`]) with per-channel uvs in its
//!   vertex attributes;
//! - [`Method::Compute`] (vergence's fourth): the per-fragment math in a
//!   compute shader writing a storage image, for GPUs whose rasterizer is
//!   the bottleneck (the H200's is).
//!
//! Each draw is timed with two timestamps around both eyes, so the figure
//! is the distortion's own GPU cost.

use crate::error::{Error, Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc, Image, ImageDesc, Pod};
use crate::gpu::pipeline::{Blend, DescriptorSets, GraphicsPipelineDesc};
use crate::gpu::shaders;
use crate::gpu::surface::{Source, SHOWN};
use crate::gpu::Context;
use crate::view::distortion::{mesh, Lens, Radial};
use crate::view::Fov;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// How the panel image is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// The lens evaluated per panel pixel.
    Fragment,
    /// A grid warped in the vertex shader, aberration per fragment.
    Grid,
    /// A pre-baked mesh with per-channel uvs.
    Mesh,
    /// The lens per panel pixel in a compute shader.
    Compute,
}

impl Method {
    /// The name the CLI takes.
    pub fn name(self) -> &'static str {
        match self {
            Method::Fragment => "fragment",
            Method::Grid => "grid",
            Method::Mesh => "mesh",
            Method::Compute => "compute",
        }
    }
}

/// Grid cells per side for the grid method (as many as the baked mesh).
pub const GRID_CELLS: u32 = mesh::GRID_CELLS;

/// Most panel-image pixels per eye-image pixel, along each axis, that the
/// preview draws: a real panel has about as many pixels as the eye image
/// rendered for it (usually fewer), so a preview is drawn at the panel's
/// own size; a profile may declare a panel far larger than the images
/// rendered (a 16×16 render for a 16384×16384 panel), and then the preview
/// is scaled down so its work and memory follow the rendered size.
pub const MAX_PANEL_PER_EYE: f64 = 2.0;

/// The size a panel of `panel` pixels is previewed at for eye images of
/// `eye`: the panel's own, or scaled down (aspect kept) to at most
/// [`MAX_PANEL_PER_EYE`] times the eye image along each axis.
pub fn preview_panel(panel: [u32; 2], eye: vk::Extent2D) -> vk::Extent2D {
    let fit = |e: u32, p: u32| MAX_PANEL_PER_EYE * e.max(1) as f64 / p.max(1) as f64;
    let s = fit(eye.width, panel[0])
        .min(fit(eye.height, panel[1]))
        .min(1.0);
    let side = |p: u32| ((p as f64 * s).floor() as u32).max(1);
    vk::Extent2D {
        width: side(panel[0]),
        height: side(panel[1]),
    }
}

/// The push constants of `shaders/distortion.glsl`.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
struct LensParams {
    k: [[f32; 4]; 3],
    centre_unit: [f32; 4],
    tangent_axis: [f32; 4],
    fov: [f32; 4],
    panel: [f32; 2],
    r_max: f32,
    model: i32,
    layer: i32,
    cells: i32,
    _pad: [i32; 2],
}

// SAFETY: plain f32/i32 fields, 128 bytes, no padding (explicit `_pad`).
unsafe impl Pod for LensParams {}

// SAFETY: eight f32, no padding.
unsafe impl Pod for mesh::MeshVertex {}

impl LensParams {
    /// The parameters of `lens` seen through `fov`, drawn into layer
    /// `layer` of a panel image of `panel` pixels.
    fn of(lens: &Lens, fov: &Fov, layer: i32, panel: vk::Extent2D) -> LensParams {
        let f = |v: f64| v as f32;
        let (model, k) = match &lens.radial {
            Radial::Panotools(p) => (0, [0, 1, 2].map(|c| p.cubic(c).map(f))),
            Radial::Dpoly3(p) => (1, p.k.map(|c| c.map(f))),
        };
        let [l, r, u, d] = fov.tangents();
        LensParams {
            k,
            centre_unit: [
                f(lens.centre[0]),
                f(lens.centre[1]),
                f(lens.unit[0]),
                f(lens.unit[1]),
            ],
            tangent_axis: [
                f(lens.tangent[0]),
                f(lens.tangent[1]),
                f(lens.axis[0]),
                f(lens.axis[1]),
            ],
            fov: [f(l), f(r), f(u), f(d)],
            panel: [panel.width as f32, panel.height as f32],
            r_max: f(lens.r_max),
            model,
            layer,
            cells: GRID_CELLS as i32,
            _pad: [0; 2],
        }
    }
}

/// The stages that read the push constants.
const STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::VERTEX.as_raw()
        | vk::ShaderStageFlags::FRAGMENT.as_raw()
        | vk::ShaderStageFlags::COMPUTE.as_raw(),
);

/// The distortion preview of one HMD's two eyes.
pub struct DistortionPreview {
    ctx: Arc<Context>,
    method: Method,
    eye: vk::Extent2D,
    panel: vk::Extent2D,
    params: [LensParams; 2],
    owned: Option<Owned>,
    target_views: [vk::ImageView; 2],
    sampler: vk::Sampler,
    binding: DescriptorSets,
    layout: vk::PipelineLayout,
    set: vk::DescriptorSet,
    pipeline: vk::Pipeline,
    queries: vk::QueryPool,
}

/// The images and buffers, destroyed explicitly in Drop.
struct Owned {
    source: Image,
    target: Image,
    /// The upload and read-back buffers of [`DistortionPreview::run`]
    /// (None when built for GPU images only).
    host: Option<HostIo>,
    meshes: Option<[(Buffer, Buffer, u32); 2]>,
}

/// The buffers that carry eye images in and panel images out.
struct HostIo {
    staging: Buffer,
    readback: Buffer,
}

/// What a preview run gives back.
pub struct PreviewOutput {
    /// The panel images, left then right (RGBA8, sRGB).
    pub images: [image::RgbaImage; 2],
    /// GPU milliseconds of each run (both eyes).
    pub gpu_ms: Vec<f64>,
}

const FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
/// The compute method's panel format: storage images have no sRGB format,
/// so the shader encodes and stores the bytes an sRGB target would hold.
const STORAGE_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// The eye images as the graphics methods' fragment shaders and the
/// compute method read them.
const SOURCE_READ: Use = Use {
    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    stage: vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw()
            | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw(),
    ),
    access: vk::AccessFlags2::SHADER_SAMPLED_READ,
};

/// The compute method's panel image while it is written.
const STORAGE_WRITE: Use = Use {
    layout: vk::ImageLayout::GENERAL,
    stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
    access: vk::AccessFlags2::SHADER_STORAGE_WRITE,
};

impl DistortionPreview {
    /// Builds the preview for `lenses` (left, right) and their views'
    /// `fovs`, for eye images of `eye` pixels; both panels must be the
    /// same size.
    pub fn new(
        ctx: &Arc<Context>,
        lenses: [&Lens; 2],
        fovs: [&Fov; 2],
        eye: vk::Extent2D,
        method: Method,
    ) -> Result<DistortionPreview> {
        Self::build(ctx, lenses, fovs, eye, method, true)
    }

    /// The size the panel images are drawn at ([`preview_panel`]).
    pub fn panel(&self) -> vk::Extent2D {
        self.panel
    }

    /// Like [`Self::new`], for drawing from GPU images only
    /// ([`Self::record_from`]): no upload or read-back buffers, so
    /// [`Self::run`] is an error.
    pub fn for_images(
        ctx: &Arc<Context>,
        lenses: [&Lens; 2],
        fovs: [&Fov; 2],
        eye: vk::Extent2D,
        method: Method,
    ) -> Result<DistortionPreview> {
        Self::build(ctx, lenses, fovs, eye, method, false)
    }

    fn build(
        ctx: &Arc<Context>,
        lenses: [&Lens; 2],
        fovs: [&Fov; 2],
        eye: vk::Extent2D,
        method: Method,
        host_io: bool,
    ) -> Result<DistortionPreview> {
        if lenses[0].panel != lenses[1].panel {
            return Err(Error::Config {
                what: "distortion preview".into(),
                message: format!(
                    "the two lenses' panels differ ({:?} and {:?})",
                    lenses[0].panel, lenses[1].panel
                ),
            });
        }
        let panel = preview_panel(lenses[0].panel, eye);
        let params = [
            LensParams::of(lenses[0], fovs[0], 0, panel),
            LensParams::of(lenses[1], fovs[1], 1, panel),
        ];
        let d = &ctx.device;
        let color = vk::ImageAspectFlags::COLOR;
        let source = Image::new(
            ctx,
            &ImageDesc {
                name: "distortion source",
                format: FORMAT,
                extent: eye,
                layers: 2,
                mips: 1,
                samples: vk::SampleCountFlags::TYPE_1,
                usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
                aspect: color,
                category: "preview",
                flags: vk::ImageCreateFlags::empty(),
            },
        )?;
        let compute = method == Method::Compute;
        let (target_format, target_usage) = if compute {
            (STORAGE_FORMAT, vk::ImageUsageFlags::STORAGE)
        } else {
            (FORMAT, vk::ImageUsageFlags::COLOR_ATTACHMENT)
        };
        let target = Image::new(
            ctx,
            &ImageDesc {
                name: "distortion panel",
                format: target_format,
                extent: panel,
                layers: 2,
                mips: 1,
                samples: vk::SampleCountFlags::TYPE_1,
                usage: target_usage | vk::ImageUsageFlags::TRANSFER_SRC,
                aspect: color,
                category: "preview",
                flags: vk::ImageCreateFlags::empty(),
            },
        )?;
        let view = |layer| {
            Image::make_view(
                ctx,
                target.image,
                target_format,
                color,
                vk::ImageViewType::TYPE_2D,
                layer,
                1,
                1,
            )
        };
        let target_views = [view(0)?, view(1)?];
        let host = if host_io {
            let eye_bytes = eye.width as u64 * eye.height as u64 * 4 * 2;
            let panel_bytes = panel.width as u64 * panel.height as u64 * 4 * 2;
            let staging = Buffer::new(
                ctx,
                &BufferDesc {
                    name: "distortion upload",
                    size: eye_bytes,
                    usage: vk::BufferUsageFlags::TRANSFER_SRC,
                    location: MemoryLocation::CpuToGpu,
                    category: "preview",
                },
            )?;
            let readback = Buffer::new(
                ctx,
                &BufferDesc {
                    name: "distortion readback",
                    size: panel_bytes,
                    usage: vk::BufferUsageFlags::TRANSFER_DST,
                    location: MemoryLocation::GpuToCpu,
                    category: "preview",
                },
            )?;
            Some(HostIo { staging, readback })
        } else {
            None
        };
        let meshes = if method == Method::Mesh {
            let one = |i: usize| -> Result<(Buffer, Buffer, u32)> {
                let m = mesh::build(lenses[i], fovs[i], mesh::GRID_CELLS);
                let usage = |u| BufferDesc {
                    name: "distortion mesh",
                    size: 0,
                    usage: u,
                    location: MemoryLocation::CpuToGpu,
                    category: "preview",
                };
                let v = Buffer::with_data(
                    ctx,
                    &usage(vk::BufferUsageFlags::VERTEX_BUFFER),
                    as_bytes(&m.vertices),
                )?;
                let ix = Buffer::with_data(
                    ctx,
                    &usage(vk::BufferUsageFlags::INDEX_BUFFER),
                    as_bytes(&m.indices),
                )?;
                Ok((v, ix, m.indices.len() as u32))
            };
            Some([one(0)?, one(1)?])
        } else {
            None
        };
        // SAFETY: plain object creation on a live device; everything is
        // owned by the returned value and destroyed in Drop.
        let binding = DescriptorSets::new(
            ctx,
            &[
                (
                    vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
                    1,
                    vk::ShaderStageFlags::FRAGMENT | vk::ShaderStageFlags::COMPUTE,
                ),
                (
                    vk::DescriptorType::STORAGE_IMAGE,
                    1,
                    vk::ShaderStageFlags::COMPUTE,
                ),
            ],
            STAGES,
            std::mem::size_of::<LensParams>() as u32,
            1,
            "distortion",
        )?;
        let (layout, set) = (binding.layout, binding.sets[0]);
        // SAFETY: plain object creation and a descriptor write on a live
        // device; the sampler is destroyed in Drop.
        let sampler = unsafe {
            let sampler = d
                .create_sampler(
                    &vk::SamplerCreateInfo::default()
                        .mag_filter(vk::Filter::LINEAR)
                        .min_filter(vk::Filter::LINEAR)
                        .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
                        .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
                        .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                        .border_color(vk::BorderColor::FLOAT_OPAQUE_BLACK),
                    None,
                )
                .vk("creating the distortion sampler")?;
            let info = [vk::DescriptorImageInfo::default()
                .sampler(sampler)
                .image_view(source.view)
                .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)];
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(&info);
            let storage = [vk::DescriptorImageInfo::default()
                .image_view(target.view)
                .image_layout(vk::ImageLayout::GENERAL)];
            if compute {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(&storage);
                d.update_descriptor_sets(&[write, w], &[]);
            } else {
                d.update_descriptor_sets(&[write], &[]);
            }
            sampler
        };
        let (vertex, fragment) = match method {
            Method::Compute => (
                &shaders::DISTORT_FULLSCREEN_VERT,
                &shaders::DISTORT_FRAGMENT_FRAG,
            ),
            Method::Fragment => (
                &shaders::DISTORT_FULLSCREEN_VERT,
                &shaders::DISTORT_FRAGMENT_FRAG,
            ),
            Method::Grid => (&shaders::DISTORT_GRID_VERT, &shaders::DISTORT_GRID_FRAG),
            Method::Mesh => (&shaders::DISTORT_MESH_VERT, &shaders::DISTORT_MESH_FRAG),
        };
        let (bindings, attributes) = if method == Method::Mesh {
            let stride = std::mem::size_of::<mesh::MeshVertex>() as u32;
            (
                vec![vk::VertexInputBindingDescription {
                    binding: 0,
                    stride,
                    input_rate: vk::VertexInputRate::VERTEX,
                }],
                (0..4)
                    .map(|i| vk::VertexInputAttributeDescription {
                        location: i,
                        binding: 0,
                        format: vk::Format::R32G32_SFLOAT,
                        offset: 8 * i,
                    })
                    .collect(),
            )
        } else {
            (Vec::new(), Vec::new())
        };
        let pipeline = if compute {
            crate::gpu::pipeline::compute_pipeline(
                ctx,
                layout,
                &shaders::DISTORT_COMPUTE_COMP.words(),
                "distortion preview (compute)",
            )?
        } else {
            GraphicsPipelineDesc {
                name: "distortion preview",
                vertex: &vertex.words(),
                fragment: &fragment.words(),
                specialization: Vec::new(),
                bindings,
                attributes,
                cull_mode: vk::CullModeFlags::NONE,
                depth_test: false,
                depth_write: false,
                depth_compare: vk::CompareOp::ALWAYS,
                stencil: None,
                blend: Blend::Off,
                color_write: vk::ColorComponentFlags::RGBA,
                samples: vk::SampleCountFlags::TYPE_1,
                color_format: FORMAT,
                depth_format: vk::Format::UNDEFINED,
                view_mask: 0,
                layout,
                shading_rate_attachment: false,
                w_scaling: false,
                points: false,
            }
            .build(ctx)?
        };
        let queries = crate::gpu::query::timestamp_pair(ctx)?;
        Ok(DistortionPreview {
            ctx: ctx.clone(),
            method,
            eye,
            panel,
            params,
            owned: Some(Owned {
                source,
                target,
                host,
                meshes,
            }),
            target_views,
            sampler,
            binding,
            layout,
            set,
            pipeline,
            queries,
        })
    }

    /// The method this preview draws with.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Uploads `eyes` (left, right; the size given to [`Self::new`]), draws
    /// the panel images `runs` times (at least once), each run timed, and
    /// reads the last back.
    pub fn run(&mut self, eyes: &[image::RgbaImage; 2], runs: u32) -> Result<PreviewOutput> {
        let layer = self.eye.width as usize * self.eye.height as usize * 4;
        for (i, img) in eyes.iter().enumerate() {
            if img.width() != self.eye.width || img.height() != self.eye.height {
                return Err(Error::Gpu(format!(
                    "distortion preview: eye image {}x{} is not the {}x{} it was built for",
                    img.width(),
                    img.height(),
                    self.eye.width,
                    self.eye.height
                )));
            }
            self.host_mut()?.staging.write(i * layer, img.as_raw())?;
        }
        let mut gpu_ms = Vec::new();
        for run in 0..runs.max(1) {
            self.ctx.one_shot(|cmd| self.record(cmd, run == 0))?;
            let mut stamps = [0u64; 2];
            // SAFETY: both queries were written by the finished submission.
            unsafe {
                self.ctx.device.get_query_pool_results(
                    self.queries,
                    0,
                    &mut stamps,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .vk("reading the distortion timestamps")?;
            let ns =
                stamps[1].wrapping_sub(stamps[0]) as f64 * self.ctx.caps.timestamp_period_ns as f64;
            gpu_ms.push(ns / 1e6);
        }
        self.ctx.one_shot(|cmd| self.record_readback(cmd))?;
        let bytes = self.panel.width as usize * self.panel.height as usize * 4;
        let (w, h) = (self.panel.width, self.panel.height);
        let data = self
            .owned
            .as_mut()
            .expect("resources live until drop")
            .host
            .as_mut()
            .ok_or_else(|| Error::Gpu("the distortion preview has no read-back buffer".into()))?
            .readback
            .mapped()
            .ok_or_else(|| Error::Gpu("distortion readback is not mapped".into()))?;
        let image = |i: usize| {
            image::RgbaImage::from_raw(w, h, data[i * bytes..(i + 1) * bytes].to_vec())
                .ok_or_else(|| Error::Gpu("distortion readback too small".into()))
        };
        Ok(PreviewOutput {
            images: [image(0)?, image(1)?],
            gpu_ms,
        })
    }

    /// The upload and read-back buffers; an error for a preview built for
    /// GPU images only.
    fn host_mut(&mut self) -> Result<&mut HostIo> {
        self.owned
            .as_mut()
            .expect("resources live until drop")
            .host
            .as_mut()
            .ok_or_else(|| Error::Gpu("this distortion preview draws from GPU images only".into()))
    }

    fn owned(&self) -> &Owned {
        self.owned.as_ref().expect("resources live until drop")
    }

    /// Upload (first run only), then both eyes' panel images between two
    /// timestamps.
    fn record(&self, cmd: vk::CommandBuffer, upload: bool) {
        let d = &self.ctx.device;
        let o = self.owned();
        let color = vk::ImageAspectFlags::COLOR;
        // SAFETY: recording into an idle command buffer; all objects live.
        unsafe {
            if upload {
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&[barrier::image(
                        o.source.image,
                        color,
                        2,
                        Use::TRANSFER_DST.discarded(),
                        Use::TRANSFER_DST,
                    )]),
                );
                let host = o.host.as_ref().expect("run checked the buffers");
                d.cmd_copy_buffer_to_image(
                    cmd,
                    host.staging.buffer,
                    o.source.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[barrier::color_copy(0, 2, self.eye.width, self.eye.height)],
                );
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&[barrier::image(
                        o.source.image,
                        color,
                        2,
                        Use::TRANSFER_DST,
                        SOURCE_READ,
                    )]),
                );
            }
        }
        self.record_draws(cmd, true, Use::TRANSFER_SRC.discarded());
    }

    /// Both eyes' panel images from the source image (in SOURCE_READ), the
    /// panel image left in the layout its method writes; between two
    /// timestamps when `timed`. `last` is how the panel image was last used
    /// (its contents are discarded, its accesses waited for).
    fn record_draws(&self, cmd: vk::CommandBuffer, timed: bool, last: Use) {
        let d = &self.ctx.device;
        let o = self.owned();
        let color = vk::ImageAspectFlags::COLOR;
        let stamp = |i: u32| {
            if timed {
                // SAFETY: recording outside rendering; the pool was reset
                // in this command buffer.
                unsafe {
                    d.cmd_write_timestamp2(
                        cmd,
                        vk::PipelineStageFlags2::ALL_COMMANDS,
                        self.queries,
                        i,
                    )
                };
            }
        };
        // SAFETY: recording into an idle command buffer; all objects live.
        unsafe {
            if timed {
                d.cmd_reset_query_pool(cmd, self.queries, 0, 2);
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&[barrier::image(
                    o.target.image,
                    color,
                    2,
                    Use {
                        layout: vk::ImageLayout::UNDEFINED,
                        ..last
                    },
                    self.target_use(),
                )]),
            );
            stamp(0);
        }
        match self.method {
            Method::Compute => self.record_compute(cmd),
            _ => self.record_raster(cmd),
        }
        stamp(1);
    }

    /// The compute warp: one dispatch per eye over the panel.
    fn record_compute(&self, cmd: vk::CommandBuffer) {
        let d = &self.ctx.device;
        let bind = vk::PipelineBindPoint::COMPUTE;
        let groups = (self.panel.width.div_ceil(8), self.panel.height.div_ceil(8));
        // SAFETY: recording into an idle command buffer; all objects live.
        unsafe {
            d.cmd_bind_pipeline(cmd, bind, self.pipeline);
            d.cmd_bind_descriptor_sets(cmd, bind, self.layout, 0, &[self.set], &[]);
            for params in &self.params {
                d.cmd_push_constants(cmd, self.layout, STAGES, 0, as_bytes(&[*params]));
                d.cmd_dispatch(cmd, groups.0, groups.1, 1);
            }
        }
    }

    /// The raster warps: per eye, a scope over its target view drawing the
    /// distortion mesh, the grid or one full-screen triangle.
    fn record_raster(&self, cmd: vk::CommandBuffer) {
        let d = &self.ctx.device;
        let o = self.owned();
        let area = vk::Rect2D {
            offset: vk::Offset2D { x: 0, y: 0 },
            extent: self.panel,
        };
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: self.panel.width as f32,
            height: self.panel.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let clear = crate::gpu::rendering::Load::Clear([0.0, 0.0, 0.0, 1.0]);
        for (eye, &view) in self.target_views.iter().enumerate() {
            // SAFETY: recording into an idle command buffer; all objects live.
            unsafe {
                crate::gpu::rendering::begin_color(d, cmd, view, area.extent, clear, 0);
                d.cmd_set_viewport(cmd, 0, &[viewport]);
                d.cmd_set_scissor(cmd, 0, &[area]);
                d.cmd_bind_pipeline(cmd, bind, self.pipeline);
                d.cmd_bind_descriptor_sets(cmd, bind, self.layout, 0, &[self.set], &[]);
                d.cmd_push_constants(cmd, self.layout, STAGES, 0, as_bytes(&[self.params[eye]]));
                match (&o.meshes, self.method) {
                    (Some(meshes), _) => {
                        let (v, ix, count) = &meshes[eye];
                        d.cmd_bind_vertex_buffers(cmd, 0, &[v.buffer], &[0]);
                        d.cmd_bind_index_buffer(cmd, ix.buffer, 0, vk::IndexType::UINT32);
                        d.cmd_draw_indexed(cmd, *count, 1, 0, 0, 0);
                    }
                    (None, Method::Grid) => d.cmd_draw(cmd, GRID_CELLS * GRID_CELLS * 6, 1, 0, 0),
                    (None, _) => d.cmd_draw(cmd, 3, 1, 0, 0),
                }
                d.cmd_end_rendering(cmd);
            }
        }
    }

    /// Records, into `cmd`, the panel images of the eye images `eyes`
    /// (left, right: each an image layer in TRANSFER_SRC_OPTIMAL, made
    /// readable by the caller): blitted into the source image (converting
    /// the format, scaling when the sizes differ), then drawn. The panel
    /// image ends in COLOR_ATTACHMENT_OPTIMAL, written as an attachment;
    /// for a graphics method only (the mirror window's `distorted` mode),
    /// and the panel image is left as [`SHOWN`] describes.
    pub fn record_from(&self, cmd: vk::CommandBuffer, eyes: [Source; 2]) -> Result<()> {
        if self.method == Method::Compute {
            return Err(Error::Gpu(
                "the distortion preview draws from images with a graphics method only".into(),
            ));
        }
        let d = &self.ctx.device;
        let o = self.owned();
        let color = vk::ImageAspectFlags::COLOR;
        let layers = |layer: u32| vk::ImageSubresourceLayers {
            aspect_mask: color,
            mip_level: 0,
            base_array_layer: layer,
            layer_count: 1,
        };
        let corner = |e: vk::Extent2D| vk::Offset3D {
            x: e.width as i32,
            y: e.height as i32,
            z: 1,
        };
        // SAFETY: recording into an open command buffer outside rendering;
        // the eye images are in TRANSFER_SRC_OPTIMAL and readable (the
        // caller's contract), the source image was last read by this
        // preview's draws in an earlier submission on this queue.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&[barrier::image(
                    o.source.image,
                    color,
                    2,
                    SOURCE_READ.discarded(),
                    Use::TRANSFER_DST,
                )]),
            );
            for (i, eye) in eyes.iter().enumerate() {
                let same = eye.extent == self.eye;
                let region = vk::ImageBlit::default()
                    .src_subresource(layers(eye.layer))
                    .src_offsets([vk::Offset3D::default(), corner(eye.extent)])
                    .dst_subresource(layers(i as u32))
                    .dst_offsets([vk::Offset3D::default(), corner(self.eye)]);
                d.cmd_blit_image(
                    cmd,
                    eye.image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    o.source.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                    if same {
                        vk::Filter::NEAREST
                    } else {
                        vk::Filter::LINEAR
                    },
                );
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&[barrier::image(
                    o.source.image,
                    color,
                    2,
                    Use::TRANSFER_DST,
                    SOURCE_READ,
                )]),
            );
        }
        // The panels were last shown: written as attachments by the previous
        // draw and perhaps read by the window's blit since (its contract).
        self.record_draws(cmd, false, SHOWN);
        Ok(())
    }

    /// The panel images (one layer per eye) and their size.
    pub fn panels(&self) -> (vk::Image, vk::Extent2D) {
        (self.owned().target.image, self.panel)
    }

    /// How the panel image is written: as a colour attachment, or as a
    /// storage image by the compute method.
    fn target_use(&self) -> Use {
        if self.method == Method::Compute {
            STORAGE_WRITE
        } else {
            Use::COLOR_ATTACHMENT
        }
    }

    /// Copies both panel images into the read-back buffer.
    fn record_readback(&self, cmd: vk::CommandBuffer) {
        let d = &self.ctx.device;
        let o = self.owned();
        let color = vk::ImageAspectFlags::COLOR;
        // SAFETY: recording into an idle command buffer; the panel image was
        // last written by the previous submission's draws or dispatches.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&[barrier::image(
                    o.target.image,
                    color,
                    2,
                    self.target_use(),
                    Use::TRANSFER_SRC,
                )]),
            );
            let host = o.host.as_ref().expect("run checked the buffers");
            d.cmd_copy_image_to_buffer(
                cmd,
                o.target.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                host.readback.buffer,
                &[barrier::color_copy(
                    0,
                    2,
                    self.panel.width,
                    self.panel.height,
                )],
            );
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&[barrier::copies_to_host()]),
            );
        }
    }
}

impl Drop for DistortionPreview {
    fn drop(&mut self) {
        let ctx = self.ctx.clone();
        let d = &ctx.device;
        // SAFETY: every submission was waited for; nothing is in use.
        unsafe {
            let _ = d.device_wait_idle();
            d.destroy_query_pool(self.queries, None);
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_sampler(self.sampler, None);
            for v in self.target_views {
                d.destroy_image_view(v, None);
            }
        }
        self.binding.destroy(&ctx);
        if let Some(o) = self.owned.take() {
            o.source.destroy(&ctx);
            o.target.destroy(&ctx);
            if let Some(h) = o.host {
                h.staging.destroy(&ctx);
                h.readback.destroy(&ctx);
            }
            for (v, ix, _) in o.meshes.into_iter().flatten() {
                v.destroy(&ctx);
                ix.destroy(&ctx);
            }
        }
    }
}
