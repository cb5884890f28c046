//! Lens-matched shading (`lms`, `lms=K`, `lms-emulated`; the geometry and
//! its derivation in [`crate::view::lms`]): each view set is drawn into its
//! own smaller LMS targets (`forward-lms`), once per quadrant of the eye
//! image with that quadrant's viewport, scissor and clip-space w scaling;
//! after the scopes `lms-resample` writes each set's composed output image
//! (the rectilinear eye image) from the LMS resolve.
//!
//! Two paths scale w. Where the device offers VK_NV_clip_space_w_scaling
//! (the native path), the pipelines take the coefficients as dynamic state
//! and the rasterizer applies them after clipping. Elsewhere, or with
//! `lms-emulated`, the vertex shaders apply the same map to gl_Position
//! before clipping (`lms_scaled` in `shaders/common.glsl`); the two differ
//! only where geometry crosses the near plane at the image's periphery.
//! Culling tests each eye once; every quadrant draws the eye's visible
//! list, so vertex work is four times the plain frame's.

use super::sampled::SampledSets;
use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::view::lms::{quadrant_scaling, Coefficients, Layout};
use ash::vk;

/// What `stats.json` and bench results say of lens-matched shading.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LmsReport {
    /// Which path scaled w: "nv-clip-space-w-scaling", or "vertex-shader"
    /// with why (not offered, or `lms-emulated`).
    pub path: String,
    /// The side coefficients in use.
    pub coefficients: Coefficients,
    /// The LMS image's size per eye (width, height).
    pub size: [u32; 2],
    /// The share of the eye image's pixels the LMS image has.
    pub pixel_fraction: f64,
}

/// The LMS targets, the resample pipeline and the path.
pub struct LmsPass {
    /// The LMS attachment sets (as the eye's), resolved images sampled.
    pub targets: SampledSets,
    coefficients: Coefficients,
    layout: Layout,
    resample: vk::Pipeline,
    /// The extension's command, on the native path.
    native: Option<ash::nv::clip_space_w_scaling::Device>,
    /// What the report says of the path.
    path: String,
}

impl LmsPass {
    /// The LMS targets for eyes of `extent` (`samples` per pixel) and the
    /// resample; the native path when `setup.w_scaling`; `path` as the
    /// report says it; with `rdm` the resolved LMS images are changed in
    /// place by RDM's fill (storage use). On failure, destroys what it
    /// made.
    pub fn new(
        setup: &PipelineSetup,
        extent: vk::Extent2D,
        samples: u32,
        multiview: bool,
        coefficients: Coefficients,
        (path, rdm): (String, bool),
    ) -> Result<LmsPass> {
        let ctx = setup.ctx;
        let layout = Layout::new(&coefficients, [extent.width, extent.height]);
        let size = vk::Extent2D {
            width: layout.size[0],
            height: layout.size[1],
        };
        let targets = SampledSets::new(
            ctx,
            size,
            &super::sampled::SampledOptions {
                samples,
                storage_resolve: rdm,
                ..Default::default()
            },
            multiview,
            setup.depth_format,
            "LMS resample",
        )?;
        let (vs, fs) = (
            shaders::FLOOR_VERT.words(),
            shaders::LMS_RESAMPLE_FRAG.words(),
        );
        let desc = setup.composed_desc("LMS resample", &vs, &fs);
        let resample = match desc.build(ctx) {
            Ok(p) => p,
            Err(e) => {
                targets.destroy(ctx);
                return Err(e);
            }
        };
        let native = setup
            .w_scaling
            .then(|| ash::nv::clip_space_w_scaling::Device::new(&ctx.instance, &ctx.device));
        Ok(LmsPass {
            targets,
            coefficients,
            layout,
            resample,
            native,
            path,
        })
    }

    /// Draws the following frames' eyes at `eye` (`aq`'s scale, at most
    /// the size the targets were made for): the LMS image is laid out for
    /// it in the top-left part of the LMS targets, and the resample reads
    /// that part.
    pub fn set_eye_size(&mut self, eye: vk::Extent2D) {
        self.layout = Layout::new(&self.coefficients, [eye.width, eye.height]);
    }

