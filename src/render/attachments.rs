//! The stereo render targets. Multiview renders into 2-layer images; two-pass
//! renders into one single-layer set per eye (as an OpenXR session would use
//! one swapchain per view). Each set is a multisampled colour and
//! depth-stencil pair as transient attachments (lazily allocated memory where
//! the device has it; contents never stored) and a single-sample resolve
//! image that holds the frame.

use crate::error::Result;
use crate::gpu::memory::{Image, ImageDesc};
use crate::gpu::Context;
use ash::vk;

/// Colour format of the resolved frame (what an OpenXR swapchain would use).
pub const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;

/// Views one rendering scope draws into.
#[derive(Clone, Copy)]
pub struct TargetViews {
    /// Multisampled colour (or the resolve image at 1 sample).
    pub color: vk::ImageView,
    /// Depth-stencil.
    pub depth: vk::ImageView,
    /// Resolve target (None at 1 sample).
    pub resolve: Option<vk::ImageView>,
    /// Depth resolve target (None at 1 sample or when depth is not kept).
    pub depth_resolve: Option<vk::ImageView>,
    /// Whether the depth contents must be stored (kept at 1 sample).
    pub store_depth: bool,
    /// Whether the depth attachment has a stencil aspect (bound as the
    /// stencil attachment too).
    pub stencil: bool,
}

/// One set of attachments (2 layers for multiview, 4 for `inset`'s four
/// views, 1 for an eye in two-pass).
pub struct AttachmentSet {
    /// Multisampled colour (None at 1 sample).
    pub color_msaa: Option<Image>,
    /// Depth-stencil (multisampled to match).
    pub depth: Image,
    /// Resolved (or directly rendered) colour.
    pub resolve: Image,
    /// Resolved depth (kept depth at more than 1 sample).
    pub depth_resolve: Option<Image>,
    /// Whether the frame's depth is kept for output.
    pub keep_depth: bool,
    /// Radial density masking with reconstruction: the image the fill pass
    /// writes (the frame's output), and a 2D-array view of `resolve` it
    /// samples.
    pub filled: Option<(Image, vk::ImageView)>,
    /// A UNORM 2D-array view of the composed output for compute writes
    /// (with [`SetOptions::storage_output`]).
    pub filled_storage: Option<vk::ImageView>,
    /// A UNORM 2D-array view of `resolve` for compute work in place
    /// (with [`SetOptions::storage_resolve`]).
    pub resolve_storage: Option<vk::ImageView>,
    /// A one-sample depth image for drawing the set at one sample straight
    /// into `resolve` (with [`SetOptions::one_sample_depth`] at more than
    /// one sample; [`AttachmentSet::views_one_sample`]).
    pub depth_one_sample: Option<Image>,
}

/// What a set's images must support beyond drawing and resolving.
#[derive(Clone, Copy, Debug)]
pub struct SetOptions {
    /// The depth attachment's format (the renderer's: with a stencil
    /// aspect only when a pass uses stencil or the depth goes to a depth
    /// swapchain).
    pub depth_format: vk::Format,
    /// Keep a single-sample copy of the frame's depth (for output).
    pub keep_depth: bool,
    /// Add a composed output image (`filled`), written by a pass after the
    /// scene from the sampled resolve image: radial density masking's
    /// reconstruction, or the inset composite.
    pub composed: bool,
    /// Make the resolve image sampleable (and the kept depth, with
    /// `keep_depth`).
    pub sampled: bool,
    /// The composed output image is written by a compute shader (the
    /// inset composite): it gets storage use and a UNORM view
    /// ([`AttachmentSet::filled_storage`]).
    pub storage_output: bool,
    /// The resolve image is changed in place by a compute shader (radial
    /// density masking's fill in the inset's wide views and in lens-matched
    /// shading's image): it gets storage use and a UNORM view
    /// ([`AttachmentSet::resolve_storage`]).
    pub storage_resolve: bool,
    /// Occlusion culling: the frame is drawn in two rendering scopes, so
    /// the multisampled colour and depth are stored between them (not
    /// transient), and the depth is sampleable (the depth pyramid).
    pub occlusion: bool,
    /// Layers of a multiview set's drawn images: 2, or 4 for `inset`'s
    /// four views (the eyes, then the wide views); the composed output
    /// keeps the eyes' 2.
    pub multiview_layers: u32,
    /// Also a one-sample depth image, so that a frame may draw the set at
    /// one sample into its resolve image instead (`aq`'s MSAA rung on the
    /// inset's wide view).
    pub one_sample_depth: bool,
}

