//! The frame plan: a pure description of one frame's GPU work in the
//! order the GPU runs it — compute steps, the rendering scopes (which
//! target, area, view mask and eye, which draw list, jitter, whether the
//! colour is covered) and the steps after the resolve — computed from what
//! the configuration built, the device's choices and the frame's geometry
//! ([`PlanInput`]), with no Vulkan handles. `Renderer::record` walks it
//! (`render::record`); the tests below check it per configuration without
//! a GPU.
//!
//! The shape follows the render-graph builders of rend3 (`base.rs`,
//! `add_to_graph`) and kajiya (`world_render_passes.rs`): a list of steps
//! decided first, recorded second.

pub use super::passes::technique::AfterResolve;
use crate::view::inset::PixelRect;

/// Which part of the frame's drawing a scope holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScopePart {
    /// All of it: clear, draw, resolve.
    Whole,
    /// The first of two (occlusion's early views): clear, draw, store
    /// colour and depth unresolved.
    First,
    /// The second of two (the late views): load, draw, resolve.
    Second,
}

/// Pixels (width, height).
pub type Size = [u32; 2];

/// What a scope draws into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// The frame's attachment set `set` (the eye's targets: one set
    /// under multiview, one per eye in two-pass).
    Eye {
        /// Index into the frame's attachment sets.
        set: usize,
    },
    /// The inset's wide targets of `eye`.
    Wide {
        /// The eye.
        eye: u32,
    },
    /// Lens-matched shading's targets of `eye`.
    Lms {
        /// The eye.
        eye: u32,
    },
}

/// What a scope's draws come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draws {
    /// A floor frame's fixed draw.
    Floor,
    /// The far field's composite, then the near field's list (no sky:
    /// the far field has it).
    FarThenNear,
    /// The forward list: the inset's own (`inset_list`) or the frame's.
    Forward {
        /// The inset's list (the scope with a render area).
        inset_list: bool,
        /// With `gpu-cull`: the cull's second command set (occlusion's
        /// late draws, or the inset's list).
        gpu_second: bool,
        /// The sky is drawn in this scope.
        sky: bool,
    },
}

/// One rendering scope.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScopeStep {
    /// Which part of the frame it holds.
    pub part: ScopePart,
    /// The timing name (`forward-late` for occlusion's second part).
    pub name: &'static str,
    /// Where it draws.
    pub target: Target,
    /// Its viewport's size.
    pub extent: Size,
    /// A render area inside the extent (the inset); None: all of it.
    pub area: Option<PixelRect>,
    /// Multiview mask (0: one view).
    pub view_mask: u32,
    /// The eye (two-pass) or 0 (multiview).
    pub eye: u32,
    /// The wide view at one sample: the one-sample pipeline twins.
    pub one_sample_twins: bool,
    /// The viewport's sub-pixel offset.
    pub jitter: [f32; 2],
    /// The draws were recorded into secondaries (`--record-threads`).
    pub secondaries: bool,
    /// The sky is drawn after the resolve instead.
    pub sky_after_resolve: bool,
    /// Every colour sample is written: no colour clear.
    pub colour_covered: bool,
    /// The stencil mask, RDM's checkerboard and the points' composite are
    /// drawn first (not in occlusion's second part).
    pub masks: bool,
    /// RDM's checkerboard is among the masks: every scope but the inset's
    /// own (with the inset, the wide views hold the periphery).
    pub checkerboard: bool,
    /// What the scope draws.
    pub draws: Draws,
    /// The overlay (boxes, section) after the draws.
    pub overlay: bool,
    /// Times the contents are drawn: once per LMS quadrant, else once.
    pub quadrants: u32,
}

/// One step of the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// The GPU cull (its early phase with occlusion).
    GpuCull,
    /// The hooked techniques' work before the scopes (the points'
    /// compute rasterization).
    BeforeScopes,
    /// The attachments' layout barriers at the frame's start.
    BeginBarriers,
    /// The pipeline-statistics query opens.
    BeginStats,
    /// The monoscopic far field's own pass.
    FarField,
    /// Occlusion's late cull against the depth pyramid, between the parts.
    LateCull,
    /// A rendering scope.
    Scope(ScopeStep),
    /// The hooked techniques' work after the scopes, at `AfterResolve`
    /// (the sky behind the resolved colour, RDM's fill of the
    /// checkerboard's holes).
    AfterResolve(AfterResolve),
    /// LMS's resample into the eye images.
    LmsResample,
    /// The inset's composite of the wide and inset views.
    InsetComposite,
    /// The pipeline-statistics query closes.
    EndStats,
}

