//! `vergence raster-floors`: what an empty multiview frame costs on this
//! GPU for each way of clearing and resolving its multisampled targets.
//!
//! The renderer's floor frames ([`crate::render::passes::floor`]) measure
//! the frame as vergence draws it today: colour and depth-stencil cleared
//! by the rendering scope's load operations and the colour resolved by the
//! scope's resolve attachment. On a GPU whose raster units are few (the
//! H200: GPU time follows pixel samples, and clearing alone is two thirds
//! of an empty 4x frame) other routes may be cheaper: a transfer clear
//! before a scope that loads, a depth format without stencil, or a resolve
//! in a compute shader. Each variant here records that route alone, over
//! two-layer targets drawn with view mask 0b11 (`--views 1`: one
//! single-layer view), and is timed with two
//! timestamps around its commands; the table gives the median and the
//! fastest of `--repeats` submissions.

use crate::error::{Error, Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Image, ImageDesc};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::query::{timestamp_pair, timestamp_pair_ms};
use crate::gpu::{shaders, Context};
use ash::vk;

/// Command-line arguments of `raster-floors`.
#[derive(clap::Args, Clone, Debug)]
pub struct RasterFloorsArgs {
    /// Width of each eye's target in pixels (16 to 8192).
    #[arg(long, default_value_t = 2016, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub width: u32,
    /// Height of each eye's target in pixels (16 to 8192).
    #[arg(long, default_value_t = 2240, value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub height: u32,
    /// Samples per pixel: 2, 4 or 8 (at most what the device offers).
    #[arg(long, default_value_t = 4, value_parser = parse_samples)]
    pub samples: u32,
    /// Submissions timed per variant (1 to 1000).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: u32,
    /// Views: 2 (both eyes in one multiview scope over 2-layer targets,
    /// as the renderer draws) or 1 (one single-layer view; Mesa 25's
    /// lavapipe crashes executing an empty multiview scope, so the tests
    /// run this).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=2))]
    pub views: u32,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

fn parse_samples(s: &str) -> std::result::Result<u32, String> {
    match s.parse::<u32>() {
        Ok(v @ (2 | 4 | 8)) => Ok(v),
        _ => Err(format!("`{s}` is not 2, 4 or 8")),
    }
}

/// How a variant clears its targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Clear {
    /// The scope's load operations clear colour and depth.
    Scope,
    /// The scope clears depth only; colour is loaded as don't-care.
    ScopeDepthOnly,
    /// vkCmdClearColorImage and vkCmdClearDepthStencilImage before a scope
    /// that loads.
    Transfer,
}

/// How a variant resolves the colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Resolve {
    /// Not resolved (colour stored multisampled).
    None,
    /// The scope's resolve attachment (average).
    Attachment,
    /// vkCmdResolveImage after the scope.
    Command,
    /// A compute shader (`shaders/msaa_resolve.comp`) after the scope.
    Compute,
}

/// One route through an empty frame.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Variant {
    /// Short name.
    pub name: &'static str,
    /// How the targets are cleared.
    pub clear: Clear,
    /// Whether a rendering scope is begun at all (false: clears and
    /// resolve only).
    pub scope: bool,
    /// The depth attachment has a stencil aspect (D32_SFLOAT_S8_UINT or
    /// the device's depth-stencil format) rather than D32_SFLOAT alone.
    pub stencil: bool,
    /// How the colour is resolved.
    pub resolve: Resolve,
}