impl AttachmentSet {
    /// Creates one set of `layers` layers with `samples` per pixel.
    pub fn new(
        ctx: &Context,
        extent: vk::Extent2D,
        samples: u32,
        layers: u32,
        opts: SetOptions,
    ) -> Result<AttachmentSet> {
        let size = Size {
            extent,
            layers,
            samples,
        };
        // What is made so far: destroyed if a later image fails.
        let mut p = Parts::default();
        let made = p.make(ctx, &size, &opts);
        match (made, p) {
            (
                Ok(()),
                Parts {
                    color_msaa,
                    depth: Some(depth),
                    resolve: Some(resolve),
                    depth_resolve,
                    depth_one_sample,
                    filled,
                    filled_view,
                    filled_storage,
                    resolve_storage,
                },
            ) => Ok(AttachmentSet {
                color_msaa,
                depth,
                resolve,
                depth_resolve,
                keep_depth: opts.keep_depth,
                filled: filled.zip(filled_view),
                filled_storage,
                resolve_storage,
                depth_one_sample,
            }),
            (made, p) => {
                p.destroy(ctx);
                Err(made.err().unwrap_or_else(|| {
                    crate::error::Error::Gpu("an attachment set was left unmade".into())
                }))
            }
        }
    }

    /// The image holding the finished frame: the RDM-filled image when
    /// there is one, else the resolve image.
    pub fn output_image(&self) -> &Image {
        self.filled.as_ref().map_or(&self.resolve, |(f, _)| f)
    }

    /// The single-sample image holding this set's depth when it is kept.
    pub fn depth_output(&self) -> Option<&Image> {
        match &self.depth_resolve {
            Some(d) => Some(d),
            None if self.keep_depth => Some(&self.depth),
            None => None,
        }
    }

    /// The views for drawing this set at one sample straight into its
    /// resolve image (None without a one-sample depth image).
    pub fn views_one_sample(&self) -> Option<TargetViews> {
        let depth = self.depth_one_sample.as_ref()?;
        Some(TargetViews {
            color: self.resolve.view,
            depth: depth.view,
            resolve: None,
            depth_resolve: None,
            store_depth: false,
            stencil: crate::gpu::has_stencil(depth.format),
        })
    }

    /// The views of this set.
    pub fn views(&self) -> TargetViews {
        match &self.color_msaa {
            Some(c) => TargetViews {
                color: c.view,
                depth: self.depth.view,
                resolve: Some(self.resolve.view),
                depth_resolve: self.depth_resolve.as_ref().map(|d| d.view),
                store_depth: false,
                stencil: crate::gpu::has_stencil(self.depth.format),
            },
            None => TargetViews {
                color: self.resolve.view,
                depth: self.depth.view,
                resolve: None,
                depth_resolve: None,
                store_depth: self.keep_depth,
                stencil: crate::gpu::has_stencil(self.depth.format),
            },
        }
    }

    /// Destroys its images.
    pub fn destroy(self, ctx: &Context) {
        let (filled, filled_view) = self.filled.unzip();
        Parts {
            color_msaa: self.color_msaa,
            depth: Some(self.depth),
            resolve: Some(self.resolve),
            depth_resolve: self.depth_resolve,
            depth_one_sample: self.depth_one_sample,
            filled,
            filled_view,
            filled_storage: self.filled_storage,
            resolve_storage: self.resolve_storage,
        }
        .destroy(ctx);
    }
}

/// A set's size: its extent, layers and samples per pixel.
struct Size {
    extent: vk::Extent2D,
    layers: u32,
    samples: u32,
}

