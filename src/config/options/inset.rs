//! `inset[=F]` and its variants: multi-resolution foveated rendering
//! ([`crate::view::inset`], accumulation in [`crate::view::taa`] and
//! [`crate::view::taau`]).

use super::{
    flag, four_views, foveation_on, optional, rdm_on, required, submission_on, Entry, Rule,
    Technique,
};
use crate::config::{Inset, RenderConfig};
use crate::error::{Error, Result};
use crate::view::{sharpen, taa};

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Multi-resolution foveated rendering (inset)",
    page: "inset",
    summary: "full resolution around the gaze, a smaller wide view elsewhere, optionally at one sample, accumulated, upsampled and sharpened over frames; four views to runtimes that take them",
    options: &[
        optional("inset", "F", "0.6"),
        required("inset-fov", "DEG", "15"),
        required("inset-views", "2|4", "4"),
        flag("inset-wide-1x"),
        optional("inset-taa", "A", "0.25"),
        flag("inset-taa-jitter"),
        flag("inset-taau"),
        optional("inset-sharpen", "S", "0.5"),
        flag("inset-taau-lanczos"),
        flag("inset-catmull-rom"),
        flag("inset-wide-all"),
        flag("inset-composite"),
    ],
    parse,
    print,
    rules: &[
        Rule {
            when: |c| c.effort.inset.is_some(),
            with: &[
                ("timewarp", |c| c.simulator.timewarp.is_some()),
                ("--record-threads/--per-draw", submission_on),
            ],
            message: "inset renders each eye as a wide and an inset view and composites them; {} works on one full-size view: leave it out with inset",
        },
        Rule::always(
            |c| four_views(c) && foveation_on(c),
            "foveation's rate image has the eyes' two layers; inset-views=4 draws four views in one scope: leave one out (the inset's two scopes take foveation)",
        ),
        Rule::always(
            |c| four_views(c) && c.effort.mffr.is_some(),
            "mffr's far cameras take the views inset-views=4 gives the wide views: leave one out (the inset's two scopes take mffr)",
        ),
        Rule::always(
            |c| c.effort.inset.is_some_and(|i| i.wide_1x) && c.frame.msaa > 1 && c.effort.mffr.is_some(),
            "inset-wide-1x draws the wide views at one sample with their own pipelines; mffr's composite is made for the frame's samples: leave one out",
        ),
        Rule::always(
            |c| four_views(c) && rdm_on(c),
            "rdm puts its checkerboard in the inset's wide views drawn in their own scope; inset-views=4 draws them in the eyes' scope: leave one out",
        ),
        Rule::always(
            |c| c.effort.inset.is_some_and(|i| i.wide_1x) && c.frame.msaa > 1 && rdm_on(c),
            "inset-wide-1x draws the wide views at one sample with their own pipelines; rdm's checkerboard is made for the frame's samples: leave one out",
        ),
        Rule::always(
            |c| four_views(c) && c.culling.occlusion,
            "occlusion builds its depth pyramid from the inset's wide views drawn in their own scope; inset-views=4 draws them in the eyes' scope: leave one out",
        ),
        Rule::always(
            |c| four_views(c) && c.effort.inset.is_some_and(|i| i.wide_1x),
            "inset-wide-1x draws the wide views in their own scope at one sample; inset-views=4 draws them in the eyes' scope at the eyes' samples: leave one out",
        ),
        Rule::always(
            |c| four_views(c) && c.effort.inset.is_some_and(|i| i.taa.is_some()),
            "inset-taa jitters and accumulates the wide views drawn in their own scope; inset-views=4 draws them in the eyes' scope: leave one out",
        ),
        Rule::always(
            |c| c.effort.inset.is_some_and(|i| i.taau && i.catmull_rom),
            "inset-taau accumulates the wide views at the eye's resolution and the composite reads them pixel for pixel; inset-catmull-rom chooses the composite's upsampling filter, which it then no longer uses: leave one out",
        ),
        Rule::always(
            |c| c.effort.inset.is_some_and(|i| i.wide_1x) && c.frame.msaa == 1,
            "inset-wide-1x draws the wide views at one sample while the insets keep the frame's MSAA; with no-msaa (--msaa 1) every view is at one sample already: leave one out",
        ),
    ],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    let i = c.effort.inset.unwrap_or_default();
    c.effort.inset = Some(match e.name {
        "inset-fov" => Inset {
            half_angle_deg: e.number((1.0, 80.0), "DEG", "the inset's half-angle")?,
            fov_given: true,
            ..i
        },
        "inset-views" => Inset {
            four_views: views_value(e)?,
            ..i
        },
        "inset-taa" | "inset-taa-jitter" => accumulate(i, e)?,
        "inset-taau" | "inset-taau-lanczos" | "inset-sharpen" => upsample(i, e)?,
        _ => modifier(i, e)?,
    });
    Ok(())
}