/// The variants, today's route first.
pub const VARIANTS: [Variant; 9] = [
    Variant {
        name: "today",
        clear: Clear::Scope,
        scope: true,
        stencil: true,
        resolve: Resolve::Attachment,
    },
    Variant {
        name: "no-stencil",
        clear: Clear::Scope,
        scope: true,
        stencil: false,
        resolve: Resolve::Attachment,
    },
    Variant {
        name: "no-resolve",
        clear: Clear::Scope,
        scope: true,
        stencil: true,
        resolve: Resolve::None,
    },
    Variant {
        name: "colour-dont-care",
        clear: Clear::ScopeDepthOnly,
        scope: true,
        stencil: true,
        resolve: Resolve::Attachment,
    },
    Variant {
        name: "transfer-clear",
        clear: Clear::Transfer,
        scope: true,
        stencil: true,
        resolve: Resolve::Attachment,
    },
    Variant {
        name: "transfer-clear-only",
        clear: Clear::Transfer,
        scope: false,
        stencil: true,
        resolve: Resolve::None,
    },
    Variant {
        name: "resolve-command",
        clear: Clear::Scope,
        scope: true,
        stencil: true,
        resolve: Resolve::Command,
    },
    Variant {
        name: "resolve-compute",
        clear: Clear::Scope,
        scope: true,
        stencil: true,
        resolve: Resolve::Compute,
    },
    Variant {
        name: "transfer-clear-compute-resolve",
        clear: Clear::Transfer,
        scope: true,
        stencil: false,
        resolve: Resolve::Compute,
    },
];

/// One variant's timings.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Timing {
    /// The variant.
    pub variant: Variant,
    /// Median GPU milliseconds over the repeats.
    pub p50_ms: f64,
    /// Fastest GPU milliseconds.
    pub min_ms: f64,
}

/// The whole measurement.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    /// The device's name.
    pub device: String,
    /// Per-eye width and height in pixels.
    pub extent: [u32; 2],
    /// Samples per pixel.
    pub samples: u32,
    /// Views (layers) drawn.
    pub views: u32,
    /// Submissions per variant.
    pub repeats: u32,
    /// The depth-stencil format's name.
    pub depth_stencil_format: String,
    /// One row per variant.
    pub timings: Vec<Timing>,
    /// Validation messages seen while measuring (0 when clean or off).
    pub validation_messages: usize,
}

impl Report {
    /// A Markdown table.
    pub fn to_table(&self) -> String {
        let mut s = format!(
            "raster floors: {} · {}×{}×{} · {}× MSAA · depth-stencil {} · {} submissions each\n\n",
            self.device,
            self.views,
            self.extent[0],
            self.extent[1],
            self.samples,
            self.depth_stencil_format,
            self.repeats
        );
        s.push_str("| variant | clear | scope | stencil | resolve | GPU ms p50 | min |\n");
        s.push_str("|---|---|---|---|---|---:|---:|\n");
        for t in &self.timings {
            let v = &t.variant;
            s.push_str(&format!(
                "| {} | {:?} | {} | {} | {:?} | {:.3} | {:.3} |\n",
                v.name, v.clear, v.scope, v.stencil, v.resolve, t.p50_ms, t.min_ms
            ));
        }
        s.push_str(&format!(
            "\nvalidation messages: {}\n",
            self.validation_messages
        ));
        s
    }
}

/// The targets every variant draws into.
struct Targets {
    colour: Image,
    depth_stencil: Image,
    depth: Image,
    resolved: Image,
    storage: Image,
    /// 2D-array views of `colour` and `storage` for the compute resolve
    /// (an image of one layer gets a plain 2D view of its own).
    arrays: [vk::ImageView; 2],
}

/// The compute resolve's pipeline and its one descriptor set.
struct ComputeResolve {
    sets: DescriptorSets,
    pipeline: vk::Pipeline,
    sampler: vk::Sampler,
}

/// Measures every variant on `ctx`.
pub fn run(ctx: &Context, args: &RasterFloorsArgs) -> Result<Report> {
    if args.samples > ctx.caps.max_samples {
        return Err(Error::Gpu(format!(
            "--samples {}: the device offers at most {} samples",
            args.samples, ctx.caps.max_samples
        )));
    }
    if args.views == 2 && ctx.driver_id == vk::DriverId::MESA_LLVMPIPE {
        return Err(Error::Gpu(
            "--views 2: lavapipe crashes executing an empty multiview scope; use --views 1 on this driver".into(),
        ));
    }
    if ctx.caps.timestamp_period_ns == 0.0 {
        return Err(Error::Gpu(
            "the device has no timestamps on its graphics queue".into(),
        ));
    }
    let extent = vk::Extent2D {
        width: args.width,
        height: args.height,
    };
    let targets = make_targets(ctx, extent, args.samples, args.views)?;
    let timings = make_compute(ctx, &targets).and_then(|compute| {
        let timings = timestamp_pair(ctx).and_then(|pool| {
            let t = measure(ctx, pool, &targets, &compute, args);
            // SAFETY: one_shot waited for every submission.
            unsafe { ctx.device.destroy_query_pool(pool, None) };
            t
        });
        compute.destroy(ctx);
        timings
    });
    for view in targets.arrays {
        // SAFETY: one_shot waited for every submission.
        unsafe { ctx.device.destroy_image_view(view, None) };
    }
    for img in [
        targets.colour,
        targets.depth_stencil,
        targets.depth,
        targets.resolved,
        targets.storage,
    ] {
        img.destroy(ctx);
    }
    Ok(Report {
        device: ctx.device_name.clone(),
        extent: [args.width, args.height],
        samples: args.samples,
        views: args.views,
        repeats: args.repeats,
        depth_stencil_format: format!("{:?}", ctx.caps.depth_format),
        timings: timings?,
        validation_messages: ctx.validation_messages(),
    })
}