impl Size {
    /// One of the set's images: this size (with `samples`), `format`,
    /// `usage` and `aspect`.
    fn desc(
        &self,
        name: &'static str,
        format: vk::Format,
        samples: vk::SampleCountFlags,
        usage: vk::ImageUsageFlags,
        aspect: vk::ImageAspectFlags,
    ) -> ImageDesc<'static> {
        ImageDesc {
            name,
            format,
            extent: self.extent,
            layers: self.layers,
            mips: 1,
            samples,
            usage,
            aspect,
            category: "render target",
            flags: vk::ImageCreateFlags::empty(),
        }
    }
}

/// An attachment set's images and views as they are made (all optional
/// until the set is whole), so that a set left half made is destroyed.
#[derive(Default)]
struct Parts {
    color_msaa: Option<Image>,
    depth: Option<Image>,
    resolve: Option<Image>,
    depth_resolve: Option<Image>,
    depth_one_sample: Option<Image>,
    filled: Option<Image>,
    filled_view: Option<vk::ImageView>,
    filled_storage: Option<vk::ImageView>,
    resolve_storage: Option<vk::ImageView>,
}

impl Parts {
    /// Makes the set's images in order (colour MSAA, depth, resolves,
    /// the composed output), stopping at the first that fails.
    fn make(&mut self, ctx: &Context, size: &Size, opts: &SetOptions) -> Result<()> {
        let s = vk::SampleCountFlags::from_raw(size.samples);
        // Occlusion samples the depth, so nothing of it is transient.
        let transient = match opts.occlusion {
            true => vk::ImageUsageFlags::empty(),
            false => vk::ImageUsageFlags::TRANSIENT_ATTACHMENT,
        };
        if size.samples > 1 {
            let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | transient;
            let d = size.desc(
                "colour msaa",
                COLOR_FORMAT,
                s,
                usage,
                vk::ImageAspectFlags::COLOR,
            );
            self.color_msaa = Some(Image::new(ctx, &d)?);
        }
        self.make_depth(ctx, size, opts, transient)?;
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let sampled = match opts.composed || opts.sampled {
            true => vk::ImageUsageFlags::SAMPLED,
            false => vk::ImageUsageFlags::empty(),
        };
        let one = vk::SampleCountFlags::TYPE_1;
        let colour = vk::ImageAspectFlags::COLOR;
        let d = size.desc("colour resolve", COLOR_FORMAT, one, usage | sampled, colour);
        // sRGB has no storage use: made mutable with extended usage and
        // changed through a UNORM view.
        let d = match opts.storage_resolve {
            true => ImageDesc {
                usage: d.usage | vk::ImageUsageFlags::STORAGE,
                flags: vk::ImageCreateFlags::MUTABLE_FORMAT | vk::ImageCreateFlags::EXTENDED_USAGE,
                ..d
            },
            false => d,
        };
        let resolve_image = self.resolve.insert(Image::new(ctx, &d)?).image;
        if opts.storage_resolve {
            self.resolve_storage = Some(Image::view_for(
                ctx,
                resolve_image,
                vk::Format::R8G8B8A8_UNORM,
                colour,
                vk::ImageViewType::TYPE_2D_ARRAY,
                (0, size.layers),
                1,
                Some(vk::ImageUsageFlags::STORAGE),
            )?);
        }
        if !opts.composed {
            return Ok(());
        }
        // The frame the runtime gets: the eyes' layers.
        let output_layers = size.layers.min(2);
        let plain = ImageDesc {
            layers: output_layers,
            ..size.desc("composed output", COLOR_FORMAT, one, usage, colour)
        };
        let layers = (size.layers, output_layers);
        self.make_composed(ctx, plain, resolve_image, layers, opts.storage_output)
    }

