//! Radial density masking (`rdm`, `rdm=R`), after Vlachos, "Advanced VR
//! Rendering Performance" (GDC 2016): beyond NDC radius R, every other 2×2
//! pixel quad in a checkerboard is written to stencil bit 1 by a full-screen
//! pass at the start of each forward scope (`shaders/rdm.frag`), so every
//! later draw skips it (the scene tests both stencil bits). The quad at
//! pixel p of a W×H image is skipped when `((p.x >> 1) + (p.y >> 1))` is odd
//! and `|2 p / (W, H) − 1| ≥ R` (`rdm_skipped` in `shaders/common.glsl`).
//!
//! The fill (on unless `rdm-nofill`) runs after the scene, timed as
//! `rdm-fill`: each skipped quad takes the mean of the four quads around it
//! (2 pixels left, right, up, down; `shaders/rdm_fill.frag`), written with
//! the rendered pixels into a separate image that becomes the frame's
//! output.

use super::rdm_in_place::RdmInPlace;
use super::technique::{self, AfterResolve, FrameHook, ScopeHook, Technique};
use super::{destroy_pipelines, stencil_write, PipelineSetup, Recorder};
use crate::error::{Result, VkContext};
use crate::gpu::pipeline::GraphicsPipelineDesc;
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::render::descriptors::SetContents;
use crate::render::plan::PlanInput;
use ash::vk;

/// The reconstruction's pipeline and the sampler it reads the frame with.
struct Fill {
    pipeline: vk::Pipeline,
    sampler: vk::Sampler,
}

/// The checkerboard stencil pipeline, and the fill when it is on.
pub struct Rdm {
    radius: f32,
    mask: vk::Pipeline,
    fill: Option<Fill>,
    /// The fill in place, in the inset's wide views or LMS's image (which
    /// the later passes read) instead of into the eye images.
    in_place: Option<RdmInPlace>,
}

impl Rdm {
    /// Builds the checkerboard pipeline for NDC radius `radius` and, with
    /// `fill`, the reconstruction.
    pub fn new(setup: &PipelineSetup, radius: f32, fill: bool) -> Result<Rdm> {
        let ctx = setup.ctx;
        let vs = shaders::FLOOR_VERT.words();
        let (mask_fs, fill_fs) = (shaders::RDM_FRAG.words(), shaders::RDM_FILL_FRAG.words());
        let mask = GraphicsPipelineDesc {
            depth_test: false,
            depth_write: false,
            color_write: vk::ColorComponentFlags::empty(),
            stencil: Some(stencil_write(2)),
            ..setup.fullscreen_desc("rdm checkerboard stencil", &vs, &mask_fs)
        };
        let mut rdm = Rdm {
            radius,
            mask: mask.build(ctx)?,
            fill: None,
            in_place: None,
        };
        if fill {
            let info = vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE);
            // SAFETY: plain object creation; destroyed by `destroy`.
            let sampler = unsafe { ctx.device.create_sampler(&info, None) }
                .vk("creating the RDM fill sampler")?;
            let pipeline = setup.composed_desc("rdm fill", &vs, &fill_fs);
            rdm.fill = Some(Fill {
                pipeline: pipeline.build(ctx)?,
                sampler,
            });
        }
        Ok(rdm)
    }

    /// Draws the checkerboard of view `eye` into stencil inside the open
    /// scope (`extent` pixels per eye). Returns the draw calls.
    pub fn record(&self, rec: &Recorder, extent: vk::Extent2D, eye: u32) -> u64 {
        rec.bind(self.mask);
        let size = extent.width | extent.height << 16;
        rec.push([0, eye, size, self.radius.to_bits()]);
        rec.draw(3);
        1
    }

    /// What the fill samples: each attachment set's frame (the second
    /// repeats the first under multiview); None without the fill.
    pub fn filled_images(&self, targets: &Attachments) -> Option<[vk::DescriptorImageInfo; 2]> {
        let fill = self.fill.as_ref()?;
        let mut views = targets
            .sets
            .iter()
            .filter_map(|s| s.filled.as_ref().map(|f| f.1));
        let first = views.next()?;
        let info = |image_view| vk::DescriptorImageInfo {
            sampler: fill.sampler,
            image_view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        Some([info(first), info(views.next().unwrap_or(first))])
    }

    /// The reconstruction, after every forward scope: each set's resolved
    /// frame is made readable (all of them first: the fill shader indexes
    /// the array of both sets' frames) and written, with the skipped quads
    /// filled, into its `filled` image. Returns the draw calls (none
    /// without the fill).
    pub fn record_fill(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &Attachments,
        extent: vk::Extent2D,
        view_mask: u32,
    ) -> u64 {
        let Some(fill) = &self.fill else {
            return 0;
        };
        let radius = self.radius.to_bits();
        // The size drawn this frame (with aq less than the images'), packed
        // as for the checkerboard.
        let size = extent.width | extent.height << 16;
        super::record_composed(
            rec,
            q,
            "rdm-fill",
            targets,
            targets.sets.iter(),
            (extent, view_mask),
            fill.pipeline,
            |eye| [0, eye, size, radius],
        )
    }

    /// Destroys the pipelines and the sampler; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.mask]);
        if let Some(p) = self.in_place {
            p.destroy(ctx);
        }
        if let Some(fill) = self.fill {
            destroy_pipelines(ctx, [&fill.pipeline]);
            // SAFETY: the device is idle; the sampler belongs to `self`.
            unsafe { ctx.device.destroy_sampler(fill.sampler, None) };
        }
    }
}