/// Times every variant `args.repeats` times.
fn measure(
    ctx: &Context,
    pool: vk::QueryPool,
    targets: &Targets,
    compute: &ComputeResolve,
    args: &RasterFloorsArgs,
) -> Result<Vec<Timing>> {
    let mut timings = Vec::new();
    // Without a depth-only format the no-stencil variants are left out.
    let variants = VARIANTS
        .into_iter()
        .filter(|v| v.stencil || ctx.caps.depth_only_format.is_some());
    for v in variants {
        let mut ms = Vec::new();
        for _ in 0..args.repeats {
            ctx.one_shot(|cmd| record(ctx, cmd, pool, targets, compute, &v, args))?;
            ms.push(timestamp_pair_ms(ctx, pool)?);
        }
        ms.sort_by(f64::total_cmp);
        timings.push(Timing {
            variant: v,
            p50_ms: ms[ms.len() / 2],
            min_ms: ms[0],
        });
    }
    Ok(timings)
}

impl ComputeResolve {
    fn destroy(self, ctx: &Context) {
        // SAFETY: the GPU is done with them (one_shot waits).
        unsafe {
            ctx.device.destroy_pipeline(self.pipeline, None);
            ctx.device.destroy_sampler(self.sampler, None);
        }
        self.sets.destroy(ctx);
    }
}

fn make_targets(ctx: &Context, extent: vk::Extent2D, samples: u32, layers: u32) -> Result<Targets> {
    let desc = |name, format, samples, usage, aspect| ImageDesc {
        name,
        format,
        extent,
        layers,
        mips: 1,
        samples,
        usage,
        aspect,
        category: "raster floors",
        flags: vk::ImageCreateFlags::empty(),
    };
    let ms = vk::SampleCountFlags::from_raw(samples);
    let one = vk::SampleCountFlags::TYPE_1;
    let att = vk::ImageUsageFlags::TRANSFER_DST;
    let colour = Image::new(
        ctx,
        &desc(
            "floors colour msaa",
            crate::render::attachments::COLOR_FORMAT,
            ms,
            vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_SRC
                | att,
            vk::ImageAspectFlags::COLOR,
        ),
    )?;
    let ds_usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | att;
    let depth_stencil = Image::new(
        ctx,
        &desc(
            "floors depth-stencil",
            ctx.caps.depth_format,
            ms,
            ds_usage,
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
        ),
    )?;
    // Without a depth-only format the variants that use it are left out;
    // the image is then made in the combined format.
    let depth_only = ctx.caps.depth_only_format.unwrap_or(ctx.caps.depth_format);
    let depth = Image::new(
        ctx,
        &desc(
            "floors depth",
            depth_only,
            ms,
            ds_usage,
            crate::gpu::depth_aspect(depth_only),
        ),
    )?;
    let resolved = Image::new(
        ctx,
        &desc(
            "floors resolved",
            crate::render::attachments::COLOR_FORMAT,
            one,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | att,
            vk::ImageAspectFlags::COLOR,
        ),
    )?;
    let storage = Image::new(
        ctx,
        &desc(
            "floors resolved (storage)",
            vk::Format::R8G8B8A8_UNORM,
            one,
            vk::ImageUsageFlags::STORAGE,
            vk::ImageAspectFlags::COLOR,
        ),
    )?;
    let array = |img: &Image| {
        Image::make_view(
            ctx,
            img.image,
            img.format,
            vk::ImageAspectFlags::COLOR,
            vk::ImageViewType::TYPE_2D_ARRAY,
            0,
            layers,
            1,
        )
    };
    let arrays = [array(&colour)?, array(&storage)?];
    Ok(Targets {
        colour,
        depth_stencil,
        depth,
        resolved,
        storage,
        arrays,
    })
}