/// `inset[=F]` and the flags that only switch one setting on.
fn modifier(i: Inset, e: &Entry) -> Result<Inset> {
    Ok(match e.name {
        "inset-wide-1x" => Inset { wide_1x: true, ..i },
        "inset-composite" => Inset {
            composite: true,
            ..i
        },
        "inset-wide-all" => Inset {
            wide_all: true,
            ..i
        },
        "inset-catmull-rom" => Inset {
            catmull_rom: true,
            ..i
        },
        _ if e.value.is_none() => i,
        _ => Inset {
            wide_scale: e.number((0.1, 1.0), "F", "the wide view's scale per axis")?,
            ..i
        },
    })
}

/// `inset-views=2|4`: whether the four views share one scope.
fn views_value(e: &Entry) -> Result<bool> {
    match e.value {
        Some("4") => Ok(true),
        Some("2") => Ok(false),
        _ => Err(Error::config(
            "--opt",
            format!(
                "'{}': expected inset-views=2 (two scopes, the default) or inset-views=4 (one multiview scope of four views)",
                e.item
            ),
        )),
    }
}

/// `inset-taa[=A]` and `inset-taa-jitter`.
fn accumulate(i: Inset, e: &Entry) -> Result<Inset> {
    let what = "the weight of each new frame in the wide views' temporal average";
    let alpha = match e.value {
        Some(_) => e.number((0.01, 1.0), "A", what)?,
        None => i.taa.unwrap_or(taa::DEFAULT_ALPHA),
    };
    Ok(Inset {
        taa: Some(alpha),
        taa_jitter: i.taa_jitter || e.name == "inset-taa-jitter",
        ..i
    })
}

/// `inset-taau`, `inset-taau-lanczos` and `inset-sharpen[=S]` (each turns
/// `inset-taau` on).
fn upsample(i: Inset, e: &Entry) -> Result<Inset> {
    let i = i.with_taau();
    Ok(match (e.name, e.value) {
        ("inset-taau-lanczos", _) => Inset {
            taau_lanczos: true,
            ..i
        },
        ("inset-sharpen", None) => Inset {
            sharpen: Some(sharpen::DEFAULT_STRENGTH),
            ..i
        },
        ("inset-sharpen", Some(_)) => {
            let what = "the strength of the upsampled periphery's sharpening";
            Inset {
                sharpen: Some(e.number(sharpen::STRENGTH_RANGE, "S", what)?),
                ..i
            }
        }
        _ => i,
    })
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    let Some(i) = c.effort.inset else { return };
    out.push(if i.wide_scale == crate::view::inset::DEFAULT_WIDE_SCALE {
        "inset".into()
    } else {
        format!("inset={}", i.wide_scale)
    });
    if i.fov_given {
        out.push(format!("inset-fov={}", i.half_angle_deg));
    }
    for (on, name) in [
        (i.four_views, "inset-views=4"),
        (i.wide_1x, "inset-wide-1x"),
        (i.composite, "inset-composite"),
        (i.wide_all, "inset-wide-all"),
    ] {
        if on {
            out.push(name.into());
        }
    }
    print_accumulation(&i, out);
    if i.catmull_rom {
        out.push("inset-catmull-rom".into());
    }
}

/// The accumulation and upsampling entries (`inset-taau` turns
/// `inset-taa` and its jitter on; `inset-sharpen` and
/// `inset-taau-lanczos` turn `inset-taau` on).
fn print_accumulation(i: &Inset, out: &mut Vec<String>) {
    match i.taa {
        Some(a) if a == taa::DEFAULT_ALPHA && i.taau => {}
        Some(a) if a == taa::DEFAULT_ALPHA => out.push("inset-taa".into()),
        Some(a) => out.push(format!("inset-taa={a}")),
        None => {}
    }
    match (i.sharpen, i.taau) {
        (Some(s), _) if s == sharpen::DEFAULT_STRENGTH => out.push("inset-sharpen".into()),
        (Some(s), _) => out.push(format!("inset-sharpen={s}")),
        (None, true) if !i.taau_lanczos => out.push("inset-taau".into()),
        (None, _) => {}
    }
    if i.taau_lanczos {
        out.push("inset-taau-lanczos".into());
    }
    if i.taa_jitter && !i.taau {
        out.push("inset-taa-jitter".into());
    }
}