/// Builds RDM with `rdm` (after the inset and LMS: with the fill, in their
/// images when they have them).
pub fn build(b: &technique::Build) -> Result<Option<Box<dyn Technique>>> {
    let Some(radius) = b.config.effort.rdm else {
        return Ok(None);
    };
    let mut rdm = Rdm::new(b.setup, radius, b.config.effort.rdm_fill)?;
    let sets = match (b.inset, b.lms) {
        (Some(i), _) => Some(&i.wide.sets),
        (_, Some(l)) => Some(&l.targets.sets),
        _ => None,
    };
    if let Some(sets) = sets.filter(|s| b.config.effort.rdm_fill && !s.is_empty()) {
        match RdmInPlace::new(b.setup.ctx, sets, radius) {
            Ok(p) => rdm.in_place = Some(p),
            Err(e) => {
                rdm.destroy(b.setup.ctx);
                return Err(e);
            }
        }
    }
    Ok(Some(Box::new(rdm)))
}

impl Technique for Rdm {
    fn name(&self) -> &'static str {
        "rdm"
    }

    fn plan(&self, input: &mut PlanInput) {
        input.rdm = true;
    }

    fn bind(&self, _: usize, targets: Option<&Attachments>, set: &mut SetContents) {
        set.filled = targets.and_then(|t| self.filled_images(t));
    }

    fn in_scope(&self, s: &ScopeHook) -> u64 {
        if !s.checkerboard {
            return 0;
        }
        self.record(s.rec, s.extent, s.eye)
    }

    /// The fill: in place in the images the later passes read (a
    /// dispatch, not a draw), else into the eye images' `filled` ones.
    fn after_resolve(&self, f: &FrameHook, q: &mut Queries, when: AfterResolve) -> u64 {
        if when != AfterResolve::Resolved {
            return 0;
        }
        match (&self.in_place, f.inset, f.lms) {
            (Some(fill), Some(inset), _) => {
                fill.record(f.rec, q, &inset.wide.sets, inset.wide_extent(f.extent));
                0
            }
            (Some(fill), None, Some(lms)) => {
                fill.record(f.rec, q, &lms.targets.sets, lms.size());
                0
            }
            _ => self.record_fill(f.rec, q, f.targets, f.extent, f.view_mask),
        }
    }

    fn destroy(self: Box<Self>, ctx: &Context) {
        Rdm::destroy(*self, ctx);
    }
}