fn make_compute(ctx: &Context, t: &Targets) -> Result<ComputeResolve> {
    let stage = vk::ShaderStageFlags::COMPUTE;
    let sets = DescriptorSets::new(
        ctx,
        &[
            (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 1, stage),
            (vk::DescriptorType::STORAGE_IMAGE, 1, stage),
        ],
        stage,
        16,
        1,
        "compute resolve",
    )?;
    // SAFETY: plain object creation; destroyed by the caller (or here on
    // failure).
    let sampler = unsafe {
        ctx.device.create_sampler(
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST),
            None,
        )
    }
    .vk("creating the compute resolve sampler");
    let sampler = match sampler {
        Ok(s) => s,
        Err(e) => {
            sets.destroy(ctx);
            return Err(e);
        }
    };
    let pipeline = compute_pipeline(
        ctx,
        sets.layout,
        &shaders::MSAA_RESOLVE_COMP.words(),
        "compute resolve",
    );
    let pipeline = match pipeline {
        Ok(p) => p,
        Err(e) => {
            // SAFETY: unused.
            unsafe { ctx.device.destroy_sampler(sampler, None) };
            sets.destroy(ctx);
            return Err(e);
        }
    };
    let colour = [vk::DescriptorImageInfo {
        sampler,
        image_view: t.arrays[0],
        image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    }];
    let storage = [vk::DescriptorImageInfo {
        sampler: vk::Sampler::null(),
        image_view: t.arrays[1],
        image_layout: vk::ImageLayout::GENERAL,
    }];
    let writes = [
        vk::WriteDescriptorSet::default()
            .dst_set(sets.sets[0])
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&colour),
        vk::WriteDescriptorSet::default()
            .dst_set(sets.sets[0])
            .dst_binding(1)
            .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
            .image_info(&storage),
    ];
    // SAFETY: the set is not in use; the views are live.
    unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    Ok(ComputeResolve {
        sets,
        pipeline,
        sampler,
    })
}

/// Resolve attachment writes are colour attachment writes.
const RESOLVE_ATTACHMENT: Use = Use {
    layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
    stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
            | vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw(),
    ),
};

/// The depth image variant `v` draws into and its aspects.
fn depth_of<'a>(t: &'a Targets, v: &Variant) -> (&'a Image, vk::ImageAspectFlags) {
    match v.stencil {
        true => (
            &t.depth_stencil,
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
        ),
        false => (&t.depth, vk::ImageAspectFlags::DEPTH),
    }
}

/// Every image starts discarded; its first use decides its layout.
fn start_barriers(t: &Targets, v: &Variant, layers: u32) -> Vec<vk::ImageMemoryBarrier2<'static>> {
    let (depth, depth_aspect) = depth_of(t, v);
    let transfer = v.clear == Clear::Transfer;
    let first = if transfer {
        Use::TRANSFER_DST
    } else {
        RESOLVE_ATTACHMENT
    };
    let depth_first = if transfer {
        Use::TRANSFER_DST
    } else {
        Use::DEPTH_ATTACHMENT
    };
    let colour = vk::ImageAspectFlags::COLOR;
    let mut start = vec![
        barrier::image(t.colour.image, colour, layers, first.discarded(), first),
        barrier::image(
            depth.image,
            depth_aspect,
            layers,
            depth_first.discarded(),
            depth_first,
        ),
    ];
    let resolved_first = match v.resolve {
        Resolve::Attachment => Some((t.resolved.image, RESOLVE_ATTACHMENT)),
        Resolve::Command => Some((t.resolved.image, Use::TRANSFER_DST)),
        Resolve::Compute => Some((t.storage.image, Use::COMPUTE_STORAGE)),
        Resolve::None => None,
    };
    if let Some((img, u)) = resolved_first {
        start.push(barrier::image(img, colour, layers, u.discarded(), u));
    }
    start
}

