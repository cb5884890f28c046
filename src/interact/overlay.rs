//! What the user sees of the tools, as world-space boxes for the renderer's
//! overlay pass: a simple procedural controller model at each grip pose,
//! the pointing ray from each aim pose to what it hits, the teleport arc
//! and its landing marker, an outline around the instance a ray points at,
//! the measure points with the line between them
//! and the distance drawn as seven-segment digits facing the head. Pure
//! data (no Vulkan types); sizes follow the world scale so the models stay
//! hand-sized when the world is scaled.

use super::locomotion::ArcResult;
use super::raycast::SceneQuery;
use super::{FrameInput, Interaction, Update};
use crate::view::Pose;
use glam::DVec3;

/// Most boxes one frame's overlay holds (the frame uniforms' room).
pub const MAX_BOXES: usize = 160;

/// Colour of the pointing rays (linear RGB), magenta: a colour no scene
/// material of the samples uses, so tests can find the ray in an image.
pub const RAY_COLOR: [f32; 3] = [1.0, 0.0, 1.0];
/// Controller bodies.
pub const BODY_COLOR: [f32; 3] = [0.06, 0.06, 0.07];
/// The controllers' tracking rings, left and right.
pub const RING_COLORS: [[f32; 3]; 2] = [[0.1, 0.35, 1.0], [1.0, 0.3, 0.1]];
/// A teleport arc with a target, and its marker.
pub const ARC_OK_COLOR: [f32; 3] = [0.1, 1.0, 0.25];
/// A teleport arc without a target.
pub const ARC_NONE_COLOR: [f32; 3] = [1.0, 0.1, 0.05];
/// The outline of the instance a ray points at.
pub const HIGHLIGHT_COLOR: [f32; 3] = [0.0, 0.85, 1.0];
/// Measure points and the line between them.
pub const MEASURE_COLOR: [f32; 3] = [1.0, 0.85, 0.0];
/// The measure label.
pub const LABEL_COLOR: [f32; 3] = [1.0, 1.0, 1.0];

/// Thickness of a pointing ray, metres at world scale 1.
pub const RAY_THICKNESS_M: f64 = 0.005;
/// Length of a ray that hits nothing, metres at world scale 1.
pub const RAY_MISS_LENGTH_M: f64 = 5.0;
/// Most segments an arc is drawn with.
const ARC_SEGMENTS: usize = 48;

/// One oriented box: centre and three half-axis vectors (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverlayBox {
    /// World-space centre.
    pub center: DVec3,
    /// Half-axis vectors (each the box's half extent along that axis).
    pub axes: [DVec3; 3],
    /// Linear RGB colour.
    pub color: [f32; 3],
}

impl OverlayBox {
    /// A bar of square cross-section `thickness` from `a` to `b` (None
    /// for a degenerate or non-finite one).
    pub fn segment(a: DVec3, b: DVec3, thickness: f64, color: [f32; 3]) -> Option<OverlayBox> {
        let half = (b - a) * 0.5;
        let dir = half.try_normalize()?;
        if !(a.is_finite() && b.is_finite()) {
            return None;
        }
        let side = dir.any_orthonormal_vector();
        let up = dir.cross(side);
        Some(OverlayBox {
            center: a + half,
            axes: [side * thickness * 0.5, up * thickness * 0.5, half],
            color,
        })
    }

    /// A box of half extents `h` along `pose`'s axes, centred at `pose`'s
    /// position moved by `offset` (in the pose's frame).
    fn posed(pose: &Pose, offset: DVec3, h: DVec3, color: [f32; 3]) -> OverlayBox {
        let q = pose.orientation;
        OverlayBox {
            center: pose.position + q * offset,
            axes: [q * DVec3::X * h.x, q * DVec3::Y * h.y, q * DVec3::Z * h.z],
            color,
        }
    }
}

/// Segments (of a unit cell, x right 0..1, y up 0..2) of a character in
/// the seven-segment style, as (x0, y0, x1, y1).
fn glyph(c: char) -> &'static [(f64, f64, f64, f64)] {
    const A: (f64, f64, f64, f64) = (0.0, 2.0, 1.0, 2.0);
    const B: (f64, f64, f64, f64) = (1.0, 1.0, 1.0, 2.0);
    const C: (f64, f64, f64, f64) = (1.0, 0.0, 1.0, 1.0);
    const D: (f64, f64, f64, f64) = (0.0, 0.0, 1.0, 0.0);
    const E: (f64, f64, f64, f64) = (0.0, 0.0, 0.0, 1.0);
    const F: (f64, f64, f64, f64) = (0.0, 1.0, 0.0, 2.0);
    const G: (f64, f64, f64, f64) = (0.0, 1.0, 1.0, 1.0);
    // Lower-case m: three stems under a bar.
    const M: (f64, f64, f64, f64) = (0.5, 0.0, 0.5, 1.0);
    match c {
        '0' => &[A, B, C, D, E, F],
        '1' => &[B, C],
        '2' => &[A, B, D, E, G],
        '3' => &[A, B, C, D, G],
        '4' => &[B, C, F, G],
        '5' => &[A, C, D, F, G],
        '6' => &[A, C, D, E, F, G],
        '7' => &[A, B, C],
        '8' => &[A, B, C, D, E, F, G],
        '9' => &[A, B, C, D, F, G],
        '-' => &[G],
        'm' => &[E, M, C, G],
        _ => &[],
    }
}