    /// The depth-stencil image, its one-sample resolve when the depth is
    /// kept under MSAA, and the one-sample depth of a set that also draws
    /// at one sample. Sampled: the depth pyramid reads the multisampled
    /// depth; a sampled set that keeps its depth (the inset's wide views
    /// under inset-taa) has its kept depth read.
    fn make_depth(
        &mut self,
        ctx: &Context,
        size: &Size,
        opts: &SetOptions,
        transient: vk::ImageUsageFlags,
    ) -> Result<()> {
        let format = opts.depth_format;
        let aspect = crate::gpu::depth_aspect(format);
        let usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        let (s, one) = (
            vk::SampleCountFlags::from_raw(size.samples),
            vk::SampleCountFlags::TYPE_1,
        );
        let stored = opts.keep_depth && size.samples == 1;
        let sampled = match opts.occlusion || (opts.sampled && stored) {
            true => vk::ImageUsageFlags::SAMPLED,
            false => vk::ImageUsageFlags::empty(),
        };
        let depth_usage = match stored {
            true => usage | sampled | vk::ImageUsageFlags::TRANSFER_SRC,
            false => usage | sampled | transient,
        };
        let d = size.desc("depth-stencil", format, s, depth_usage, aspect);
        self.depth = Some(Image::new(ctx, &d)?);
        if opts.keep_depth && size.samples > 1 {
            let read = match opts.sampled {
                true => vk::ImageUsageFlags::SAMPLED,
                false => vk::ImageUsageFlags::empty(),
            };
            let resolve_usage = usage | vk::ImageUsageFlags::TRANSFER_SRC | read;
            let d = size.desc("depth resolve", format, one, resolve_usage, aspect);
            self.depth_resolve = Some(Image::new(ctx, &d)?);
        }
        if opts.one_sample_depth && size.samples > 1 {
            let d = size.desc(
                "depth-stencil one sample",
                format,
                one,
                usage | transient,
                aspect,
            );
            self.depth_one_sample = Some(Image::new(ctx, &d)?);
        }
        Ok(())
    }

    /// The composed output (`plain`, with storage use and a UNORM view
    /// when `storage_output`), and a 2D-array view of the resolve image
    /// `resolve_image` of `layers` layers that the composing pass samples.
    fn make_composed(
        &mut self,
        ctx: &Context,
        plain: ImageDesc,
        resolve_image: vk::Image,
        (layers, output_layers): (u32, u32),
        storage_output: bool,
    ) -> Result<()> {
        let usage = plain.usage;
        // sRGB has no storage use: the image is made mutable with
        // extended usage and written through a UNORM view.
        let filled = self.filled.insert(Image::new(
            ctx,
            &if storage_output {
                ImageDesc {
                    usage: usage | vk::ImageUsageFlags::STORAGE,
                    flags: vk::ImageCreateFlags::MUTABLE_FORMAT
                        | vk::ImageCreateFlags::EXTENDED_USAGE,
                    ..plain
                }
            } else {
                plain
            },
        )?);
        let filled_image = filled.image;
        self.filled_view = Some(Image::make_view(
            ctx,
            resolve_image,
            COLOR_FORMAT,
            vk::ImageAspectFlags::COLOR,
            vk::ImageViewType::TYPE_2D_ARRAY,
            0,
            layers,
            1,
        )?);
        if storage_output {
            self.filled_storage = Some(Image::view_for(
                ctx,
                filled_image,
                vk::Format::R8G8B8A8_UNORM,
                vk::ImageAspectFlags::COLOR,
                vk::ImageViewType::TYPE_2D_ARRAY,
                (0, output_layers),
                1,
                Some(vk::ImageUsageFlags::STORAGE),
            )?);
        }
        Ok(())
    }

    /// Destroys the views, then the images; the device must be idle.
    fn destroy(self, ctx: &Context) {
        for view in [self.filled_storage, self.filled_view, self.resolve_storage]
            .into_iter()
            .flatten()
        {
            // SAFETY: the GPU is idle when attachments are destroyed.
            unsafe { ctx.device.destroy_image_view(view, None) };
        }
        let images = [
            self.color_msaa,
            self.depth,
            self.resolve,
            self.depth_resolve,
            self.depth_one_sample,
            self.filled,
        ];
        for img in images.into_iter().flatten() {
            img.destroy(ctx);
        }
    }
}

