//! Recording a frame: `Renderer::record` computes the frame's plan
//! ([`super::plan`]) from what this renderer built and this frame's
//! geometry, then walks it, each step handed to the pass that does it.

use super::batches::Batches;
use super::passes::technique::{FrameHook, ScopeHook};
use super::passes::{Recorder, Scope};
use super::plan::{self, Draws, InsetInput, PlanInput, ScopePart, ScopeStep, Step, Target};
use super::{attachments, pixel_area, FloorKind, Renderer};
use crate::config::StereoMode;
use crate::gpu::query::Queries;
use ash::vk;

/// What one recording of a frame shares between its steps.
struct Frame<'a> {
    cmd: vk::CommandBuffer,
    rec: Recorder<'a>,
    batches: &'a Batches,
    floor: Option<FloorKind>,
}

impl Renderer {
    /// Records the frame's passes into `cmd` in GPU order (the plan's
    /// steps); returns the draw calls recorded. `floor`: a floor frame
    /// ([`Renderer::render_floor`]) draws that instead of the scene.
    pub(super) fn record(
        &self,
        cmd: vk::CommandBuffer,
        batches: &Batches,
        q: &mut Queries,
        floor: Option<FloorKind>,
    ) -> u64 {
        let steps = plan::frame(&self.plan_input(floor.is_some()));
        let f = Frame {
            cmd,
            rec: self.recorder(cmd),
            batches,
            floor,
        };
        steps.iter().map(|s| self.record_step(&f, q, s)).sum()
    }

    /// The plan's view of this renderer and frame.
    pub(super) fn plan_input(&self, floor: bool) -> PlanInput {
        let p = &self.passes;
        let inset = p.inset.as_ref().map(|i| InsetInput {
            rect: self.inset_rect,
            four_view_region: self.four_view_region(),
            wide_extent: size(i.wide_extent(self.extent)),
            wide_one_sample: [0, 1].map(|e| p.inset_wide.is_some() && i.wide_views(e).1),
            jitter: i.jitter(),
            quad: self.quad,
        });
        let mut input = PlanInput {
            two_pass: self.config.frame.stereo == StereoMode::TwoPass,
            extent: size(self.extent),
            floor,
            gpu_cull: p.gpu_cull.is_some(),
            occlusion: p.gpu_cull.as_ref().is_some_and(|g| g.occlusion()),
            gpu_inset_lists: p.gpu_cull.as_ref().is_some_and(|g| g.inset_lists()),
            points: false,
            points_compute: false,
            far: p.far.as_ref().is_some_and(|f| f.frame().is_some()),
            far_pass: p.far.is_some(),
            inset,
            lms: p.lms.as_ref().map(|l| size(l.size())),
            resolved_sky: false,
            rdm: false,
            stencil_mask: false,
            mask_in_depth: self.mask_in_depth,
            parallel: self.parallel.is_some(),
        };
        for t in &p.techniques {
            t.plan(&mut input);
        }
        input
    }

    /// What the hooks outside the scopes see of frame `f`.
    fn frame_hook<'a>(&'a self, f: &'a Frame) -> FrameHook<'a> {
        FrameHook {
            rec: &f.rec,
            slot: self.slot,
            extent: self.extent,
            view_mask: self.view_mask(),
            targets: self.targets(),
            inset: self.passes.inset.as_ref(),
            lms: self.passes.lms.as_ref(),
            quad: self.quad,
            floor: f.floor.is_some(),
        }
    }