/// One image barrier over all `layers` of `image`.
fn transition(d: &ash::Device, cmd: vk::CommandBuffer, to: &[vk::ImageMemoryBarrier2]) {
    // SAFETY: recording into the one-shot command buffer; the barriers
    // name this device's images in the layouts they say.
    unsafe {
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(to),
        )
    };
}

/// Records variant `v`'s frame between two timestamps: the clear (by
/// transfer or by the scope's load), the empty scope and the resolve.
fn record(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    pool: vk::QueryPool,
    t: &Targets,
    compute: &ComputeResolve,
    v: &Variant,
    args: &RasterFloorsArgs,
) {
    let d = &ctx.device;
    let (depth, _) = depth_of(t, v);
    transition(d, cmd, &start_barriers(t, v, args.views));
    // SAFETY: recording into the one-shot command buffer; every image
    // belongs to this device and is in the layout its barriers say.
    unsafe {
        d.cmd_reset_query_pool(cmd, pool, 0, 2);
        d.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, pool, 0);
    }
    if v.clear == Clear::Transfer {
        clear_by_transfer(d, cmd, t, v, args.views);
    }
    if v.scope {
        begin_scope(ctx, cmd, t, depth, v, args);
        // SAFETY: ends the scope just begun.
        unsafe { d.cmd_end_rendering(cmd) };
    }
    match v.resolve {
        Resolve::None | Resolve::Attachment => {}
        Resolve::Command => resolve_by_command(d, cmd, t, args),
        Resolve::Compute => resolve_by_compute(d, cmd, t, compute, args),
    }
    // SAFETY: as above.
    unsafe { d.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, pool, 1) };
}

/// Clears colour and depth with transfer commands, then (with a scope)
/// moves them to attachment layouts.
fn clear_by_transfer(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    t: &Targets,
    v: &Variant,
    layers_n: u32,
) {
    let (depth, depth_aspect) = depth_of(t, v);
    let colour_aspect = vk::ImageAspectFlags::COLOR;
    let layers = vk::ImageSubresourceRange {
        aspect_mask: colour_aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: layers_n,
    };
    let black = vk::ClearColorValue {
        float32: [0.0, 0.0, 0.0, 1.0],
    };
    let far = vk::ClearDepthStencilValue {
        depth: 0.0,
        stencil: 0,
    };
    let depth_layers = vk::ImageSubresourceRange {
        aspect_mask: depth_aspect,
        ..layers
    };
    let dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    // SAFETY: both images were moved to TRANSFER_DST by the start barriers.
    unsafe {
        d.cmd_clear_color_image(cmd, t.colour.image, dst, &black, &[layers]);
        d.cmd_clear_depth_stencil_image(cmd, depth.image, dst, &far, &[depth_layers]);
    }
    if v.scope {
        let to = [
            barrier::image(
                t.colour.image,
                colour_aspect,
                layers_n,
                Use::TRANSFER_DST,
                RESOLVE_ATTACHMENT,
            ),
            barrier::image(
                depth.image,
                depth_aspect,
                layers_n,
                Use::TRANSFER_DST,
                Use::DEPTH_ATTACHMENT,
            ),
        ];
        transition(d, cmd, &to);
    }
}

/// Moves the multisampled colour from its resolve-attachment use to `to`.
fn colour_to(d: &ash::Device, cmd: vk::CommandBuffer, t: &Targets, layers: u32, to: Use) {
    let colour = vk::ImageAspectFlags::COLOR;
    let b = [barrier::image(
        t.colour.image,
        colour,
        layers,
        RESOLVE_ATTACHMENT,
        to,
    )];
    transition(d, cmd, &b);
}

