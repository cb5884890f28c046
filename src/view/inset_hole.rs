//! The wide views' hole: what the wide views of multi-resolution foveated
//! rendering need not draw, because the composite never shows it.
//!
//! The composite (`shaders/inset_composite.comp`, the weight of
//! [`super::inset::weight`]) gives an eye pixel whose centre lies at least
//! `feather` pixels inside the inset rectangle the inset alone: the weight
//! is 1 and the shader then selects the inset (no blend arithmetic). Every
//! other pixel reads the wide view at its centre scaled by s = wide size /
//! eye size per axis, from the texels whose centres lie within the read's
//! **reach** k of that point ([`read_reach`]: k = 1 for the bilinear read,
//! 2 for the Catmull-Rom read's 4×4 texels; `inset-taa` adds the reach of
//! the pass that made those texels, 2.5: its Catmull-Rom read of the
//! current frame at a jittered centre, and its 3×3 box), whose areas lie
//! within k + 0.5 texels of it, that is within (k + 0.5) / s eye pixels.
//! A pixel that reads the wide view has its centre less than `feather`
//! pixels inside the rectangle, so nothing of the wide view it reads lies
//! deeper than feather + (k + 0.5) / s. The rectangle shrunk by that,
//! rounded up, and by one pixel more for the rasterizer's fixed-point
//! rounding, is the **core** ([`core_rect`]): a
//! sample of the wide view inside it (at any MSAA position: samples lie in
//! their pixel's area) never reaches the eye image.
//!
//! The projection is linear in the tangents, so the core's tangents
//! ([`super::inset::rect_tangents`]) give a pyramid from each eye whose
//! four side planes hold exactly the directions that project into the core
//! (a point inside all four lies in front of the eye: left and right hold
//! tan_l·s ≤ x ≤ tan_r·s at depth s, which needs s ≥ 0). A triangle
//! covers only samples inside its projection, so an instance whose
//! bounding sphere lies inside both eyes' pyramids
//! ([`crate::view::frustum::PlaneSet::contains_sphere`], [`core_volume`];
//! with `gpu-cull` the cull shader tests the boxes against the side planes)
//! covers no wide sample the composite reads, and the wide views skip it:
//! the eye image is the same, and the wide views' vertex and raster work
//! for everything wholly under the inset is saved. The inset views still
//! draw it. This needs the composite: with the four views submitted to
//! the runtime (`XR_VARJO_quad_views`) the runtime shows the wide views
//! as it likes, so they keep everything.

use super::frustum::Frustum;
use super::inset::{rect_tangents, PixelRect};
use super::View;

/// How far, in wide texels, from the point the composite reads the centres
/// of the texels that can reach its pixel lie: 1 for the bilinear read, 2
/// for the Catmull-Rom read (`catmull_rom`), and with `taa` 2.5 more (the
/// accumulation pass reads the current frame's 4×4 texels around a centre
/// moved by a jitter of at most half a texel, and its 3×3 neighbourhood).
pub fn read_reach(catmull_rom: bool, taa: bool) -> f64 {
    let composite = if catmull_rom { 2.0 } else { 1.0 };
    composite + if taa { 2.5 } else { 0.0 }
}

/// The part of the inset `r` (pixels of `eye` = (width, height) eye
/// images) where the composite reads no wide-view sample, for wide views of
/// `wide` = (width, height) pixels, a seam `feather` pixels wide and reads
/// of `reach` texels ([`read_reach`]): `r` shrunk by
/// ceil(feather + (reach + 0.5) × eye / wide) + 1 pixels on each side (see
/// the module). None when nothing is left, or a size is zero.
pub fn core_rect(
    r: &PixelRect,
    eye: (u32, u32),
    wide: (u32, u32),
    feather: f32,
    reach: f64,
) -> Option<PixelRect> {
    let margin = |e: u32, w: u32| -> Option<u32> {
        if e == 0 || w == 0 || !feather.is_finite() || !reach.is_finite() {
            return None;
        }
        let m =
            (feather.max(0.0) as f64 + (reach.max(0.0) + 0.5) * e as f64 / w as f64).ceil() + 1.0;
        (m < u32::MAX as f64).then_some(m as u32)
    };
    let (mx, my) = (margin(eye.0, wide.0)?, margin(eye.1, wide.1)?);
    let (x0, x1) = (r.x0.checked_add(mx)?, r.x1.checked_sub(mx)?);
    let (y0, y1) = (r.y0.checked_add(my)?, r.y1.checked_sub(my)?);
    (x0 < x1 && y0 < y1).then_some(PixelRect { x0, y0, x1, y1 })
}

