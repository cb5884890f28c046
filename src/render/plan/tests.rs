//! The frame plan per configuration, without a GPU.

use super::*;

fn base() -> PlanInput {
    PlanInput {
        two_pass: false,
        extent: [200, 100],
        floor: false,
        gpu_cull: false,
        occlusion: false,
        gpu_inset_lists: false,
        points: false,
        points_compute: false,
        far: false,
        far_pass: false,
        inset: None,
        lms: None,
        resolved_sky: false,
        rdm: false,
        stencil_mask: false,
        mask_in_depth: false,
        parallel: false,
    }
}

fn inset(four: bool) -> InsetInput {
    InsetInput {
        rect: PixelRect {
            x0: 60,
            y0: 30,
            x1: 140,
            y1: 70,
        },
        four_view_region: four.then_some(PixelRect {
            x0: 10,
            y0: 5,
            x1: 190,
            y1: 95,
        }),
        wide_extent: [70, 35],
        wide_one_sample: [true, false],
        jitter: [0.25, -0.25],
        quad: false,
    }
}

fn scopes(steps: &[Step]) -> Vec<ScopeStep> {
    steps
        .iter()
        .filter_map(|s| match s {
            Step::Scope(s) => Some(*s),
            _ => None,
        })
        .collect()
}

#[test]
fn multiview_is_one_covered_scope_between_the_frame_steps() {
    let steps = frame(&base());
    assert_eq!(steps.len(), 4, "{steps:?}");
    assert_eq!(steps[0], Step::BeginBarriers);
    assert_eq!(steps[1], Step::BeginStats);
    assert_eq!(steps[3], Step::EndStats);
    let s = scopes(&steps)[0];
    assert_eq!(s.name, "forward");
    assert_eq!(s.target, Target::Eye { set: 0 });
    assert_eq!((s.view_mask, s.eye, s.part), (0b11, 0, ScopePart::Whole));
    assert_eq!(s.extent, [200, 100]);
    assert!(s.colour_covered && s.overlay && s.masks && s.area.is_none());
    assert_eq!(
        s.draws,
        Draws::Forward {
            inset_list: false,
            gpu_second: false,
            sky: true
        }
    );
}

#[test]
fn two_pass_draws_each_eye_into_its_own_set() {
    let s = scopes(&frame(&PlanInput {
        two_pass: true,
        ..base()
    }));
    assert_eq!(s.len(), 2);
    for (k, s) in s.iter().enumerate() {
        assert_eq!(s.target, Target::Eye { set: k });
        assert_eq!((s.eye, s.view_mask), (k as u32, 0));
    }
}

#[test]
fn occlusion_splits_the_scopes_around_the_late_cull() {
    let steps = frame(&PlanInput {
        gpu_cull: true,
        occlusion: true,
        two_pass: true,
        ..base()
    });
    assert_eq!(steps[0], Step::GpuCull);
    let late = steps.iter().position(|s| *s == Step::LateCull).unwrap();
    let s = scopes(&steps);
    assert_eq!(s.len(), 4);
    let before = steps[..late]
        .iter()
        .filter(|s| matches!(s, Step::Scope(_)))
        .count();
    assert_eq!(before, 2, "the early scopes come before the late cull");
    for s in &s[..2] {
        assert_eq!(s.part, ScopePart::First);
        assert!(s.masks && !s.overlay);
        assert_eq!(
            s.draws,
            Draws::Forward {
                inset_list: false,
                gpu_second: false,
                sky: false
            }
        );
    }
    for s in &s[2..] {
        assert_eq!((s.part, s.name), (ScopePart::Second, "forward-late"));
        assert!(!s.masks && s.overlay);
        assert_eq!(
            s.draws,
            Draws::Forward {
                inset_list: false,
                gpu_second: true,
                sky: true
            }
        );
    }
}