/// The attachments of one stereo frame.
pub struct Attachments {
    /// One 2-layer set (multiview; 4 layers for `inset`'s four views) or
    /// one single-layer set per eye (two-pass).
    pub sets: Vec<AttachmentSet>,
    /// Per-eye size.
    pub extent: vk::Extent2D,
}

impl Attachments {
    /// Creates the attachments for `extent` per eye with `samples` (1 or 4)
    /// and what `opts` asks for.
    pub fn new(
        ctx: &Context,
        extent: vk::Extent2D,
        samples: u32,
        multiview: bool,
        opts: SetOptions,
    ) -> Result<Attachments> {
        let (count, layers) = if multiview {
            (1, opts.multiview_layers)
        } else {
            (2, 1)
        };
        let mut sets = Vec::with_capacity(count);
        for _ in 0..count {
            match AttachmentSet::new(ctx, extent, samples, layers, opts) {
                Ok(set) => sets.push(set),
                Err(e) => {
                    // The sets made before go too.
                    for set in sets {
                        set.destroy(ctx);
                    }
                    return Err(e);
                }
            }
        }
        Ok(Attachments { sets, extent })
    }

    /// Whether the transient attachments got lazily allocated memory.
    pub fn lazily_allocated(&self) -> bool {
        self.sets[0].depth.lazy
    }

    /// Barriers that discard the previous frame's contents and make the
    /// attachments writable.
    pub fn begin_barriers(&self) -> Vec<vk::ImageMemoryBarrier2<'static>> {
        begin_barriers(&self.sets)
    }

    /// Destroys all images.
    pub fn destroy(self, ctx: &Context) {
        for s in self.sets {
            s.destroy(ctx);
        }
    }
}

/// Barriers that discard the previous contents of `sets` and make their
/// attachments writable.
pub fn begin_barriers(sets: &[AttachmentSet]) -> Vec<vk::ImageMemoryBarrier2<'static>> {
    let mut out = Vec::new();
    let mut add = |img: &Image, aspect: vk::ImageAspectFlags, layout, stage, access| {
        out.push(
            vk::ImageMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(stage)
                .dst_access_mask(access)
                .old_layout(vk::ImageLayout::UNDEFINED)
                .new_layout(layout)
                .image(img.image)
                .subresource_range(vk::ImageSubresourceRange {
                    aspect_mask: aspect,
                    base_mip_level: 0,
                    level_count: 1,
                    base_array_layer: 0,
                    layer_count: img.layers,
                }),
        );
    };
    let color_stage = vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT;
    let color_access =
        vk::AccessFlags2::COLOR_ATTACHMENT_READ | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE;
    for set in sets {
        if let Some(c) = &set.color_msaa {
            add(
                c,
                vk::ImageAspectFlags::COLOR,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                color_stage,
                color_access,
            );
        }
        if let Some((f, _)) = &set.filled {
            add(
                f,
                vk::ImageAspectFlags::COLOR,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                color_stage,
                color_access,
            );
        }
        add(
            &set.resolve,
            vk::ImageAspectFlags::COLOR,
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            color_stage,
            color_access,
        );
        let depths = std::iter::once(&set.depth)
            .chain(&set.depth_resolve)
            .chain(&set.depth_one_sample);
        for d in depths {
            add(
                d,
                crate::gpu::depth_aspect(d.format),
                vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                // Resolves are synchronized as colour attachment accesses.
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
                    | vk::AccessFlags2::COLOR_ATTACHMENT_READ
                    | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            );
        }
    }
    out
}

/// The barrier between a frame's first and second rendering scopes
/// (occlusion): the colour the first stored is loaded and written by the
/// second. (The depth goes through the depth pyramid's own barriers.)
pub fn between_scopes() -> vk::MemoryBarrier2<'static> {
    vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT)
        .src_access_mask(vk::AccessFlags2::COLOR_ATTACHMENT_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT)
        .dst_access_mask(
            vk::AccessFlags2::COLOR_ATTACHMENT_READ | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
        )
}