/// Appends `text` (digits, '.', '-', ' ', 'm') as seven-segment bars of
/// character height `height`, centred at `anchor`, upright and facing
/// `eye`.
pub fn push_label(out: &mut Vec<OverlayBox>, text: &str, anchor: DVec3, eye: DVec3, height: f64) {
    let view = anchor - eye;
    let flat = DVec3::new(view.x, 0.0, view.z);
    let right = flat.cross(DVec3::Y).try_normalize().unwrap_or(DVec3::X);
    let cell = height * 0.5;
    let t = height * 0.12;
    let advance = |c: char| match c {
        '.' | ' ' => height * 0.35,
        _ => cell + height * 0.3,
    };
    let width: f64 = text.chars().map(advance).sum();
    let mut x = -width * 0.5;
    let at = |lx: f64, ly: f64| anchor + right * lx + DVec3::Y * (ly - height * 0.5);
    for c in text.chars() {
        if c == '.' {
            let p = at(x + t, t * 0.5);
            out.push(OverlayBox {
                center: p,
                axes: [
                    right * t * 0.5,
                    DVec3::Y * t * 0.5,
                    right.cross(DVec3::Y) * t * 0.25,
                ],
                color: LABEL_COLOR,
            });
        }
        for &(x0, y0, x1, y1) in glyph(c) {
            let (a, b) = (at(x + x0 * cell, y0 * cell), at(x + x1 * cell, y1 * cell));
            let along = (b - a) * 0.5;
            let across = if x0 == x1 { right } else { DVec3::Y };
            // Each bar overlaps its neighbours by half a thickness.
            let along = along + along.normalize_or_zero() * t * 0.5;
            out.push(OverlayBox {
                center: (a + b) * 0.5,
                axes: [along, across * t * 0.5, right.cross(DVec3::Y) * t * 0.25],
                color: LABEL_COLOR,
            });
        }
        x += advance(c);
    }
}

/// Appends the twelve edges of the box `[lo, hi]`, grown by `pad`, as bars
/// of `thickness`.
pub fn push_outline(out: &mut Vec<OverlayBox>, lo: DVec3, hi: DVec3, pad: f64, thickness: f64) {
    let (lo, hi) = (lo - DVec3::splat(pad), hi + DVec3::splat(pad));
    let corner = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    // Corners differing in one bit share an edge.
    for a in 0..8 {
        for bit in [1, 2, 4] {
            if a & bit == 0 {
                out.extend(OverlayBox::segment(
                    corner(a),
                    corner(a | bit),
                    thickness,
                    HIGHLIGHT_COLOR,
                ));
            }
        }
    }
}

/// The teleport arc (green with a target, red without), at most
/// [`ARC_SEGMENTS`] segments, and at its target a pad and a post; `s` is
/// the user's scale.
fn push_arc(out: &mut Vec<OverlayBox>, arc: &ArcResult, s: f64) {
    let color = if arc.target.is_some() {
        ARC_OK_COLOR
    } else {
        ARC_NONE_COLOR
    };
    let step = arc.points.len().div_ceil(ARC_SEGMENTS).max(1);
    let mut pts: Vec<DVec3> = arc.points.iter().copied().step_by(step).collect();
    if let Some(&last) = arc.points.last() {
        if pts.last() != Some(&last) {
            pts.push(last);
        }
    }
    for w in pts.windows(2) {
        out.extend(OverlayBox::segment(w[0], w[1], 0.008 * s, color));
    }
    let Some(t) = arc.target else {
        return;
    };
    out.push(OverlayBox {
        center: t + DVec3::Y * 0.005 * s,
        axes: [
            DVec3::X * 0.25 * s,
            DVec3::Y * 0.005 * s,
            DVec3::Z * 0.25 * s,
        ],
        color: ARC_OK_COLOR,
    });
    out.extend(OverlayBox::segment(
        t,
        t + DVec3::Y * 0.3 * s,
        0.02 * s,
        ARC_OK_COLOR,
    ));
}