    fn record_step(&self, f: &Frame, q: &mut Queries, step: &Step) -> u64 {
        let (ctx, cmd, p) = (&self.ctx, f.cmd, &self.passes);
        let targets = self.targets();
        let gpu = p.gpu_cull.as_ref();
        let far = p.far.as_ref().filter(|_| f.floor.is_none());
        match step {
            Step::GpuCull => {
                if let Some(g) = gpu {
                    g.record(ctx, cmd, q, self.slot);
                }
                0
            }
            Step::BeforeScopes => {
                let hook = self.frame_hook(f);
                for t in &p.techniques {
                    t.before_scopes(&hook, q);
                }
                0
            }
            Step::BeginBarriers => {
                f.rec.barriers(&targets.begin_barriers());
                if let Some(inset) = &p.inset {
                    f.rec
                        .barriers(&attachments::begin_barriers(&inset.wide.sets));
                }
                if let Some(lms) = &p.lms {
                    f.rec
                        .barriers(&attachments::begin_barriers(&lms.targets.sets));
                }
                0
            }
            Step::BeginStats => {
                q.begin_stats(ctx, cmd);
                0
            }
            Step::FarField => match (far, gpu) {
                (Some(far), Some(g)) => far.record_gpu(&f.rec, q, g, self.slot),
                (Some(far), None) => far.record(&f.rec, q, f.batches),
                _ => 0,
            },
            Step::LateCull => {
                if let Some(g) = gpu {
                    g.record_late(ctx, cmd, q, self.slot);
                    f.rec.memory_barriers(&[attachments::between_scopes()]);
                }
                0
            }
            Step::Scope(s) => self.record_scope(f, q, s),
            Step::AfterResolve(when) => {
                let hook = self.frame_hook(f);
                let hooks = p.techniques.iter();
                hooks.map(|t| t.after_resolve(&hook, q, *when)).sum()
            }
            Step::LmsResample => p.lms.as_ref().map_or(0, |l| {
                l.record_resample(&f.rec, q, targets, self.extent, self.view_mask())
            }),
            Step::InsetComposite => {
                // A dispatch per set, not a draw: not counted.
                if let Some(inset) = &p.inset {
                    inset.record_composite(
                        &f.rec,
                        q,
                        targets,
                        self.extent,
                        (self.inset_rect, self.wide_region),
                    );
                }
                0
            }
            Step::EndStats => {
                q.end_stats(ctx, cmd);
                0
            }
        }
    }

    /// The attachments a scope's target names.
    fn scope_views(&self, target: Target) -> super::attachments::TargetViews {
        let p = &self.passes;
        match (target, &p.inset, &p.lms) {
            (Target::Wide { eye }, Some(inset), _) => inset.wide_views(eye).0,
            (Target::Lms { eye }, _, Some(lms)) => {
                let sets = &lms.targets.sets;
                sets[eye as usize % sets.len()].views()
            }
            (Target::Eye { set }, ..) => self.targets().sets[set].views(),
            _ => self.targets().sets[0].views(),
        }
    }

    /// One rendering scope of the plan.
    fn record_scope(&self, f: &Frame, q: &mut Queries, s: &ScopeStep) -> u64 {
        let (ctx, cmd, p) = (&self.ctx, f.cmd, &self.passes);
        let far = p
            .far
            .as_ref()
            .filter(|fa| f.floor.is_none() && fa.frame().is_some());
        // With a monoscopic far field, the near field's depth starts at the
        // split plane (reverse-Z: near / D), so only geometry nearer than D
        // passes the depth test.
        let depth_clear = far.map_or(0.0, |fa| fa.depth_clear(self.config.frame.near));
        let twins = p.inset_wide.as_ref().filter(|_| s.one_sample_twins);
        q.begin_pass(ctx, cmd, s.name);
        f.rec.begin_scope(&Scope {
            part: s.part,
            views: self.scope_views(s.target),
            area: s.area.as_ref().map(pixel_area),
            extent: vk::Extent2D {
                width: s.extent[0],
                height: s.extent[1],
            },
            view_mask: s.view_mask,
            depth_clear,
            shading_rate: self.shading_rate.as_ref().and_then(|r| {
                let drawn = vk::Extent2D {
                    width: s.extent[0],
                    height: s.extent[1],
                };
                r.attachment(s.eye, drawn)
            }),
            secondaries: s.secondaries,
            sky_after_resolve: s.sky_after_resolve,
            colour_covered: s.colour_covered,
            jitter: s.jitter,
        });
        let draw_calls = match self.parallel.as_ref().filter(|_| s.secondaries) {
            Some(par) => {
                // SAFETY: inside a scope begun for secondary contents; the
                // secondaries were recorded for it this frame.
                unsafe {
                    ctx.device
                        .cmd_execute_commands(cmd, par.commands(self.slot, s.eye as usize))
                };
                0
            }
            None => self.scope_masks(f, s, twins) + self.scope_draws(f, s, twins, far),
        };
        f.rec.end_scope();
        q.end_pass(ctx, cmd);
        draw_calls
    }