#[test]
fn the_inset_draws_the_wide_view_then_the_eye_inside_its_rectangle() {
    let i = inset(false);
    let steps = frame(&PlanInput {
        inset: Some(i),
        gpu_cull: true,
        gpu_inset_lists: true,
        ..base()
    });
    let s = scopes(&steps);
    assert_eq!(s.len(), 2);
    assert_eq!(
        (s[0].name, s[0].target),
        ("forward-wide", Target::Wide { eye: 0 })
    );
    assert_eq!(s[0].extent, [70, 35]);
    assert_eq!(s[0].jitter, [0.25, -0.25]);
    assert!(s[0].one_sample_twins && s[0].area.is_none());
    assert_eq!(
        s[0].draws,
        Draws::Forward {
            inset_list: false,
            gpu_second: false,
            sky: true
        }
    );
    assert_eq!(
        (s[1].name, s[1].target),
        ("forward-inset", Target::Eye { set: 0 })
    );
    assert_eq!(s[1].area, Some(i.rect));
    assert!(!s[1].one_sample_twins);
    assert_eq!(s[1].jitter, [0.0; 2]);
    assert_eq!(
        s[1].draws,
        Draws::Forward {
            inset_list: true,
            gpu_second: true,
            sky: true
        }
    );
    assert_eq!(steps[steps.len() - 2], Step::InsetComposite);
    // A quad output: the runtime shows the views as drawn.
    let quad = frame(&PlanInput {
        inset: Some(InsetInput { quad: true, ..i }),
        ..base()
    });
    assert!(!quad.contains(&Step::InsetComposite));
    assert_eq!(scopes(&quad)[0].jitter, [0.0; 2]);
}

#[test]
fn rdm_checkers_the_periphery_the_wide_views_or_the_eye_and_fills_it_before_the_composites() {
    let i = inset(false);
    for lms in [None, Some([120, 60])] {
        let steps = frame(&PlanInput {
            rdm: true,
            lms,
            ..base()
        });
        assert!(scopes(&steps).iter().all(|s| s.checkerboard));
        let at = |want: Step| steps.iter().position(|s| *s == want);
        if lms.is_some() {
            assert!(at(Step::AfterResolve(AfterResolve::Resolved)) < at(Step::LmsResample));
        }
    }
    let steps = frame(&PlanInput {
        rdm: true,
        inset: Some(i),
        gpu_cull: true,
        occlusion: true,
        ..base()
    });
    let s = scopes(&steps);
    let checkered: Vec<_> = s
        .iter()
        .map(|s| (s.target, s.part, s.checkerboard))
        .collect();
    assert_eq!(
        checkered,
        [
            (Target::Wide { eye: 0 }, ScopePart::First, true),
            (Target::Eye { set: 0 }, ScopePart::First, false),
            (Target::Wide { eye: 0 }, ScopePart::Second, false),
            (Target::Eye { set: 0 }, ScopePart::Second, false),
        ]
    );
    let at = |want: Step| steps.iter().position(|s| *s == want).unwrap();
    assert!(at(Step::AfterResolve(AfterResolve::Resolved)) < at(Step::InsetComposite));
}

#[test]
fn four_inset_views_share_one_scope_over_the_region_and_the_inset() {
    let i = inset(true);
    for floor in [false, true] {
        let s = scopes(&frame(&PlanInput {
            inset: Some(i),
            floor,
            ..base()
        }));
        assert_eq!(s.len(), 1);
        assert_eq!(s[0].view_mask, 0b1111);
        assert_eq!(
            s[0].area,
            Some(PixelRect {
                x0: 9,
                y0: 4,
                x1: 191,
                y1: 96
            })
        );
        let name = if floor {
            "forward"
        } else {
            "forward-four-view"
        };
        assert_eq!(s[0].name, name);
    }
}

#[test]
fn a_floor_frame_draws_the_floor_without_culling_sky_or_composites() {
    let steps = frame(&PlanInput {
        floor: true,
        gpu_cull: true,
        occlusion: true,
        points: true,
        points_compute: true,
        resolved_sky: true,
        inset: Some(inset(false)),
        ..base()
    });
    for absent in [
        Step::GpuCull,
        Step::BeforeScopes,
        Step::LateCull,
        Step::AfterResolve(AfterResolve::Resolved),
        Step::InsetComposite,
    ] {
        assert!(!steps.contains(&absent), "{absent:?} in {steps:?}");
    }
    let s = scopes(&steps);
    assert_eq!(s.len(), 1, "no wide view on a floor frame");
    assert_eq!(s[0].draws, Draws::Floor);
    assert!(!s[0].overlay && !s[0].sky_after_resolve && !s[0].secondaries);
}

