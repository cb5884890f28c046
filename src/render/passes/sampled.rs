//! Attachment sets drawn by one pass and sampled by a later one: the inset's
//! wide view and lens-matched shading's image. Each set's resolved colour
//! gets a 2D-array view (whatever its layer count) and one linear,
//! clamp-to-edge sampler serves them all.

use crate::error::{Result, VkContext};
use crate::gpu::Context;
use crate::render::attachments::{AttachmentSet, Attachments, SetOptions, COLOR_FORMAT};
use ash::vk;

/// What sampled sets are made with beyond drawing and resolving.
#[derive(Clone, Copy, Debug, Default)]
pub struct SampledOptions {
    /// Samples per pixel.
    pub samples: u32,
    /// Also drawable at one sample ([`SetOptions::one_sample_depth`]).
    pub one_sample_depth: bool,
    /// The depth kept and sampleable ([`AttachmentSet::depth_output`]).
    pub keep_depth: bool,
    /// Drawn in occlusion's two scopes, the depth read by the depth
    /// pyramid ([`SetOptions::occlusion`]).
    pub occlusion: bool,
    /// The resolve images changed in place by a compute shader
    /// ([`SetOptions::storage_resolve`]).
    pub storage_resolve: bool,
}

/// Sampled attachment sets, their array views and sampler.
pub struct SampledSets {
    /// The sets (as the eye's: one 2-layer set under multiview, one per eye
    /// in two-pass), resolved images sampled.
    pub sets: Vec<AttachmentSet>,
    /// Their size.
    pub extent: vk::Extent2D,
    views: Vec<vk::ImageView>,
    sampler: vk::Sampler,
}

impl SampledSets {
    /// Sets of `extent` as `opts` asks, their views and the sampler
    /// (`what` names it in errors); on failure, destroys what it made.
    pub fn new(
        ctx: &Context,
        extent: vk::Extent2D,
        opts: &SampledOptions,
        multiview: bool,
        depth_format: vk::Format,
        what: &str,
    ) -> Result<SampledSets> {
        let set_opts = SetOptions {
            depth_format,
            keep_depth: opts.keep_depth,
            composed: false,
            sampled: true,
            storage_output: false,
            storage_resolve: opts.storage_resolve,
            occlusion: opts.occlusion,
            multiview_layers: 2,
            one_sample_depth: opts.one_sample_depth,
        };
        let sets = Attachments::new(ctx, extent, opts.samples, multiview, set_opts)?.sets;
        Self::with_sets(ctx, sets, extent, what)
    }

    /// No sets, only the sampler: for a pass that samples images it does
    /// not own (`inset`'s four views, whose wide view lies in the eye's
    /// own layers).
    pub fn sampler_only(ctx: &Context, extent: vk::Extent2D, what: &str) -> Result<SampledSets> {
        Self::with_sets(ctx, Vec::new(), extent, what)
    }

    /// `sets` with their array views and the sampler; on failure, destroys
    /// what it made and the sets.
    fn with_sets(
        ctx: &Context,
        sets: Vec<AttachmentSet>,
        extent: vk::Extent2D,
        what: &str,
    ) -> Result<SampledSets> {
        let mut made = SampledSets {
            sets,
            extent,
            views: Vec::new(),
            sampler: vk::Sampler::null(),
        };
        match made.finish(ctx, what) {
            Ok(()) => Ok(made),
            Err(e) => {
                made.destroy(ctx);
                Err(e)
            }
        }
    }

    fn finish(&mut self, ctx: &Context, what: &str) -> Result<()> {
        for set in &self.sets {
            // Sampled only: a resolve image with storage use (changed in
            // place through its UNORM view) has uses sRGB lacks.
            self.views.push(crate::gpu::memory::Image::view_for(
                ctx,
                set.resolve.image,
                COLOR_FORMAT,
                vk::ImageAspectFlags::COLOR,
                vk::ImageViewType::TYPE_2D_ARRAY,
                (0, set.resolve.layers),
                1,
                Some(vk::ImageUsageFlags::SAMPLED),
            )?);
        }
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        // SAFETY: plain object creation; destroyed by `destroy`.
        self.sampler = unsafe { ctx.device.create_sampler(&info, None) }
            .vk(&format!("creating the {what}'s sampler"))?;
        Ok(())
    }

    /// The linear, clamp-to-edge sampler the sets' views are read with.
    pub fn sampler(&self) -> vk::Sampler {
        self.sampler
    }

    /// The sampler and view of `view` as a descriptor (shader-read layout).
    pub fn info(&self, view: vk::ImageView) -> vk::DescriptorImageInfo {
        vk::DescriptorImageInfo {
            sampler: self.sampler,
            image_view: view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }
    }

    /// The two array elements a composing shader indexes by attachment
    /// set: the sets' views, the second repeating the first under
    /// multiview (None before any view exists).
    pub fn infos(&self) -> Option<[vk::DescriptorImageInfo; 2]> {
        (!self.views.is_empty()).then(|| {
            pair(
                &self.views,
                self.sampler,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            )
        })
    }

    /// Destroys the sampler, views and sets; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        if self.sampler != vk::Sampler::null() {
            // SAFETY: the device is idle; the sampler belongs to `self`.
            unsafe { ctx.device.destroy_sampler(self.sampler, None) };
        }
        for v in self.views {
            // SAFETY: the device is idle; the view belongs to `self`.
            unsafe { ctx.device.destroy_image_view(v, None) };
        }
        for s in self.sets {
            s.destroy(ctx);
        }
    }
}

/// The two array elements a shader indexes by attachment set, from one
/// view per set (`views`, at least one): the second repeats the first
/// when there is one set (multiview).
pub fn pair(
    views: &[vk::ImageView],
    sampler: vk::Sampler,
    layout: vk::ImageLayout,
) -> [vk::DescriptorImageInfo; 2] {
    let v0 = views[0];
    let v1 = views.get(1).copied().unwrap_or(v0);
    [v0, v1].map(|image_view| vk::DescriptorImageInfo {
        sampler,
        image_view,
        image_layout: layout,
    })
}