/// The volume of `view` through the pixels of `core` in its
/// `width`×`height` image, between `near` and the draw distance `far`
/// (when given): a sphere that its planes'
/// [`crate::view::frustum::PlaneSet::contains_sphere`] holds projects
/// inside `core` (and so does a box inside its four side planes alone).
/// None for a view whose pose or FOV cannot make a volume.
pub fn core_volume(
    view: &View,
    core: &PixelRect,
    width: u32,
    height: u32,
    near: f64,
    far: Option<f64>,
) -> Option<Frustum> {
    let t = rect_tangents(&view.fov, core, width, height);
    Frustum::from_tangents(&view.pose, t, near, far).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::inset::{weight, FEATHER_PX};
    use crate::view::projection::{reverse_z_infinite, view_relative};
    use crate::view::{Fov, Pose};
    use glam::{DQuat, DVec3};
    use proptest::prelude::*;

    /// The wide texels (column or row indices) whose values can reach eye
    /// pixel `p` on one axis through reads of `reach` texels: the centre
    /// the composite reads at is q = clamp((p + 0.5) / eye × wide, 0.5,
    /// wide − 0.5) (as the shader computes it), and every texel whose
    /// centre lies less than `reach` from q (clamped to the image: clamp
    /// to edge) — the taps of nonzero weight: the bilinear and
    /// Catmull-Rom weights vanish at distance 1 and 2, so at a q on a
    /// texel centre (as the clamp puts it at the image's edge) the read
    /// is that texel alone.
    fn taps(p: u32, eye: u32, wide: u32, reach: f64) -> Vec<u32> {
        let q = ((p as f64 + 0.5) / eye as f64 * wide as f64).clamp(0.5, wide as f64 - 0.5);
        let lo = (q - 0.5 - reach).floor().max(0.0) as u32;
        let hi = (q - 0.5 + reach).ceil() as u32;
        (lo..=hi)
            .filter(|&i| (i as f64 + 0.5 - q).abs() < reach)
            .map(|i| i.min(wide - 1))
            .collect()
    }

    proptest! {
        /// Brute force over every eye pixel: a pixel the composite gives
        /// any of the wide view (weight below 1) reads only wide texels
        /// whose areas, in eye pixels, lie outside the core.
        #[test]
        fn no_pixel_that_reads_the_wide_view_reads_under_the_core(
            ew in 8u32..160, eh in 8u32..160, sx in 0.1f64..1.0, sy in 0.1f64..1.0,
            fx in 0.0f64..1.0, fy in 0.0f64..1.0, fw in 0.0f64..1.0, fh in 0.0f64..1.0,
            feather in 0.0f32..12.0, catmull_rom: bool, taa: bool,
        ) {
            let reach = read_reach(catmull_rom, taa);
            let wide = (((ew as f64 * sx).round() as u32).max(1), ((eh as f64 * sy).round() as u32).max(1));
            let x0 = (fx * ew as f64) as u32 % ew;
            let y0 = (fy * eh as f64) as u32 % eh;
            let r = PixelRect {
                x0, y0,
                x1: x0 + 1 + ((ew - x0 - 1) as f64 * fw) as u32,
                y1: y0 + 1 + ((eh - y0 - 1) as f64 * fh) as u32,
            };
            let Some(core) = core_rect(&r, (ew, eh), wide, feather, reach) else {
                return Ok(());
            };
            prop_assert!(r.x0 < core.x0 && core.x1 < r.x1 && r.y0 < core.y0 && core.y1 < r.y1);
            // A texel's area in eye pixels on one axis.
            let area = |i: u32, eye: u32, w: u32| (i as f64 * eye as f64 / w as f64, (i + 1) as f64 * eye as f64 / w as f64);
            for y in 0..eh {
                for x in 0..ew {
                    if weight(&r, x, y, feather) >= 1.0 {
                        continue;
                    }
                    for &tx in &taps(x, ew, wide.0, reach) {
                        for &ty in &taps(y, eh, wide.1, reach) {
                            let (ax0, ax1) = area(tx, ew, wide.0);
                            let (ay0, ay1) = area(ty, eh, wide.1);
                            let overlaps = ax1 > core.x0 as f64 && ax0 < core.x1 as f64
                                && ay1 > core.y0 as f64 && ay0 < core.y1 as f64;
                            prop_assert!(!overlaps, "pixel ({x}, {y}) reads texel ({tx}, {ty}) under {core:?} of {r:?}");
                        }
                    }
                }
            }
        }

        /// Against the projection matrix: every point of a sphere the core
        /// volume contains projects inside the core, for asymmetric FOVs
        /// and any head orientation; and a sphere at the core's centre ray,
        /// small enough, is contained (the test is not empty).
        #[test]
        fn a_contained_sphere_projects_inside_the_core(
            l in 0.3f64..1.2, rt in 0.3f64..1.2, u in 0.3f64..1.2, d in 0.3f64..1.2,
            yaw in -3.0f64..3.0, pitch in -1.5f64..1.5, roll in -3.0f64..3.0,
            cx0 in 0u32..200, cy0 in 0u32..200, cw in 20u32..200, ch in 20u32..200,
            tx in -1.5f64..1.5, ty in -1.5f64..1.5, dist in 0.05f64..50.0, radius in 0.0f64..5.0,
        ) {
            let (w, h) = (400u32, 400u32);
            let fov = Fov { left: -l.atan(), right: rt.atan(), up: u.atan(), down: -d.atan() };
            let pose = Pose {
                position: DVec3::new(3.0, -2.0, 7.0),
                orientation: DQuat::from_euler(glam::EulerRot::YXZ, yaw, pitch, roll),
            };
            let view = View { pose, fov };
            let core = PixelRect { x0: cx0, y0: cy0, x1: (cx0 + cw).min(w), y1: (cy0 + ch).min(h) };
            let near = 0.05;
            let vol = core_volume(&view, &core, w, h, near, Some(100.0)).unwrap().planes;
            let m = reverse_z_infinite(&fov, near) * view_relative(&pose, pose.position);
            let pixel = |p: DVec3| {
                let c = m * (p - pose.position).extend(1.0);
                ((c.x / c.w + 1.0) * 0.5 * w as f64, (c.y / c.w + 1.0) * 0.5 * h as f64, c.w)
            };
            // A centre along a direction of the view (tangents tx, ty).
            let dir = pose.orientation * DVec3::new(tx, ty, -1.0).normalize();
            let centre = pose.position + dir * dist;
            if vol.contains_sphere(centre, radius) {
                for i in 0..64 {
                    for j in 0..=16 {
                        let (a, b) = (i as f64 / 64.0 * std::f64::consts::TAU, j as f64 / 16.0 * std::f64::consts::PI);
                        let p = centre + radius * DVec3::new(b.sin() * a.cos(), b.sin() * a.sin(), b.cos());
                        let (px, py, cw) = pixel(p);
                        prop_assert!(cw > 0.0, "a point of a contained sphere is behind the eye");
                        prop_assert!(px >= core.x0 as f64 - 1e-6 && px <= core.x1 as f64 + 1e-6
                            && py >= core.y0 as f64 - 1e-6 && py <= core.y1 as f64 + 1e-6,
                            "({px}, {py}) of a contained sphere lies outside {core:?}");
                    }
                }
            }
            // The core's centre ray at 10 m: a sphere of 1 mm is inside.
            let [cl, cr, cu, cd] = rect_tangents(&fov, &core, w, h);
            let mid = pose.orientation * DVec3::new((cl + cr) / 2.0, (cu + cd) / 2.0, -1.0).normalize();
            prop_assert!(vol.contains_sphere(pose.position + mid * 10.0, 1e-3));
        }
    }

    #[test]
    fn the_core_shrinks_by_the_feather_and_the_reads_reach() {
        let r = PixelRect {
            x0: 100,
            y0: 50,
            x1: 300,
            y1: 250,
        };
        // F = 0.5, bilinear: 8 + 1.5 x 2 = 11, + 1.
        let bilinear = read_reach(false, false);
        let c = core_rect(&r, (1000, 1000), (500, 500), FEATHER_PX, bilinear).unwrap();
        assert_eq!(
            c,
            PixelRect {
                x0: 112,
                y0: 62,
                x1: 288,
                y1: 238
            }
        );
        // F = 0.25 horizontally: 8 + 6 + 1.
        let c = core_rect(&r, (1000, 1000), (250, 500), FEATHER_PX, bilinear).unwrap();
        assert_eq!((c.x0, c.x1, c.y0, c.y1), (115, 285, 62, 238));
        // Catmull-Rom: 8 + 2.5 x 2 + 1 = 14; with inset-taa 8 + 5 x 2 + 1.
        let c = core_rect(
            &r,
            (1000, 1000),
            (500, 500),
            FEATHER_PX,
            read_reach(true, false),
        );
        assert_eq!(c.map(|c| (c.x0, c.x1)), Some((114, 286)));
        let c = core_rect(
            &r,
            (1000, 1000),
            (500, 500),
            FEATHER_PX,
            read_reach(true, true),
        );
        assert_eq!(c.map(|c| (c.x0, c.x1)), Some((119, 281)));
        // Too small an inset leaves no core; zero sizes none either.
        let small = PixelRect {
            x0: 10,
            y0: 10,
            x1: 30,
            y1: 30,
        };
        assert_eq!(
            core_rect(&small, (1000, 1000), (500, 500), FEATHER_PX, bilinear),
            None
        );
        assert_eq!(
            core_rect(&r, (1000, 1000), (0, 500), FEATHER_PX, bilinear),
            None
        );
        assert_eq!(
            core_rect(&r, (1000, 1000), (500, 500), f32::NAN, bilinear),
            None
        );
        assert_eq!(
            core_rect(&r, (1000, 1000), (500, 500), FEATHER_PX, f64::NAN),
            None
        );
    }

    #[test]
    fn a_sphere_straddling_the_cores_edge_or_the_near_plane_is_not_contained() {
        let view = View {
            pose: Pose::default(),
            fov: Fov::symmetric(1f64.atan(), 1f64.atan()),
        };
        // Core = the middle half of a ±45° eye: tangents ±0.5.
        let core = PixelRect {
            x0: 100,
            y0: 100,
            x1: 300,
            y1: 300,
        };
        let vol = core_volume(&view, &core, 400, 400, 0.1, None)
            .unwrap()
            .planes;
        assert!(vol.contains_sphere(DVec3::new(0.0, 0.0, -10.0), 1.0));
        // At 10 m the core's edge is at x = 5: a sphere reaching past it.
        assert!(!vol.contains_sphere(DVec3::new(4.5, 0.0, -10.0), 1.0));
        // Through the near plane.
        assert!(!vol.contains_sphere(DVec3::new(0.0, 0.0, -0.15), 0.1));
        // Behind the eye.
        assert!(!vol.contains_sphere(DVec3::new(0.0, 0.0, 10.0), 0.01));
    }
}