#[test]
fn lms_draws_four_quadrants_into_its_targets_then_resamples() {
    let steps = frame(&PlanInput {
        lms: Some([120, 60]),
        two_pass: true,
        ..base()
    });
    let s = scopes(&steps);
    assert_eq!(s[1].target, Target::Lms { eye: 1 });
    assert_eq!(
        (s[1].name, s[1].extent, s[1].quadrants),
        ("forward-lms", [120, 60], 4)
    );
    assert!(!s[1].colour_covered);
    assert!(steps.contains(&Step::LmsResample));
}

#[test]
fn with_lms_the_resolved_sky_goes_under_the_resampled_image() {
    let steps = frame(&PlanInput {
        lms: Some([120, 60]),
        resolved_sky: true,
        ..base()
    });
    let at = |want: Step| steps.iter().position(|s| *s == want).unwrap();
    assert_eq!(
        at(Step::AfterResolve(AfterResolve::Resampled)),
        at(Step::LmsResample) + 1
    );
    assert!(scopes(&steps).iter().all(|s| s.sky_after_resolve));
}

#[test]
fn the_far_field_goes_first_and_its_composite_leads_each_scope() {
    let steps = frame(&PlanInput {
        far: true,
        far_pass: true,
        ..base()
    });
    assert_eq!(steps[2], Step::FarField);
    let s = scopes(&steps)[0];
    assert_eq!(s.draws, Draws::FarThenNear);
    assert!(!s.colour_covered);
    // A frame without a far camera keeps the pass's uncovered colour.
    let s = scopes(&frame(&PlanInput {
        far_pass: true,
        ..base()
    }))[0];
    assert!(!s.colour_covered);
    assert!(matches!(s.draws, Draws::Forward { .. }));
}

#[test]
fn colour_is_covered_only_without_stencil_kept_draws_or_a_later_sky() {
    let covered = |i: PlanInput| scopes(&frame(&i))[0].colour_covered;
    assert!(covered(base()));
    assert!(!covered(PlanInput {
        stencil_mask: true,
        ..base()
    }));
    assert!(covered(PlanInput {
        stencil_mask: true,
        mask_in_depth: true,
        ..base()
    }));
    assert!(!covered(PlanInput {
        rdm: true,
        ..base()
    }));
    assert!(!covered(PlanInput {
        resolved_sky: true,
        ..base()
    }));
    let sky = frame(&PlanInput {
        resolved_sky: true,
        ..base()
    });
    assert!(sky.contains(&Step::AfterResolve(AfterResolve::Resolved)));
    assert!(scopes(&sky)[0].sky_after_resolve);
    assert_eq!(
        scopes(&sky)[0].draws,
        Draws::Forward {
            inset_list: false,
            gpu_second: false,
            sky: false
        }
    );
}

#[test]
fn occlusion_with_the_inset_draws_both_scopes_in_each_part() {
    let steps = frame(&PlanInput {
        gpu_cull: true,
        occlusion: true,
        inset: Some(inset(false)),
        ..base()
    });
    let late = steps.iter().position(|s| *s == Step::LateCull).unwrap();
    let s = scopes(&steps);
    assert_eq!(s.len(), 4, "{steps:?}");
    let before = steps[..late]
        .iter()
        .filter(|s| matches!(s, Step::Scope(_)))
        .count();
    assert_eq!(before, 2, "both early scopes come before the late cull");
    for (k, s) in s.iter().enumerate() {
        let second = k >= 2;
        let inset_scope = k % 2 == 1;
        assert_eq!(
            s.part,
            if second {
                ScopePart::Second
            } else {
                ScopePart::First
            }
        );
        assert_eq!(
            s.target,
            if inset_scope {
                Target::Eye { set: 0 }
            } else {
                Target::Wide { eye: 0 }
            }
        );
        assert_eq!(s.area.is_some(), inset_scope);
        // Without the inset's own lists both scopes draw the early set
        // first and the late set second.
        assert_eq!(
            s.draws,
            Draws::Forward {
                inset_list: inset_scope,
                gpu_second: second,
                sky: second
            }
        );
    }
    assert_eq!(steps[steps.len() - 2], Step::InsetComposite);
}