    /// The LMS image's size this frame (the part of the targets drawn).
    pub fn size(&self) -> vk::Extent2D {
        vk::Extent2D {
            width: self.layout.size[0],
            height: self.layout.size[1],
        }
    }

    /// Where the LMS image lies and the side coefficients it is drawn
    /// with.
    pub fn geometry(&self) -> (&Layout, &Coefficients) {
        (&self.layout, &self.coefficients)
    }

    /// The report of this pass.
    pub fn report(&self) -> LmsReport {
        LmsReport {
            path: self.path.clone(),
            coefficients: self.coefficients,
            size: self.layout.size,
            pixel_fraction: self.layout.pixel_fraction(),
        }
    }

    /// What the resample samples (binding 7): the LMS resolves.
    pub fn images(&self) -> Option<[vk::DescriptorImageInfo; 2]> {
        self.targets.infos()
    }

    /// Inside an LMS scope: the following draws go to quadrant `q` (bit 0
    /// the right half, bit 1 the bottom half) — its viewport, scissor and
    /// w scaling — or, with None, to the whole image unscaled (the raster
    /// floors).
    pub fn set_quadrant(&self, rec: &Recorder, q: Option<u32>) {
        let d = &rec.ctx.device;
        let (viewport, scissor, scale) = match q {
            Some(q) => {
                let [x, y, w, h] = self.layout.viewport();
                let [sx, sy, sw, sh] = self.layout.scissor(q);
                (
                    vk::Viewport {
                        x: x as f32,
                        y: y as f32,
                        width: w as f32,
                        height: h as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    },
                    vk::Rect2D {
                        offset: vk::Offset2D {
                            x: sx as i32,
                            y: sy as i32,
                        },
                        extent: vk::Extent2D {
                            width: sw,
                            height: sh,
                        },
                    },
                    quadrant_scaling(&self.coefficients, q),
                )
            }
            None => {
                let (viewport, scissor) = super::whole(self.targets.extent);
                (viewport, scissor, [0.0, 0.0])
            }
        };
        // SAFETY: recording inside a rendering scope of the LMS targets;
        // the viewport lies within the device's bounds (its width and
        // height are the eye image's) and the scissor inside the render
        // area.
        unsafe {
            d.cmd_set_viewport(rec.cmd, 0, &[viewport]);
            d.cmd_set_scissor(rec.cmd, 0, &[scissor]);
        }
        match &self.native {
            Some(nv) => {
                let w = [vk::ViewportWScalingNV {
                    xcoeff: scale[0],
                    ycoeff: scale[1],
                }];
                // SAFETY: the extension is enabled (`native` exists only
                // then) and the scope's pipelines take the scaling as
                // dynamic state for viewport 0.
                unsafe { (nv.fp().cmd_set_viewport_w_scaling_nv)(rec.cmd, 0, 1, w.as_ptr()) };
                rec.lms.set(q.map(|q| (q, [0.0, 0.0])));
            }
            None => rec.lms.set(q.map(|q| (q, scale))),
        }
    }

    /// After every LMS scope: the LMS resolves are made readable and each
    /// set's output image is resampled from them over `extent`. Returns
    /// the draw calls.
    pub fn record_resample(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &Attachments,
        extent: vk::Extent2D,
        view_mask: u32,
    ) -> u64 {
        rec.lms.set(None);
        let [lr, ud] = self.coefficients.packed();
        let eye = self.layout.eye[0] | self.layout.eye[1] << 16;
        // The centre beside the set (images are at most 16,384 pixels a
        // side, so the centre fits 15 bits).
        let [cx, cy] = self.layout.centre;
        let at = (cx & 0x7fff) << 1 | cy << 16;
        super::record_composed(
            rec,
            q,
            "lms-resample",
            targets,
            self.targets.sets.iter(),
            (extent, view_mask),
            self.resample,
            |set| [lr, set | at, ud, eye],
        )
    }

    /// Destroys the targets and pipeline; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.resample]);
        self.targets.destroy(ctx);
    }
}