/// Resolves the multisampled colour with vkCmdResolveImage.
fn resolve_by_command(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    t: &Targets,
    args: &RasterFloorsArgs,
) {
    let colour_aspect = vk::ImageAspectFlags::COLOR;
    colour_to(d, cmd, t, args.views, Use::TRANSFER_SRC);
    let sub = vk::ImageSubresourceLayers {
        aspect_mask: colour_aspect,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: args.views,
    };
    let region = vk::ImageResolve {
        src_subresource: sub,
        src_offset: vk::Offset3D::default(),
        dst_subresource: sub,
        dst_offset: vk::Offset3D::default(),
        extent: vk::Extent3D {
            width: args.width,
            height: args.height,
            depth: 1,
        },
    };
    // SAFETY: the colour image is in TRANSFER_SRC and the resolved image in
    // TRANSFER_DST (the start barriers), both of this device.
    unsafe {
        d.cmd_resolve_image(
            cmd,
            t.colour.image,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            t.resolved.image,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &[region],
        )
    };
}

/// Resolves the multisampled colour in a compute shader into the storage
/// image.
fn resolve_by_compute(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    t: &Targets,
    compute: &ComputeResolve,
    args: &RasterFloorsArgs,
) {
    colour_to(d, cmd, t, args.views, Use::COMPUTE_SAMPLED);
    let push = [args.width, args.height, args.views, args.samples];
    let bind = vk::PipelineBindPoint::COMPUTE;
    // SAFETY: the pipeline and sets were made for this device; the colour
    // image is sampled and the storage image in GENERAL (start barriers).
    unsafe {
        d.cmd_bind_pipeline(cmd, bind, compute.pipeline);
        d.cmd_bind_descriptor_sets(cmd, bind, compute.sets.layout, 0, &compute.sets.sets, &[]);
        d.cmd_push_constants(
            cmd,
            compute.sets.layout,
            vk::ShaderStageFlags::COMPUTE,
            0,
            crate::gpu::memory::as_bytes(&push),
        );
        d.cmd_dispatch(
            cmd,
            args.width.div_ceil(8),
            args.height.div_ceil(8),
            args.views,
        );
    }
}

/// Begins the empty multiview scope of variant `v`.
fn begin_scope(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    t: &Targets,
    depth: &Image,
    v: &Variant,
    args: &RasterFloorsArgs,
) {
    let colour_load = match v.clear {
        Clear::Scope => vk::AttachmentLoadOp::CLEAR,
        Clear::ScopeDepthOnly => vk::AttachmentLoadOp::DONT_CARE,
        Clear::Transfer => vk::AttachmentLoadOp::LOAD,
    };
    let mut colour = vk::RenderingAttachmentInfo::default()
        .image_view(t.colour.view)
        .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .load_op(colour_load)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            color: vk::ClearColorValue {
                float32: [0.0, 0.0, 0.0, 1.0],
            },
        });
    if v.resolve == Resolve::Attachment {
        colour = colour
            .store_op(vk::AttachmentStoreOp::DONT_CARE)
            .resolve_mode(vk::ResolveModeFlags::AVERAGE)
            .resolve_image_view(t.resolved.view)
            .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
    }
    let depth_load = if v.clear == Clear::Transfer {
        vk::AttachmentLoadOp::LOAD
    } else {
        vk::AttachmentLoadOp::CLEAR
    };
    let depth_info = vk::RenderingAttachmentInfo::default()
        .image_view(depth.view)
        .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
        .load_op(depth_load)
        .store_op(vk::AttachmentStoreOp::DONT_CARE)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 0.0,
                stencil: 0,
            },
        });
    let colours = [colour];
    let mut info = vk::RenderingInfo::default()
        .render_area(vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: vk::Extent2D {
                width: args.width,
                height: args.height,
            },
        })
        .layer_count(1)
        .view_mask(if args.views == 2 { 0b11 } else { 0 })
        .color_attachments(&colours)
        .depth_attachment(&depth_info);
    if v.stencil {
        info = info.stencil_attachment(&depth_info);
    }
    let (viewport, area) = crate::render::passes::whole(vk::Extent2D {
        width: args.width,
        height: args.height,
    });
    // SAFETY: inside the one-shot command buffer, outside any scope; the
    // attachments are in attachment layouts. The viewport and scissor are
    // set as the renderer's scopes set them (Mesa 25's lavapipe crashes on
    // an empty multiview scope without them).
    unsafe {
        ctx.device.cmd_set_viewport(cmd, 0, &[viewport]);
        ctx.device.cmd_set_scissor(cmd, 0, &[area]);
        ctx.device.cmd_begin_rendering(cmd, &info);
    }
}
