//! Techniques as hooks: a technique that adds work to the frame without
//! reshaping its scopes (the stencil mask, the sky after the resolve,
//! RDM, the point cloud) implements [`Technique`], and the renderer keeps
//! the ones the configuration asks for in a list
//! ([`super::Passes::techniques`]) that it iterates at each point of the
//! frame: per-slot data before recording, work before the scopes, draws
//! inside each scope, work after the resolve, the frame's stats and the
//! report. A new one lives in its own file plus one line in [`REGISTRY`]
//! (and, where the plan must change for it, a flag in
//! [`crate::render::plan::PlanInput`] that its `plan` hook sets).
//!
//! Techniques that shape the scopes themselves (the inset, lens-matched
//! shading, the far field, occlusion) extend the frame plan
//! ([`crate::render::plan`]) instead; a hooked technique tells the plan
//! what it needs through [`Technique::plan`].

use super::inset::InsetPass;
use super::inset_wide::WidePipelines;
use super::lms::LmsPass;
use super::{PipelineSetup, Recorder};
use crate::config::RenderConfig;
use crate::error::Result;
use crate::gpu::memory::Buffer;
use crate::gpu::query::Queries;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::render::descriptors::SetContents;
use crate::render::plan::PlanInput;
use crate::render::report::RendererReport;
use crate::render::FrameStats;
use crate::scene::points::PointCloud;
use crate::view::StereoRig;
use ash::vk;

/// What a technique is built from.
pub struct Build<'a> {
    /// The pipelines' shared description.
    pub setup: &'a PipelineSetup<'a>,
    /// The configuration.
    pub config: &'a RenderConfig,
    /// The eye images' size.
    pub extent: vk::Extent2D,
    /// Frame slots.
    pub slots: usize,
    /// The inset's pass, built before the hooked techniques.
    pub inset: Option<&'a InsetPass>,
    /// Lens-matched shading's pass, built before the hooked techniques.
    pub lms: Option<&'a LmsPass>,
    /// The scene's point cloud and the frame slots' uniform buffers.
    pub points: Option<(&'a PointCloud, &'a [&'a Buffer])>,
}

/// Builds a technique when the configuration (and the scene) asks for it.
pub type Builder = fn(&Build) -> Result<Option<Box<dyn Technique>>>;

/// Every hooked technique, in the order their hooks run: inside a scope
/// the stencil mask is drawn before RDM's checkerboard and the points'
/// composite; after the resolve the sky goes in before RDM's fill.
pub const REGISTRY: &[Builder] = &[
    super::stencil_mask::build,
    super::resolved_sky::build,
    super::rdm::build,
    super::points::build,
];

/// Builds the registered techniques `b` asks for, in [`REGISTRY`]'s
/// order; on failure destroys those already built.
pub fn build_all(b: &Build) -> Result<Vec<Box<dyn Technique>>> {
    let mut built: Vec<Box<dyn Technique>> = Vec::new();
    for make in REGISTRY {
        match make(b) {
            Ok(Some(t)) => built.push(t),
            Ok(None) => {}
            Err(e) => {
                for t in built {
                    t.destroy(b.setup.ctx);
                }
                return Err(e);
            }
        }
    }
    Ok(built)
}

/// What a technique's per-slot preparation sees.
pub struct Prepare<'a> {
    /// The frame slot being prepared (free: the GPU is done with it).
    pub slot: usize,
    /// This frame's views.
    pub rig: &'a StereoRig,
    /// The configuration.
    pub config: &'a RenderConfig,
}

/// Where after the scopes a hook's work goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AfterResolve {
    /// Right after the scopes' resolve, into the images they drew.
    Resolved,
    /// After lens-matched shading's resample, into the eye images.
    Resampled,
}

/// What the hooks outside the scopes see of the frame being recorded.
pub struct FrameHook<'a> {
    /// The frame's recorder.
    pub rec: &'a Recorder<'a>,
    /// The frame slot.
    pub slot: usize,
    /// The eye images' size this frame.
    pub extent: vk::Extent2D,
    /// The forward views' multiview mask.
    pub view_mask: u32,
    /// The eye images.
    pub targets: &'a Attachments,
    /// The inset's pass (its wide views), when on.
    pub inset: Option<&'a InsetPass>,
    /// Lens-matched shading's pass, when on.
    pub lms: Option<&'a LmsPass>,
    /// The output takes the inset's four views as drawn (no jitter).
    pub quad: bool,
    /// A floor frame: no scene, points or sky.
    pub floor: bool,
}

/// What the hooks inside a scope see of it.
pub struct ScopeHook<'a> {
    /// The scope's recorder.
    pub rec: &'a Recorder<'a>,
    /// The frame slot.
    pub slot: usize,
    /// The eye (two-pass) or 0 (multiview).
    pub eye: u32,
    /// The scope's viewport size.
    pub extent: vk::Extent2D,
    /// RDM's checkerboard belongs in this scope.
    pub checkerboard: bool,
    /// Draws are repeated per LMS quadrant through `lms` (1: once).
    pub quadrants: u32,
    /// Lens-matched shading's pass, when the scope is an LMS one.
    pub lms: Option<&'a LmsPass>,
    /// The wide view's one-sample pipeline twins, when the scope uses them.
    pub twins: Option<&'a WidePipelines>,
    /// A floor frame: no scene or points.
    pub floor: bool,
}

/// A technique's hooks into the frame; every one but `name` and
/// `destroy` does nothing unless the technique has work there.
pub trait Technique: Send + Sync {
    /// Its `--opt` name.
    fn name(&self) -> &'static str;

    /// Tells the frame plan what it needs (its flags in `input`).
    fn plan(&self, _input: &mut PlanInput) {}

    /// Writes this frame's per-slot data before the frame is recorded;
    /// what it chose goes into `stats`.
    fn prepare(&mut self, _p: &Prepare, _stats: &mut FrameStats) -> Result<()> {
        Ok(())
    }

    /// Points the slot's descriptor set at its resources.
    fn bind(&self, _slot: usize, _targets: Option<&Attachments>, _set: &mut SetContents) {}

    /// Compute work before the frame's scopes.
    fn before_scopes(&self, _f: &FrameHook, _q: &mut Queries) {}

    /// Draws inside a scope before its draw list; returns the draw calls.
    fn in_scope(&self, _s: &ScopeHook) -> u64 {
        0
    }

    /// Work after the scopes at `when`; returns the draw calls.
    fn after_resolve(&self, _f: &FrameHook, _q: &mut Queries, _when: AfterResolve) -> u64 {
        0
    }

    /// Reads back what the GPU counted for frame slot `slot` into `stats`
    /// once the slot's frame completed.
    fn collect(&mut self, _slot: usize, _stats: &mut FrameStats) -> Result<()> {
        Ok(())
    }

    /// Its part of the renderer's report.
    fn report(&self, _r: &mut RendererReport) {}

    /// Destroys its Vulkan objects; the device must be idle.
    fn destroy(self: Box<Self>, ctx: &Context);
}
