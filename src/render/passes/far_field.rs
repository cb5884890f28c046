//! Monoscopic far-field rendering (`mffr`, `mffr=D`), after Oculus' hybrid
//! mono rendering (the split distance and the centre camera are derived in
//! `view::mffr`): beyond the split distance D the far field is rendered
//! once, from the centre camera with its near plane at D, into its own
//! target ([`FAR_WIDTH_SCALE`] × an eye's width, same MSAA), timed as
//! `mffr-far`. Each eye's forward scope clears depth to the split plane
//! (reverse-Z: `near / D`), so only nearer geometry passes, and a
//! full-screen composite (`shaders/mffr_composite.frag`) looks up every
//! pixel's ray in the far image (`mffr-depth-shift`: the ray's point at D).
//! The sky lies beyond the split, so only the far pass draws it (with
//! `resolved-sky` none does: the eyes' sky after the resolve fills what the
//! composite and the near field leave uncovered).
//!
//! `mffr-alternate-eye` keeps one far image per eye, each re-rendered from
//! its eye (with the centre camera's orientation and union FOV) every other
//! frame, both on the first.
//!
//! The depth split: an instance's bounding sphere (centre c, radius r) feeds
//! the near passes when its nearest depth in some eye, `(c − p)·f − r`, is
//! before D, and the far pass when its farthest depth from some far camera,
//! `(c − p)·f + r`, is beyond D (p a camera's position, f its forward
//! axis); margins of `1e-3 · D + 1e-3` cover f32 rounding. An instance left
//! out of a pass would have been clipped or depth-rejected there, so the
//! split changes no pixel.

use super::gpu_cull::GpuCull;
use super::{
    destroy_pipelines, to_sampled, PipelineSetup, Recorder, ScenePipelines, Scope, ScopePart,
};
use crate::config::Mffr;
use crate::cull::gpu::FarSplitAxes;
use crate::error::{Result, VkContext};
use crate::gpu::pipeline::GraphicsPipelineDesc;
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::{self, AttachmentSet, SetOptions};
use crate::render::batches::{Batcher, Batches, PipelineKey};
use crate::view::{mffr, Pose, StereoRig, View};
use ash::vk;
use std::collections::HashMap;

/// Far-field image width relative to an eye's: the centre camera's union
/// FOV is wider than one eye's by the other eye's extra coverage.
pub const FAR_WIDTH_SCALE: f64 = 1.25;

/// The far image's size for eyes of `eye` pixels: [`FAR_WIDTH_SCALE`]
/// times as wide, as tall.
fn far_size(eye: vk::Extent2D) -> vk::Extent2D {
    vk::Extent2D {
        width: ((eye.width as f64 * FAR_WIDTH_SCALE).ceil() as u32).min(16384),
        height: eye.height,
    }
}

/// This frame's far field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FarFrame {
    /// Split distance in metres.
    pub split: f64,
    /// Which of the (up to two) far images are rendered this frame.
    pub render: [bool; 2],
}

/// The far field's targets, pipelines (no view mask), composite, and its
/// plan for the current frame.
pub struct FarField {
    settings: Mffr,
    /// One far image, or one per eye (alternate eye).
    sets: Vec<AttachmentSet>,
    /// The far images' size (for the largest eye size).
    extent: vk::Extent2D,
    /// The part of them drawn for this frame's eye size (with `aq`, the
    /// top-left part the eye size at the current scale gives).
    drawn: vk::Extent2D,
    pipelines: ScenePipelines,
    sky: vk::Pipeline,
    /// With `resolved-sky` the far scopes draw no sky and leave the
    /// uncovered pixels transparent: the eyes' sky after the resolve goes
    /// under the composite too.
    resolved_sky: bool,
    composite: vk::Pipeline,
    sampler: vk::Sampler,
    /// This frame's plan (None: fell back to stereo).
    frame: Option<FarFrame>,
    /// The view each far image was (or is being) rendered from (uniform
    /// views 2 and 3).
    views: [Option<View>; 2],
}

