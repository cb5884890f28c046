//! Multi-resolution foveated rendering (`inset[=F]`, `inset-fov=DEG`): each
//! eye is rendered twice, as a wide view over its whole FOV into targets
//! of F × the eye size per axis (`forward-wide`), and as the eye itself at
//! full size but only inside the inset rectangle around the gaze — render
//! area and scissor limited to it, so only its pixels are rasterized,
//! cleared and resolved (`forward-inset`). The composite (`inset-composite`,
//! `shaders/inset_composite.comp`, a compute pass: on a GPU with little
//! raster hardware a full-resolution fragment pass is the dearer way) then
//! writes the eye image: the wide view
//! upsampled bilinearly, the inset over it with a feathered seam
//! ([`crate::view::inset`] has the rectangle and the weight). Culling tests
//! each eye once: the wide views draw the eye's visible list, the inset
//! views the part of it inside the eyes' volumes through the rectangle
//! (`Batcher::build_inset`; with `gpu-cull`, the GPU's list).
//!
//! The inset keeps the eye's own projection and viewport, so its pixels are
//! the full-resolution render's own; the wide view keeps the eye's
//! projection with a smaller viewport, so it is the same image at a lower
//! resolution.
//!
//! With `inset-views=4` under multiview, where the device draws four views
//! in one scope (maxMultiviewViewCount >= 4), all four go into one scope
//! (`forward-four-view`) on 4-layer eye-sized targets: layers 0 and 1 are
//! the eyes as before, layers 2 and 3 the wide views. The views share one
//! viewport and render area, so a wide view is drawn at its own size into
//! a region of its layer ([`crate::view::inset::wide_region`], centred on
//! the inset): its view has the eye's pose and the FOV that puts the eye's
//! FOV exactly on the region's pixels ([`crate::view::inset::layer_fov`]);
//! the render area is the region and the inset together. One scope, one
//! draw list (the eye's) and one clear and resolve, for more work: every
//! view gets the whole render area and the whole list. On the H200 that
//! is the slower path (factory:100000 12.43 against 8.46 ms,
//! `bench/results/2026-12-03-h200-inset-four-view.md`: there the multiview
//! views cost as separate views), so two scopes are the default.

