//! The sky after the MSAA resolve (`resolved-sky`). With 4× MSAA the
//! procedural sky, a full-screen triangle at the far plane, is depth-tested
//! at every sample of every pixel of the forward scope; on a GPU bound by
//! its raster back end that costs as much as a full-screen layer of
//! geometry (the H200's "one full-screen triangle" floor). Instead the
//! forward scope clears colour to transparent black (alpha 0), every
//! opaque, masked, point and overlay fragment writes alpha 1 and blended
//! ones accumulate coverage ("over" with alpha `a + (1 − a)·dst.a`,
//! [`crate::gpu::pipeline::Blend::Over`]), and after the resolve one
//! single-sample full-screen pass draws the sky *under* the image
//! ([`crate::gpu::pipeline::Blend::Under`]): `rgb + (1 − a)·sky`.
//!
//! Why this is the same image. Let a pixel's N samples hold premultiplied
//! (c_i, a_i), where a_i = 0 and c_i = 0 at samples nothing covered. The
//! reference composites the sky s (constant over the pixel: the sky's
//! fragment shader runs once per pixel at its centre, without sample
//! shading) under each sample and averages: (1/N)·Σ (c_i + (1 − a_i)·s).
//! The resolve averages first: (C, A) = (1/N)·Σ (c_i, a_i), and
//! C + (1 − A)·s is the same sum (Porter and Duff, "Compositing Digital
//! Images", SIGGRAPH 1984: "under" is "over" with the operands swapped,
//! and both are linear in the premultiplied pixel). A blended fragment
//! drawn over an uncovered sample in the reference sees the sky behind it;
//! here it sees (0, 0) and leaves alpha a, so the sky added later is
//! weighted by (1 − a): again the same sum. What differs is rounding: the
//! resolved colour is stored in 8-bit sRGB before the sky is added, so a
//! pixel can differ by one code value.
//!
//! The stencil mask marks its hidden area covered (it writes alpha 1 there,
//! colour untouched), so the area stays black as with the sky in the scope.

use super::technique::{self, AfterResolve, FrameHook, Technique};
use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::pipeline::{Blend, GraphicsPipelineDesc};
use crate::gpu::query::Queries;
use crate::gpu::rendering::Load;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::{self, AttachmentSet};
use crate::render::plan::PlanInput;
use ash::vk;

/// The forward scope's colour clear with `resolved-sky`: transparent black,
/// so the resolved alpha is each pixel's coverage.
pub const CLEAR: [f32; 4] = [0.0, 0.0, 0.0, 0.0];

/// The sky drawn under the resolved forward image.
pub struct ResolvedSky {
    pipeline: vk::Pipeline,
}

impl ResolvedSky {
    /// Builds the single-sample sky pipeline that blends under.
    pub fn new(setup: &PipelineSetup) -> Result<ResolvedSky> {
        let (full, sky) = (shaders::FULLSCREEN_VERT.words(), shaders::SKY_FRAG.words());
        let desc = GraphicsPipelineDesc {
            blend: Blend::Under,
            ..setup.composed_desc("resolved sky", &full, &sky)
        };
        Ok(ResolvedSky {
            pipeline: desc.build(setup.ctx)?,
        })
    }

    /// After every forward scope: waits for their resolves, then draws the
    /// sky under each set's resolved image (`view_mask`: both eyes in one
    /// scope under multiview; one set per eye in two-pass) — the eyes'
    /// `targets` of `extent`, and with the inset its wide views' too (the
    /// sky is a function of each pixel's direction, so the wide views get
    /// the same sky at their resolution; `jitter`: the viewport offset the
    /// views were drawn with, `inset-taa`'s for the wide views, so each
    /// pixel gets the sky of the direction its scope drew). Returns the
    /// draw calls.
    pub fn record(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &[AttachmentSet],
        area: (vk::Extent2D, u32, [f32; 2]),
    ) -> u64 {
        self.record_into(rec, q, targets, area, |set| Some(set.resolve.view))
    }

    /// [`ResolvedSky::record`] under the composed output images of
    /// `targets` (lens-matched shading's resample writes them): the
    /// resample's bilinear reads keep premultiplied colour and coverage,
    /// which "under" is linear in, so the sky fills what the scene left
    /// uncovered at the eye image's resolution.
    pub fn record_composed(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &[AttachmentSet],
        extent: vk::Extent2D,
        view_mask: u32,
    ) -> u64 {
        let area = (extent, view_mask, [0.0; 2]);
        self.record_into(rec, q, targets, area, |set| {
            set.filled.as_ref().map(|(composed, _)| composed.view)
        })
    }

    /// The sky under the image `target` picks of each set.
    fn record_into(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &[AttachmentSet],
        area: (vk::Extent2D, u32, [f32; 2]),
        target: impl Fn(&AttachmentSet) -> Option<vk::ImageView>,
    ) -> u64 {
        rec.memory_barriers(&[attachments::between_scopes()]);
        super::record_per_set(
            rec,
            q,
            "sky-resolved",
            targets,
            area,
            (self.pipeline, Load::Keep),
            target,
            |eye| [0, eye, 0, 0],
        )
    }

    /// Destroys the pipeline; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.pipeline]);
    }
}

/// Builds the pass with `resolved-sky`.
pub fn build(b: &technique::Build) -> Result<Option<Box<dyn Technique>>> {
    if !b.config.effort.resolved_sky {
        return Ok(None);
    }
    Ok(Some(Box::new(ResolvedSky::new(b.setup)?)))
}

impl Technique for ResolvedSky {
    fn name(&self) -> &'static str {
        "resolved-sky"
    }

    fn plan(&self, input: &mut PlanInput) {
        input.resolved_sky = true;
    }

    /// Under the resolved wide views and eye images; with LMS under the
    /// resample's output instead.
    fn after_resolve(&self, f: &FrameHook, q: &mut Queries, when: AfterResolve) -> u64 {
        let under = if f.lms.is_some() {
            AfterResolve::Resampled
        } else {
            AfterResolve::Resolved
        };
        if f.floor || when != under {
            return 0;
        }
        let wide = f.inset.map_or(0, |i| {
            let jitter = if f.quad { [0.0; 2] } else { i.jitter() };
            let area = (i.wide_extent(f.extent), f.view_mask, jitter);
            self.record(f.rec, q, &i.wide.sets, area)
        });
        let sets = &f.targets.sets;
        wide + match f.lms {
            Some(_) => self.record_composed(f.rec, q, sets, f.extent, f.view_mask),
            None => self.record(f.rec, q, sets, (f.extent, f.view_mask, [0.0; 2])),
        }
    }

    fn destroy(self: Box<Self>, ctx: &Context) {
        ResolvedSky::destroy(*self, ctx);
    }
}