impl FarField {
    /// Creates the far targets for eyes of `eye_extent` and the pipelines;
    /// with `resolved_sky` the far images get no sky: their uncovered
    /// pixels stay transparent through the composite (premultiplied colour
    /// and coverage, bilinearly read, which "under" is linear in), and the
    /// eyes' sky after the resolve fills them at the eyes' resolution.
    pub fn new(
        setup: &PipelineSetup,
        settings: Mffr,
        eye_extent: vk::Extent2D,
        resolved_sky: bool,
    ) -> Result<FarField> {
        let ctx = setup.ctx;
        let extent = far_size(eye_extent);
        let count = if settings.alternate_eye { 2 } else { 1 };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        // SAFETY: plain object creation; destroyed by `destroy`.
        let sampler = unsafe { ctx.device.create_sampler(&info, None) }
            .vk("creating the far-field sampler")?;
        let mut far = FarField {
            settings,
            sets: Vec::new(),
            extent,
            drawn: extent,
            pipelines: ScenePipelines::default(),
            sky: vk::Pipeline::null(),
            resolved_sky,
            composite: vk::Pipeline::null(),
            sampler,
            frame: None,
            views: [None, None],
        };
        if let Err(e) = far.build(setup, count) {
            far.destroy(ctx);
            return Err(e);
        }
        Ok(far)
    }

    /// Creates `count` far targets and the pipelines into `self`.
    fn build(&mut self, setup: &PipelineSetup, count: usize) -> Result<()> {
        let ctx = setup.ctx;
        for _ in 0..count {
            self.sets.push(AttachmentSet::new(
                ctx,
                self.extent,
                setup.samples,
                1,
                SetOptions {
                    depth_format: setup.depth_format,
                    keep_depth: false,
                    composed: false,
                    sampled: true,
                    storage_output: false,
                    storage_resolve: false,
                    occlusion: false,
                    multiview_layers: 2,
                    one_sample_depth: false,
                },
            )?);
        }
        let full = shaders::FULLSCREEN_VERT.words();
        let (sky, composite) = (
            shaders::SKY_FRAG.words(),
            shaders::MFFR_COMPOSITE_FRAG.words(),
        );
        self.pipelines = ScenePipelines::new(Self::scene_pipelines(setup, false)?);
        self.sky = GraphicsPipelineDesc {
            view_mask: 0,
            shading_rate_attachment: false,
            ..setup.fullscreen_desc("far-field sky", &full, &sky)
        }
        .build(ctx)?;
        self.composite = GraphicsPipelineDesc {
            depth_test: false,
            depth_write: false,
            ..setup.fullscreen_desc("far-field composite", &full, &composite)
        }
        .build(ctx)?;
        Ok(())
    }

    fn scene_pipelines(
        setup: &PipelineSetup,
        section: bool,
    ) -> Result<HashMap<PipelineKey, vk::Pipeline>> {
        let vertex = if section {
            &shaders::SCENE_CLIP_VERT
        } else {
            &shaders::SCENE_VERT
        };
        let (vs, fs) = (vertex.words(), shaders::SCENE_FRAG.words());
        setup.scene_pipelines(&GraphicsPipelineDesc {
            view_mask: 0,
            shading_rate_attachment: false,
            ..setup.scene_desc(&vs, &fs)
        })
    }

    /// Draws the following frames' far images at the size eyes of `eye`
    /// pixels give (`aq`'s render scale), in the top-left part of the
    /// images; the composite reads that part. With `mffr-alternate-eye`
    /// a change of size renders both far images again on the next frame
    /// (the one kept from the frame before has the old size).
    pub fn set_eye_size(&mut self, eye: vk::Extent2D) {
        let s = far_size(eye);
        let drawn = vk::Extent2D {
            width: s.width.min(self.extent.width),
            height: s.height.min(self.extent.height),
        };
        if drawn != self.drawn {
            self.views = [None, None];
        }
        self.drawn = drawn;
    }