use super::inset_taa::{InsetTaa, TaaSettings};
use super::sampled::SampledSets;
use super::{PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::barrier::{self, Use};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::view::inset::PixelRect;
use ash::vk;

/// The composite's push constants: the inset (2 words), the feather, the
/// attachment set, the wide view's region (origin, size), its first layer,
/// the eyes' drawn size, the wide view's upsampling filter and the
/// sharpening's strength.
const PUSH_BYTES: u32 = 10 * 4;

/// How the wide views' targets are made.
#[derive(Clone, Copy, Debug)]
pub struct WideOptions {
    /// Samples per pixel.
    pub samples: u32,
    /// Over MSAA, also drawable at one sample (`aq`'s MSAA rung, see
    /// [`InsetPass::set_one_sample`]).
    pub msaa_rung: bool,
    /// Drawn in occlusion's two scopes, their depth sampled by the depth
    /// pyramid.
    pub occlusion: bool,
    /// Radial density masking's fill changes the resolved wide views in
    /// place (storage use).
    pub rdm: bool,
}

/// The wide view's targets and the composite's compute pipeline with its
/// one descriptor set (the frames do not change between frame slots).
pub struct InsetPass {
    /// The wide view's attachment sets at F × the eye size (as the eye's:
    /// one 2-layer set under multiview, one per eye in two-pass), resolved
    /// images sampled; with four views none (only the sampler: the wide
    /// views are layers 2 and 3 of the eye's set), `extent` still the wide
    /// view's size.
    pub wide: SampledSets,
    /// Four views in one multiview scope (the pipelines' view mask is
    /// 0b1111).
    four_view: bool,
    /// The wide view's scale per axis (`inset=F`).
    scale: f64,
    /// The factor on `scale` this frame (`aq`'s inset rung; 1 otherwise).
    factor: f64,
    /// This frame's wide views are drawn at one sample into the resolve
    /// images (`aq`'s MSAA rung; only where the sets have a one-sample
    /// depth image).
    one_sample: bool,
    /// `inset-taa`: the wide views' temporal anti-aliasing, whose history
    /// the composite reads as the wide view.
    taa: Option<InsetTaa>,
    /// `inset-catmull-rom`: the composite reads the wide view through the
    /// Catmull-Rom filter (false: bilinearly).
    pub catmull_rom: bool,
    /// `inset-sharpen`: the strength with which the composite sharpens the
    /// upsampled history (0: not at all; only with `inset-taau`).
    pub sharpen: f32,
    sets: DescriptorSets,
    composite: vk::Pipeline,
    /// The composite's barriers for the bound targets, made once by
    /// [`InsetPass::bind`] (not per frame): resolves to compute-sampled and
    /// outputs to storage before, outputs back to colour attachment after.
    before: Vec<vk::ImageMemoryBarrier2<'static>>,
    after: Vec<vk::ImageMemoryBarrier2<'static>>,
}

impl InsetPass {
    /// The wide targets at `scale` × `extent` as `wide_options` says,
    /// with `taa` their temporal
    /// anti-aliasing (upsampling to `extent` with `inset-taau`), and the
    /// composite; on failure, destroys what it made.
    pub fn new(
        setup: &PipelineSetup,
        extent: vk::Extent2D,
        scale: f64,
        wide_options: WideOptions,
        multiview: bool,
        taa: Option<TaaSettings>,
    ) -> Result<InsetPass> {
        let ctx = setup.ctx;
        let wide_extent = crate::render::scaled(extent, scale);
        let four_view = setup.view_mask == 0b1111;
        let wide = if four_view {
            SampledSets::sampler_only(ctx, wide_extent, "inset composite")?
        } else {
            SampledSets::new(
                ctx,
                wide_extent,
                &super::sampled::SampledOptions {
                    samples: wide_options.samples,
                    one_sample_depth: wide_options.msaa_rung,
                    keep_depth: taa.is_some(),
                    occlusion: wide_options.occlusion,
                    storage_resolve: wide_options.rdm,
                },
                multiview,
                setup.depth_format,
                "inset composite",
            )?
        };
        let taa = match taa
            .filter(|_| !four_view)
            .map(|settings| InsetTaa::new(ctx, &wide, settings, extent))
        {
            Some(Ok(t)) => Some(t),
            Some(Err(e)) => {
                wide.destroy(ctx);
                return Err(e);
            }
            None => None,
        };
        let stage = vk::ShaderStageFlags::COMPUTE;
        let sets = match DescriptorSets::new(
            ctx,
            &[
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 2, stage),
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 2, stage),
                (vk::DescriptorType::STORAGE_IMAGE, 2, stage),
            ],
            stage,
            PUSH_BYTES,
            1,
            "inset composite",
        ) {
            Ok(s) => s,
            Err(e) => {
                if let Some(t) = taa {
                    t.destroy(ctx);
                }
                wide.destroy(ctx);
                return Err(e);
            }
        };
        match compute_pipeline(
            ctx,
            sets.layout,
            &shaders::INSET_COMPOSITE_COMP.words(),
            "inset composite",
        ) {
            Ok(composite) => Ok(InsetPass {
                wide,
                four_view,
                scale,
                factor: 1.0,
                one_sample: false,
                taa,
                catmull_rom: false,
                sharpen: 0.0,
                sets,
                composite,
                before: Vec::new(),
                after: Vec::new(),
            }),
            Err(e) => {
                sets.destroy(ctx);
                if let Some(t) = taa {
                    t.destroy(ctx);
                }
                wide.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Whether the four views are drawn in one multiview scope.
    pub fn four_view(&self) -> bool {
        self.four_view
    }

    /// Writes the composite's descriptor set for the frame's `targets`:
    /// per attachment set the eye's resolved frame (binding 0), the wide
    /// view's (binding 1; with four views the eye's frame again, whose
    /// layers 2 and 3 hold it) and the composed output's UNORM view
    /// (binding 2), the second element repeating the first under
    /// multiview. Call
    /// once the targets exist, before the first frame. Fails when the
    /// targets lack the composed output or its storage view (made without
    /// `SetOptions::storage_output`).
    pub fn bind(&mut self, ctx: &Context, targets: &Attachments) -> Result<()> {
        let eye: Vec<vk::ImageView> = targets
            .sets
            .iter()
            .filter_map(|s| s.filled.as_ref().map(|f| f.1))
            .collect();
        let out: Vec<vk::ImageView> = targets
            .sets
            .iter()
            .filter_map(|s| s.filled_storage)
            .collect();
        let (Some(&e0), Some(_)) = (eye.first(), out.first()) else {
            return Err(crate::error::Error::Gpu(
                "the inset composite's targets have no composed output with a storage view".into(),
            ));
        };
        let e1 = eye.get(1).copied().unwrap_or(e0);
        let frames = [self.wide.info(e0), self.wide.info(e1)];
        let wide = match (self.wide.infos(), self.four_view) {
            // With inset-taa the composite reads the wide views' history.
            (Some(_), false) if self.taa.is_some() => {
                self.taa.as_ref().map(InsetTaa::infos).expect("checked")
            }
            (Some(w), false) => w,
            (None, true) => frames,
            _ => {
                return Err(crate::error::Error::Gpu(
                    "the inset composite has no wide view to sample".into(),
                ))
            }
        };
        let storage = super::sampled::pair(&out, vk::Sampler::null(), vk::ImageLayout::GENERAL);
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        // No frame has used the set yet.
        self.sets.write_images(
            ctx,
            0,
            &[
                (0, sampler, &frames),
                (1, sampler, &wide),
                (2, vk::DescriptorType::STORAGE_IMAGE, &storage),
            ],
        );
        let colour = vk::ImageAspectFlags::COLOR;
        let outputs = targets
            .sets
            .iter()
            .filter_map(|s| s.filled.as_ref().map(|f| &f.0));
        // With inset-taa its pass has made the wide views readable.
        let wide_sets = match self.taa {
            Some(_) => &[][..],
            None => &self.wide.sets[..],
        };
        self.before = targets
            .sets
            .iter()
            .chain(wide_sets)
            .map(|s| {
                let r = &s.resolve;
                barrier::image(
                    r.image,
                    colour,
                    r.layers,
                    Use::COLOR_ATTACHMENT,
                    Use::COMPUTE_SAMPLED,
                )
            })
            .collect();
        self.before.extend(outputs.clone().map(|o| {
            barrier::image(
                o.image,
                colour,
                o.layers,
                Use::COLOR_ATTACHMENT.discarded(),
                Use::COMPUTE_STORAGE,
            )
        }));
        self.after = outputs
            .map(|o| {
                barrier::image(
                    o.image,
                    colour,
                    o.layers,
                    Use::COMPUTE_STORAGE,
                    Use::COLOR_ATTACHMENT,
                )
            })
            .collect();
        Ok(())
    }

    /// With `inset-taa`, starts a frame whose eyes are `views` (eyes of
    /// `extent`, `near` the projection's near plane): see
    /// [`InsetTaa::begin_frame`]. Nothing without it.
    pub fn begin_frame(&mut self, views: [crate::view::View; 2], near: f64, extent: vk::Extent2D) {
        let size = self.wide_extent(extent);
        if let Some(t) = self.taa.as_mut() {
            t.begin_frame(views, near, size);
        }
    }

    /// This frame's sub-pixel offset of the wide views' viewport
    /// (`inset-taa`'s jitter; zero without it).
    pub fn jitter(&self) -> [f32; 2] {
        self.taa.as_ref().map_or([0.0; 2], InsetTaa::jitter)
    }

    /// Draws the following wide views at `factor` × F (clamped to (0, 1]:
    /// the targets hold F × the largest eye; a factor that is not a
    /// positive number is taken as 1).
    pub fn set_wide_factor(&mut self, factor: f64) {
        self.factor = if factor > 0.0 { factor.min(1.0) } else { 1.0 };
    }

    /// Draws the following frames' wide views at one sample into their
    /// resolve images (`aq`'s MSAA rung), or again at the targets' samples;
    /// ignored where the targets were not made for it.
    pub fn set_one_sample(&mut self, one: bool) {
        self.one_sample = one && self.has_msaa_rung();
    }

    /// Whether the wide targets can also be drawn at one sample (`aq`'s
    /// MSAA rung).
    pub fn has_msaa_rung(&self) -> bool {
        self.wide.sets.iter().all(|s| s.depth_one_sample.is_some()) && !self.wide.sets.is_empty()
    }

    /// The views the wide scope of `eye` draws into this frame, and whether
    /// they have one sample (`inset-wide-1x`'s targets, or the MSAA rung
    /// this frame): over frame MSAA, the pipelines' one-sample twins draw
    /// them.
    pub fn wide_views(&self, eye: u32) -> (crate::render::attachments::TargetViews, bool) {
        let set = &self.wide.sets[eye as usize % self.wide.sets.len()];
        match set.views_one_sample().filter(|_| self.one_sample) {
            Some(v) => (v, true),
            None => (set.views(), set.color_msaa.is_none()),
        }
    }

    /// The wide view's size for eyes of `extent` (F × the factor ×
    /// `extent`, within the targets: with `aq` the eyes are drawn smaller
    /// than allocated, and on its inset rung the wide view smaller still).
    pub fn wide_extent(&self, extent: vk::Extent2D) -> vk::Extent2D {
        let e = crate::render::scaled(extent, self.scale * self.factor);
        vk::Extent2D {
            width: e.width.min(self.wide.extent.width),
            height: e.height.min(self.wide.extent.height),
        }
    }

    /// Where the wide view's pixels lie in its frame this frame, for eyes
    /// of `extent`: with four views its region of the eye-sized layer
    /// around `rect` ([`crate::view::inset::wide_region`]), else the top
    /// left of the wide image ([`InsetPass::wide_extent`]).
    pub fn wide_region(&self, rect: &PixelRect, extent: vk::Extent2D) -> PixelRect {
        let w = self.wide_extent(extent);
        let size = (w.width, w.height);
        if self.four_view {
            crate::view::inset::wide_region(rect, extent.width, extent.height, size)
        } else {
            PixelRect {
                x0: 0,
                y0: 0,
                x1: size.0,
                y1: size.1,
            }
        }
    }

    /// After both views of every set: their resolved frames are made
    /// readable, each set's output image is written from them by the
    /// compute shader over `extent` (the wide view read from `region` of
    /// its frame, see [`InsetPass::wide_region`]), and handed on as a
    /// written colour attachment (what the output copy and read-back
    /// expect).
    pub fn record_composite(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &Attachments,
        extent: vk::Extent2D,
        (rect, region): (PixelRect, PixelRect),
    ) {
        let lo = rect.x0 | rect.y0 << 16;
        let hi = rect.x1 | rect.y1 << 16;
        let feather = crate::view::inset::FEATHER_PX.to_bits();
        let eye_size = extent.width | extent.height << 16;
        // With inset-taau the wide view is the eye-sized history.
        let upsampled = self.taa.as_ref().is_some_and(InsetTaa::upsamples);
        let (wide_lo, wide_size) = match upsampled {
            true => (0, eye_size),
            false => (
                region.x0 | region.y0 << 16,
                region.width() | region.height() << 16,
            ),
        };
        let filter = match (upsampled, self.catmull_rom) {
            (true, _) => 2,
            (false, c) => u32::from(c),
        };
        let sharpen = if upsampled { self.sharpen } else { 0.0 }.to_bits();
        let wide_layer = match (&self.taa, self.four_view) {
            (Some(t), _) => t.history_layer(),
            (None, true) => 2,
            (None, false) => 0,
        };
        if let Some(t) = &self.taa {
            t.record(rec, q);
        }
        q.begin_pass(rec.ctx, rec.cmd, "inset-composite");
        rec.barriers(&self.before);
        rec.bind_compute(self.composite, &self.sets);
        for (i, set) in targets.sets.iter().enumerate() {
            let Some((out, _)) = &set.filled else {
                continue;
            };
            let push = [
                lo, hi, feather, i as u32, wide_lo, wide_size, wide_layer, eye_size, filter,
                sharpen,
            ];
            let groups = [
                extent.width.div_ceil(8),
                extent.height.div_ceil(8),
                out.layers,
            ];
            rec.dispatch(self.sets.layout, &push, groups);
        }
        rec.barriers(&self.after);
        q.end_pass(rec.ctx, rec.cmd);
    }

    /// Destroys the targets, pipeline and set; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: the device is idle; the pipeline belongs to `self`.
        unsafe { ctx.device.destroy_pipeline(self.composite, None) };
        self.sets.destroy(ctx);
        if let Some(t) = self.taa {
            t.destroy(ctx);
        }
        self.wide.destroy(ctx);
    }
}