/// The inset as the plan needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InsetInput {
    /// The inset rectangle (eye pixels).
    pub rect: PixelRect,
    /// With four views in one scope: the wide views' region this frame.
    pub four_view_region: Option<PixelRect>,
    /// The wide view's size this frame.
    pub wide_extent: Size,
    /// Per eye: the wide view is drawn at one sample with the one-sample
    /// pipeline twins.
    pub wide_one_sample: [bool; 2],
    /// The wide views' jitter (zero without TAA).
    pub jitter: [f32; 2],
    /// The output takes the four views as drawn (a quad layer): no
    /// jitter, no composite.
    pub quad: bool,
}

/// What the frame has: the passes the configuration built, the device's
/// choices and this frame's geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanInput {
    /// Two-pass stereo (else multiview).
    pub two_pass: bool,
    /// The eye targets' size this frame.
    pub extent: Size,
    /// A floor frame (`render_floor`): no culling, points, far field,
    /// inset views or sky.
    pub floor: bool,
    /// The GPU cull runs; with `occlusion` in two phases.
    pub gpu_cull: bool,
    /// Occlusion culling (with `gpu_cull`).
    pub occlusion: bool,
    /// The GPU cull made the inset's own lists.
    pub gpu_inset_lists: bool,
    /// A point cloud is drawn; `points_compute`: by the compute raster.
    pub points: bool,
    /// The points rasterize in compute before the scopes.
    pub points_compute: bool,
    /// A monoscopic far field was planned this frame.
    pub far: bool,
    /// The far-field pass exists (even when this frame has none).
    pub far_pass: bool,
    /// The inset pass (None: off).
    pub inset: Option<InsetInput>,
    /// Lens-matched shading, its targets' size.
    pub lms: Option<Size>,
    /// The resolved-sky pass exists.
    pub resolved_sky: bool,
    /// RDM's checkerboard.
    pub rdm: bool,
    /// The stencil mask, and whether it marks the hidden area in depth.
    pub stencil_mask: bool,
    /// The stencil mask marks in depth (no stencil test keeps draws out).
    pub mask_in_depth: bool,
    /// The draws come from the recording threads' secondaries.
    pub parallel: bool,
}

/// The frame's steps in GPU order.
pub fn frame(input: &PlanInput) -> Vec<Step> {
    let gpu_cull = input.gpu_cull && !input.floor;
    // At most 11 fixed steps and 4 scopes a part.
    let mut steps = Vec::with_capacity(20);
    if gpu_cull {
        steps.push(Step::GpuCull);
    }
    if input.points && input.points_compute && !input.floor {
        steps.push(Step::BeforeScopes);
    }
    steps.push(Step::BeginBarriers);
    steps.push(Step::BeginStats);
    let far = input.far && !input.floor;
    if far {
        steps.push(Step::FarField);
    }
    let parts: &[ScopePart] = if gpu_cull && input.occlusion {
        &[ScopePart::First, ScopePart::Second]
    } else {
        &[ScopePart::Whole]
    };
    for &part in parts {
        if part == ScopePart::Second {
            steps.push(Step::LateCull);
        }
        push_scopes(input, part, &mut steps);
    }
    // With lms the sky goes under the resampled eye image (the LMS image
    // holds premultiplied colour and coverage, which the resample's
    // bilinear reads keep: "under" is linear in them).
    let sky = input.resolved_sky && !input.floor;
    if (sky && input.lms.is_none()) || input.rdm {
        steps.push(Step::AfterResolve(AfterResolve::Resolved));
    }
    if input.lms.is_some() {
        steps.push(Step::LmsResample);
        if sky {
            steps.push(Step::AfterResolve(AfterResolve::Resampled));
        }
    }
    if input.inset.is_some_and(|i| !i.quad) && !input.floor {
        steps.push(Step::InsetComposite);
    }
    steps.push(Step::EndStats);
    steps
}

/// Every colour sample is written when the sky is drawn inside the
/// scopes and no stencil (hidden-area mask, RDM's checkerboard) keeps
/// draws out (a hidden-area mask marked in depth writes its samples'
/// colour itself); the far field's composite is not counted on, nor
/// LMS's quadrants (their resample filters across the quadrant edges,
/// past what the per-quadrant sky covers). Floor frames start their
/// colour the same way as the frame.
fn colour_covered(input: &PlanInput) -> bool {
    !input.resolved_sky
        && (!input.stencil_mask || input.mask_in_depth)
        && !input.rdm
        && !input.far_pass
        && input.lms.is_none()
}