    /// Builds the pipelines that clip against the section plane, unless
    /// they exist.
    pub fn ensure_clipped(&mut self, setup: &PipelineSetup) -> Result<()> {
        if !self.pipelines.has_clipped() {
            self.pipelines
                .set_clipped(Self::scene_pipelines(setup, true)?);
        }
        Ok(())
    }

    /// Plans frame `frame_index` of `rig` at `width` pixels per eye: the
    /// split distance (the configured one, else where disparity falls below
    /// a pixel) and the far camera(s). Returns false when there is no
    /// finite centre camera and the frame falls back to stereo.
    pub fn plan(&mut self, rig: &StereoRig, width: u32, frame_index: u64) -> bool {
        let split = self
            .settings
            .split
            .unwrap_or_else(|| mffr::auto_split(rig, width));
        self.frame = match mffr::centre_view(rig) {
            Some(centre) if self.settings.alternate_eye => {
                // Eye p's far image is re-rendered this frame (both on the
                // first); each from its eye, covering the centre camera's
                // union FOV.
                let p = (frame_index % 2) as usize;
                let mut render = [false; 2];
                for (i, v) in rig.views.iter().take(2).enumerate() {
                    if i == p || self.views[i].is_none() {
                        self.views[i] = Some(View {
                            pose: Pose {
                                position: v.pose.position,
                                orientation: centre.pose.orientation,
                            },
                            fov: centre.fov,
                        });
                        render[i] = true;
                    }
                }
                Some(FarFrame { split, render })
            }
            Some(centre) => {
                self.views = [Some(centre), None];
                Some(FarFrame {
                    split,
                    render: [true, false],
                })
            }
            None => {
                self.views = [None, None];
                None
            }
        };
        self.frame.is_some()
    }

    /// Builds this frame's batches of `visible` (None: all): split by depth
    /// (near draws first, then `far_start`) when the frame has a far field
    /// and `partition` is on, else every instance once for both.
    pub fn build_batches(
        &self,
        batcher: &mut Batcher,
        rig: &StereoRig,
        visible: Option<&[u32]>,
        partition: bool,
        batches: &mut Batches,
    ) {
        let Some(axes) = self.split_axes(rig).filter(|_| partition) else {
            batcher.build(visible, rig.head.position, batches);
            return;
        };
        batcher.build_split(
            visible,
            rig.head.position,
            |c, r| axes.near(c, r),
            |c, r| axes.far(c, r),
            batches,
        );
    }

    /// This frame's near/far test (None: no plan, the frame is stereo):
    /// the eyes' axes, the far cameras rendered this frame, the split and
    /// a margin of 1 mm + 0.1 % of it.
    pub fn split_axes(&self, rig: &StereoRig) -> Option<FarSplitAxes> {
        let frame = self.frame?;
        let d = frame.split;
        // Fixed-size: the frame allocates nothing (the renderer checked for
        // two views; at most two far cameras).
        let axis = |v: &View| (v.pose.position, v.pose.forward());
        let mut fars = [None; 2];
        for i in (0..2).filter(|&i| frame.render[i]) {
            fars[i] = self.views[i].as_ref().map(axis);
        }
        Some(FarSplitAxes {
            eyes: [axis(&rig.views[0]), axis(&rig.views[1])],
            fars,
            split: d,
            margin: 1e-3 * d + 1e-3,
        })
    }

    /// This frame's plan (None: fell back to stereo).
    pub fn frame(&self) -> Option<FarFrame> {
        self.frame
    }

    /// The far cameras for the frame uniforms (views 2 and 3) and their
    /// near plane: the split distance, or `near` without a plan.
    pub fn cameras(&self, near: f64) -> ([Option<View>; 2], f64) {
        (self.views, self.frame.map_or(near, |f| f.split))
    }

    /// The forward scopes' depth clear value with a far field: the split
    /// plane under reverse-Z (`near / D`), so only nearer geometry passes.
    pub fn depth_clear(&self, near: f64) -> f32 {
        self.frame.map_or(0.0, |f| (near / f.split).min(1.0) as f32)
    }