    /// What a scope draws before its list: the hooked techniques' draws
    /// (the stencil mask, RDM's checkerboard, the points' composite).
    fn scope_masks(
        &self,
        f: &Frame,
        s: &ScopeStep,
        twins: Option<&super::passes::inset_wide::WidePipelines>,
    ) -> u64 {
        if !s.masks {
            return 0;
        }
        let hook = ScopeHook {
            rec: &f.rec,
            slot: self.slot,
            eye: s.eye,
            extent: vk::Extent2D {
                width: s.extent[0],
                height: s.extent[1],
            },
            checkerboard: s.checkerboard,
            quadrants: s.quadrants,
            lms: self.passes.lms.as_ref(),
            twins,
            floor: f.floor.is_some(),
        };
        self.passes
            .techniques
            .iter()
            .map(|t| t.in_scope(&hook))
            .sum()
    }

    /// A scope's list (once per LMS quadrant) and its overlay.
    fn scope_draws(
        &self,
        f: &Frame,
        s: &ScopeStep,
        twins: Option<&super::passes::inset_wide::WidePipelines>,
        far: Option<&super::passes::far_field::FarField>,
    ) -> u64 {
        let (p, rec, eye) = (&self.passes, &f.rec, s.eye);
        let forward = twins.map_or(&p.forward, |w| &w.forward);
        let overlay = twins.map_or(&p.overlay, |w| &w.overlay);
        let gpu = p.gpu_cull.as_ref().filter(|_| f.floor.is_none());
        // The inset scope (the one with a render area) draws the inset's
        // own list.
        let (near, base) = match s.area {
            Some(_) => (
                f.batches.inset_draws(),
                f.batches.inset_start.unwrap_or(0) as u32,
            ),
            None => (f.batches.near_draws(), 0),
        };
        let mut draw_calls = 0;
        for k in 0..s.quadrants {
            if let Some(l) = &p.lms {
                l.set_quadrant(rec, (s.quadrants > 1).then_some(k));
            }
            draw_calls += match (s.draws, f.floor, far, gpu) {
                (Draws::Floor, Some(kind), ..) => p.floor.record(rec, kind, eye),
                (Draws::FarThenNear, _, Some(far), g) => {
                    far.record_composite(rec, eye)
                        + match g {
                            Some(g) => forward.record_gpu(rec, g, eye, self.slot, false, false),
                            None => forward.record(rec, near, eye, false),
                        }
                }
                (
                    Draws::Forward {
                        gpu_second, sky, ..
                    },
                    _,
                    _,
                    Some(g),
                ) => {
                    // The blended draws (CPU-sorted) after the opaque ones
                    // and the sky; with occlusion in its second part.
                    let blended = &f.batches.draws;
                    forward.record_gpu(rec, g, eye, self.slot, sky, gpu_second)
                        + if s.part == ScopePart::First || blended.is_empty() {
                            0
                        } else {
                            forward.record(rec, blended, eye, false)
                        }
                }
                (Draws::Forward { sky, .. }, ..) => forward.record_from(rec, near, base, eye, sky),
                _ => 0,
            };
            if s.overlay {
                draw_calls += overlay.record(rec, self.extras.overlay.len(), eye);
            }
        }
        draw_calls
    }
}

/// An extent as the plan's size.
fn size(e: vk::Extent2D) -> plan::Size {
    [e.width, e.height]
}