/// The measure tool's points as small cubes and, with both, the segment
/// between them and its length as a label facing the eye.
fn push_measure(out: &mut Vec<OverlayBox>, it: &Interaction, input: &FrameInput) {
    let s = it.origin.scale;
    let cube = |p: DVec3| OverlayBox {
        center: p,
        axes: [
            DVec3::X * 0.01 * s,
            DVec3::Y * 0.01 * s,
            DVec3::Z * 0.01 * s,
        ],
        color: MEASURE_COLOR,
    };
    let m = &it.measure;
    out.extend(m.first.map(cube));
    out.extend(m.second.map(cube));
    let (Some(a), Some(b), Some(d)) = (m.first, m.second, m.distance()) else {
        return;
    };
    out.extend(OverlayBox::segment(a, b, 0.003 * s, MEASURE_COLOR));
    let eye = it.origin.point(input.head.position);
    let mid = (a + b) * 0.5;
    let height = (0.04 * mid.distance(eye)).clamp(0.02 * s, 5.0 * s);
    let label = super::measure::label(d);
    push_label(out, &label, mid + DVec3::Y * height * 1.5, eye, height);
}

/// The frame's overlay for `it` after [`Interaction::update`] gave
/// `update` for `input` over the scene `q`: replaces `out`'s contents (at
/// most [`MAX_BOXES`]).
pub fn build(
    it: &Interaction,
    input: &FrameInput,
    update: &Update,
    q: &SceneQuery,
    out: &mut Vec<OverlayBox>,
) {
    out.clear();
    let s = it.origin.scale;
    for (i, hand) in input.hands.iter().enumerate() {
        if let Some(grip) = hand.grip.filter(|g| g.validate().is_ok()) {
            let g = it.origin.pose(&grip);
            // A handle along the grip's Z with a ring over its front end.
            let body = DVec3::new(0.018, 0.022, 0.06) * s;
            out.push(OverlayBox::posed(
                &g,
                DVec3::new(0.0, 0.0, 0.02) * s,
                body,
                BODY_COLOR,
            ));
            let ring = DVec3::new(0.04, 0.008, 0.035) * s;
            out.push(OverlayBox::posed(
                &g,
                DVec3::new(0.0, 0.02, -0.06) * s,
                ring,
                RING_COLORS[i],
            ));
        }
        let aiming_arc = i == 1 && update.arc.is_some();
        if let Some(aim) = hand.aim.filter(|a| a.validate().is_ok() && !aiming_arc) {
            let a = it.origin.pose(&aim);
            let end = match (&update.panel_pointer[i], &update.hover[i]) {
                // The panel's distance is in tracking space.
                (Some(on), _) => a.position + a.forward() * on.distance * s,
                (None, Some(hit)) => hit.point,
                (None, None) => a.position + a.forward() * RAY_MISS_LENGTH_M * s,
            };
            out.extend(OverlayBox::segment(
                a.position,
                end,
                RAY_THICKNESS_M * s,
                RAY_COLOR,
            ));
        }
    }
    // The instances the rays point at, outlined (once when both hands
    // point at the same one).
    let mut seen: Option<u32> = None;
    for i in update.hover.iter().flatten().map(|h| h.instance) {
        if seen == Some(i) {
            continue;
        }
        seen = Some(i);
        if let Some((lo, hi)) = q.instance_bounds(i) {
            push_outline(out, lo, hi, 0.01 * s, 0.006 * s);
        }
    }
    if let Some(arc) = &update.arc {
        push_arc(out, arc, s);
    }
    push_measure(out, it, input);
    out.truncate(MAX_BOXES);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interact::locomotion::Origin;
    use crate::interact::raycast::Hit;
    use crate::interact::{HandInput, Settings};
    use crate::scene::{shapes, Instance, Material, Mesh, Scene};
    use glam::DAffine3;

    /// One 2 × 2 × 2 m box centred at (10, 1, −3).
    fn one_box() -> Scene {
        let mut scene = Scene::default();
        scene.materials.push(Material::default());
        scene.primitives.push(shapes::cuboid([1.0, 1.0, 1.0], 0));
        scene.meshes.push(Mesh {
            name: "box".into(),
            primitives: vec![0],
        });
        scene.instances.push(Instance {
            mesh: 0,
            transform: DAffine3::from_translation(DVec3::new(10.0, 1.0, -3.0)),
        });
        scene
    }

    fn hand(at: DVec3) -> HandInput {
        let p = Pose {
            position: at,
            ..Pose::default()
        };
        HandInput {
            aim: Some(p),
            grip: Some(p),
            ..HandInput::default()
        }
    }

    #[test]
    fn the_ray_runs_from_the_aim_pose_to_the_hit() {
        let it = Interaction::new(
            Origin {
                position: DVec3::new(10.0, 0.0, 0.0),
                yaw: 0.0,
                scale: 1.0,
            },
            Settings::default(),
        );
        let input = FrameInput {
            hands: [HandInput::default(), hand(DVec3::new(0.2, 1.0, -0.3))],
            ..FrameInput::default()
        };
        let mut update = Update::default();
        update.hover[1] = Some(Hit {
            instance: 0,
            primitive: 0,
            t: 2.0,
            point: DVec3::new(10.2, 1.0, -2.3),
            normal: DVec3::Z,
        });
        let scene = one_box();
        let q = SceneQuery::new(&scene);
        let mut out = Vec::new();
        build(&it, &input, &update, &q, &mut out);
        let rays: Vec<&OverlayBox> = out.iter().filter(|b| b.color == RAY_COLOR).collect();
        assert_eq!(rays.len(), 1);
        let r = rays[0];
        let (a, b) = (r.center - r.axes[2], r.center + r.axes[2]);
        assert!(a.distance(DVec3::new(10.2, 1.0, -0.3)) < 1e-9, "{a}");
        assert!(b.distance(DVec3::new(10.2, 1.0, -2.3)) < 1e-9, "{b}");
        assert!((r.axes[0].length() - RAY_THICKNESS_M / 2.0).abs() < 1e-12);
        // Body and ring of the right controller only.
        assert_eq!(out.iter().filter(|b| b.color == BODY_COLOR).count(), 1);
        // The box the ray points at is outlined: twelve edges on its
        // bounds grown by a centimetre.
        let edges: Vec<&OverlayBox> = out.iter().filter(|b| b.color == HIGHLIGHT_COLOR).collect();
        assert_eq!(edges.len(), 12);
        for e in edges {
            for end in [e.center - e.axes[2], e.center + e.axes[2]] {
                let off = (end - DVec3::new(10.0, 1.0, -3.0)).abs();
                assert!(
                    (off - DVec3::splat(1.01)).abs().max_element() < 1e-9,
                    "{end}"
                );
            }
        }
        // No hands, no boxes.
        build(
            &it,
            &FrameInput::default(),
            &Update::default(),
            &q,
            &mut out,
        );
        assert!(out.is_empty());
    }

    #[test]
    fn a_measurement_shows_its_points_line_and_digits() {
        let mut it = Interaction::new(Origin::from_pose(&Pose::default()), Settings::default());
        it.measure.press(DVec3::new(-0.175, 0.0, -2.0));
        it.measure.press(DVec3::new(0.175, 0.0, -2.0));
        let scene = one_box();
        let mut out = Vec::new();
        build(
            &it,
            &FrameInput::default(),
            &Update::default(),
            &SceneQuery::new(&scene),
            &mut out,
        );
        let measure = out.iter().filter(|b| b.color == MEASURE_COLOR).count();
        assert_eq!(measure, 3, "two points and the line");
        // "0.350 m": 6 + 5 + 5 + 6 segments, the point and the m's 4 bars.
        let label = out.iter().filter(|b| b.color == LABEL_COLOR).count();
        assert_eq!(label, 6 + 1 + 5 + 5 + 6 + 4);
        // Upright and facing the head at the origin: every bar lies in the
        // plane z = −2 (the head looks straight at it).
        for b in out.iter().filter(|b| b.color == LABEL_COLOR) {
            assert!((b.center.z + 2.0).abs() < 1e-9, "{b:?}");
        }
    }

    #[test]
    fn overlays_never_exceed_the_uniform_room() {
        let mut it = Interaction::new(Origin::from_pose(&Pose::default()), Settings::default());
        it.measure.press(DVec3::ZERO);
        it.measure.press(DVec3::splat(1234.5678));
        let input = FrameInput {
            hands: [hand(DVec3::X), hand(DVec3::NEG_X)],
            ..FrameInput::default()
        };
        let update = Update {
            arc: Some(crate::interact::locomotion::ArcResult {
                points: (0..500)
                    .map(|i| DVec3::new(0.0, 0.0, -(i as f64)))
                    .collect(),
                hit: None,
                target: Some(DVec3::new(0.0, 0.0, -499.0)),
            }),
            ..Update::default()
        };
        let scene = one_box();
        let mut out = Vec::new();
        build(&it, &input, &update, &SceneQuery::new(&scene), &mut out);
        assert!(out.len() <= MAX_BOXES);
        let arc = out.iter().filter(|b| b.color == ARC_OK_COLOR).count();
        assert!((40..=ARC_SEGMENTS + 2).contains(&arc), "{arc}");
    }
}