/// Appends the scopes of one part to `steps`: per view set, the inset's
/// wide view (when it has one) and then the eye.
fn push_scopes(input: &PlanInput, part: ScopePart, steps: &mut Vec<Step>) {
    // (target set, view mask, eye)
    let sets: &[(usize, u32, u32)] = if input.two_pass {
        &[(0, 0, 0), (1, 0, 1)]
    } else {
        &[(0, 0b11, 0)]
    };
    // With the inset's four views in one scope (floor frames too: the
    // targets are the four-layer ones): one scope over the wide views'
    // region and the inset together, grown by a pixel (the composite's
    // bilinear reads at the region's edge texel centres, and the texel
    // past it must be written too).
    let four = input.inset.and_then(|i| {
        i.four_view_region.map(|region| {
            let grown = PixelRect {
                x0: region.x0.saturating_sub(1),
                y0: region.y0.saturating_sub(1),
                x1: (region.x1 + 1).min(input.extent[0]),
                y1: (region.y1 + 1).min(input.extent[1]),
            };
            crate::view::inset::bounding(&grown, &i.rect)
        })
    });
    let sets: &[(usize, u32, u32)] = if four.is_some() {
        &[(0, 0b1111, 0)]
    } else {
        sets
    };
    let inset = input.inset.filter(|_| !input.floor);
    for &(set, view_mask, eye) in sets {
        let base = scope_base(input, part, eye, view_mask);
        if let Some(i) = inset.filter(|i| i.four_view_region.is_none()) {
            steps.push(Step::Scope(ScopeStep {
                name: if part == ScopePart::Second {
                    "forward-late"
                } else {
                    "forward-wide"
                },
                target: Target::Wide { eye },
                extent: i.wide_extent,
                one_sample_twins: i.wide_one_sample[eye as usize % 2],
                jitter: if i.quad { [0.0; 2] } else { i.jitter },
                ..base
            }));
        }
        // The scope over the inset (or the four views' region) draws
        // inside it only.
        let area = four.or_else(|| inset.map(|i| i.rect));
        let name = match (inset, input.lms) {
            _ if part == ScopePart::Second => "forward-late",
            (Some(i), _) if i.four_view_region.is_some() => "forward-four-view",
            (Some(_), _) => "forward-inset",
            (None, Some(_)) => "forward-lms",
            (None, None) => "forward",
        };
        let (target, extent) = match input.lms {
            Some(size) => (Target::Lms { eye }, size),
            None => (Target::Eye { set }, input.extent),
        };
        steps.push(Step::Scope(ScopeStep {
            name,
            target,
            extent,
            area,
            draws: draws(input, part, area.is_some()),
            checkerboard: base.checkerboard && input.inset.is_none(),
            ..base
        }));
    }
}

/// A scope of `part` for `eye` with what every scope of the frame shares.
fn scope_base(input: &PlanInput, part: ScopePart, eye: u32, view_mask: u32) -> ScopeStep {
    ScopeStep {
        part,
        name: "forward",
        target: Target::Eye { set: 0 },
        extent: input.extent,
        area: None,
        view_mask,
        eye,
        one_sample_twins: false,
        jitter: [0.0; 2],
        secondaries: input.parallel && !input.floor,
        sky_after_resolve: input.resolved_sky && !input.floor,
        colour_covered: colour_covered(input),
        masks: part != ScopePart::Second,
        checkerboard: input.rdm && part != ScopePart::Second,
        draws: draws(input, part, false),
        overlay: !input.floor && part != ScopePart::First,
        quadrants: if input.lms.is_some() && !input.floor {
            4
        } else {
            1
        },
    }
}

/// What a scope of `part` draws (`inset_list`: the scope with a render
/// area draws the inset's own list).
fn draws(input: &PlanInput, part: ScopePart, inset_list: bool) -> Draws {
    if input.floor {
        return Draws::Floor;
    }
    if input.far {
        return Draws::FarThenNear;
    }
    let late = part == ScopePart::Second;
    Draws::Forward {
        inset_list,
        gpu_second: input.gpu_cull && (late || (inset_list && input.gpu_inset_lists)),
        sky: part != ScopePart::First && !input.resolved_sky,
    }
}

#[cfg(test)]
mod tests;