    /// The far images for the composite's descriptors (the second repeats
    /// the first without alternate eye).
    pub fn images(&self) -> [vk::DescriptorImageInfo; 2] {
        std::array::from_fn(|i| vk::DescriptorImageInfo {
            sampler: self.sampler,
            image_view: self.sets.get(i).unwrap_or(&self.sets[0]).resolve.view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        })
    }

    /// The far pass: `batches`' far draws rendered from each far camera due
    /// this frame (uniform view 2 + image, near plane at the split) into
    /// its target, which is then made readable for the composite. Returns
    /// the draw calls (none without a plan).
    pub fn record(&self, rec: &Recorder, q: &mut Queries, batches: &Batches) -> u64 {
        self.record_with(rec, q, |view| {
            let far = batches.far_draws();
            let base = batches.far_start.unwrap_or(0) as u32;
            let sky = self.in_scope_sky().map(|p| (p, rec.sky_slot(far)));
            rec.draw_batches(far, base, self.pipelines.get(rec.section), sky, view)
        })
    }

    /// [`FarField::record`] drawing what `gpu` culled into frame slot
    /// `slot`'s far set (`mffr` with `gpu-cull`).
    pub fn record_gpu(&self, rec: &Recorder, q: &mut Queries, gpu: &GpuCull, slot: usize) -> u64 {
        self.record_with(rec, q, |view| {
            let pipelines = self.pipelines.get(rec.section);
            gpu.record_draws(rec, pipelines, self.in_scope_sky(), view, slot, true)
        })
    }

    /// The far pass's scopes: one per far camera due this frame, into its
    /// target, with `draw(view)` recording the draws for uniform view
    /// `view`; each target is made readable for the composite after.
    fn record_with(&self, rec: &Recorder, q: &mut Queries, draw: impl Fn(u32) -> u64) -> u64 {
        let Some(frame) = self.frame else {
            return 0;
        };
        let mut draws = 0;
        q.begin_pass(rec.ctx, rec.cmd, "mffr-far");
        for i in (0..2).filter(|&i| frame.render[i]) {
            let set = &self.sets[i];
            rec.barriers(&attachments::begin_barriers(std::slice::from_ref(set)));
            rec.begin_scope(&Scope {
                sky_after_resolve: self.resolved_sky,
                colour_covered: false,
                part: ScopePart::Whole,
                views: set.views(),
                area: None,
                extent: self.drawn,
                view_mask: 0,
                depth_clear: 0.0,
                shading_rate: None,
                secondaries: false,
                jitter: [0.0; 2],
            });
            draws += draw(2 + i as u32);
            rec.end_scope();
            rec.barriers(&[to_sampled(&set.resolve)]);
        }
        q.end_pass(rec.ctx, rec.cmd);
        draws
    }

    /// The sky drawn inside the far scope: none with `resolved-sky`.
    fn in_scope_sky(&self) -> Option<vk::Pipeline> {
        (!self.resolved_sky).then_some(self.sky)
    }

    /// The composite of view `eye` inside the open forward scope: every
    /// pixel's ray looked up in the far image (see the module doc). Returns
    /// the draw calls.
    pub fn record_composite(&self, rec: &Recorder, eye: u32) -> u64 {
        let Some(frame) = self.frame else {
            return 0;
        };
        let flags = self.settings.depth_shift as u32 | (self.settings.alternate_eye as u32) << 1;
        // The drawn part (width | height << 16), 0 when it is the whole
        // image (both at most 16384).
        let drawn = match self.drawn == self.extent {
            true => 0,
            false => self.drawn.width | self.drawn.height << 16,
        };
        rec.bind(self.composite);
        rec.push([flags, eye, drawn, (frame.split as f32).to_bits()]);
        rec.draw(3);
        1
    }

    /// Destroys the targets, pipelines and sampler; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(
            ctx,
            self.pipelines.all().chain([&self.sky, &self.composite]),
        );
        // SAFETY: the device is idle; the sampler belongs to `self`.
        unsafe { ctx.device.destroy_sampler(self.sampler, None) };
        for set in self.sets {
            set.destroy(ctx);
        }
    }
}
