//! Multi-resolution foveated rendering's inset: the pixel rectangle of an
//! eye image that is rendered at full density, the rest coming from a wide
//! view over the whole FOV at a reduced scale.
//!
//! The inset covers ±θ of view angle around the gaze point, as tangents.
//! An eye image maps the tangent range [tan_l, tan_r] linearly onto NDC
//! [−1, 1] (the projection is linear in the tangents), so a tangent
//! half-width tan θ is an NDC half-width of 2 tan θ / (tan_r − tan_l) (and
//! likewise vertically). With the gaze point g in NDC (x right, y down, as
//! `gaze=X:Y` and the foveation rings take it), the inset is the NDC
//! rectangle g ± h, snapped outward to whole pixels and clipped to the
//! image. Both eyes share one rectangle (the larger of their half-sizes):
//! under multiview the render area is one rectangle for both views.
//! This follows the two-view foveated layout of Varjo's bionic display and
//! OpenXR's `XR_VARJO_quad_views` (a context view over the FOV and a focus
//! view at full density), composited here instead of submitted.

use super::Fov;

/// The default half-angle of the inset, degrees: 20° covers the fovea and
/// the parafovea (about ±9°) with room for the eye to rotate while the
/// gaze point stays fixed (Guenter et al., "Foveated 3D Graphics",
/// SIGGRAPH Asia 2012, use an inner layer of about this size).
pub const DEFAULT_HALF_ANGLE_DEG: f64 = 20.0;
/// The default scale per axis of the wide view.
pub const DEFAULT_WIDE_SCALE: f64 = 0.5;
/// The seam's feather width, pixels of the eye image: the inset fades into
/// the wide view over this band inside its edge.
pub const FEATHER_PX: f32 = 8.0;

/// A pixel rectangle: columns x0..x1, rows y0..y1 (ends exclusive).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelRect {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// Whether pixel (x, y) lies inside.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// The whole pixels of an axis of `size` pixels that cover the span
/// between pixel coordinates `a` and `b` (in either order): snapped
/// outward, clipped to the image, never empty.
fn outward(a: f64, b: f64, size: u32) -> (u32, u32) {
    let s = size as f64;
    let lo = a.min(b).floor().clamp(0.0, s - 1.0) as u32;
    let hi = a.max(b).ceil().clamp(lo as f64 + 1.0, s) as u32;
    (lo, hi)
}

/// The inset of eyes with `fovs` in images of `width`×`height` pixels
/// around `gaze` (NDC, clamped to the image) at half-angle
/// `half_angle_deg`. At least one pixel; the whole image when the angle
/// covers it.
pub fn inset_rect(
    fovs: &[Fov],
    gaze: [f32; 2],
    half_angle_deg: f64,
    width: u32,
    height: u32,
) -> PixelRect {
    let t = half_angle_deg.to_radians().tan().max(0.0);
    let (mut hx, mut hy) = (0.0f64, 0.0f64);
    for f in fovs {
        // Widths in tangents: the FOV's fields are angles.
        let [tl, tr, tu, td] = f.tangents();
        let (w, h) = (tr - tl, tu - td);
        if w > 0.0 && h > 0.0 {
            hx = hx.max(2.0 * t / w);
            hy = hy.max(2.0 * t / h);
        }
    }
    let g = [
        (gaze[0] as f64).clamp(-1.0, 1.0),
        (gaze[1] as f64).clamp(-1.0, 1.0),
    ];
    // NDC −1..1 over 0..size pixels; outward to whole pixels.
    let span = |c: f64, h: f64, size: u32| {
        let px = |n: f64| (n + 1.0) * 0.5 * size as f64;
        outward(px(c - h), px(c + h), size)
    };
    let (x0, x1) = span(g[0], hx, width.max(1));
    let (y0, y1) = span(g[1], hy, height.max(1));
    PixelRect { x0, y0, x1, y1 }
}

/// The inset of eyes with `fovs` whose full-density views the runtime
/// gives (`focus`, one per eye: `XR_VARJO_quad_views`' focus views, in
/// the eye's pose), in images of `width`×`height` pixels: per eye the
/// pixels the focus tangents cover (the eye image is linear in the
/// tangents, see [`rect_tangents`]), snapped outward to whole pixels and
/// clipped to the image, and the union over the eyes (one rectangle for
/// both, as [`inset_rect`]). At least one pixel.
pub fn focus_rect(fovs: &[Fov], focus: &[Fov], width: u32, height: u32) -> PixelRect {
    let (w, h) = (width.max(1), height.max(1));
    let mut out: Option<PixelRect> = None;
    for (eye, f) in fovs.iter().zip(focus) {
        let [tl, tr, tu, td] = eye.tangents();
        let [fl, fr, fu, fd] = f.tangents();
        if tr - tl <= 0.0 || tu - td <= 0.0 {
            continue;
        }
        let col = |t: f64| (t - tl) / (tr - tl) * w as f64;
        let row = |t: f64| (tu - t) / (tu - td) * h as f64;
        let (x0, x1) = outward(col(fl), col(fr), w);
        let (y0, y1) = outward(row(fu), row(fd), h);
        let r = PixelRect { x0, y0, x1, y1 };
        out = Some(out.map_or(r, |o| bounding(&o, &r)));
    }
    out.unwrap_or(PixelRect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
    })
}

/// The eye image size at which the focus view `focus` (in the eye `eye`,
/// same pose) covers at least its recommended `focus_px` (width, height)
/// pixels: the eye image is linear in the tangents, so a focus view
/// spanning a fraction f of the eye's tangent range per axis needs
/// ceil(focus_px / f) pixels on that axis. A runtime whose context views
/// are recommended at a lower density than its focus views (Varjo's) gets
/// its insets at the focus views' density from an eye this size. None
/// when either FOV is empty or the focus view lies outside the eye.
pub fn focus_density_size(eye: &Fov, focus: &Fov, focus_px: (u32, u32)) -> Option<(u32, u32)> {
    let [el, er, eu, ed] = eye.tangents();
    let [fl, fr, fu, fd] = focus.tangents();
    let (ew, eh) = (er - el, eu - ed);
    // The part of the focus view inside the eye.
    let (fw, fh) = (fr.min(er) - fl.max(el), fu.min(eu) - fd.max(ed));
    if !(ew > 0.0 && eh > 0.0 && fw > 0.0 && fh > 0.0) {
        return None;
    }
    // Up to the rounding of FOVs that went through f32 (OpenXR's): a size
    // a hundred-thousandth over a whole number is that number.
    let axis = |px: u32, part: f64, whole: f64| {
        (px as f64 * whole / part * (1.0 - 1e-5))
            .ceil()
            .min(65536.0) as u32
    };
    Some((axis(focus_px.0, fw, ew), axis(focus_px.1, fh, eh)))
}

/// The FOV of the eye `fov`'s pixel rectangle `r` in a `width`×`height`
/// image ([`rect_tangents`] as angles): what a focus view drawn as that
/// part of the eye image is submitted with.
pub fn rect_fov(fov: &Fov, r: &PixelRect, width: u32, height: u32) -> Fov {
    let [l, r, u, d] = rect_tangents(fov, r, width, height);
    Fov {
        left: l.atan(),
        right: r.atan(),
        up: u.atan(),
        down: d.atan(),
    }
}

/// The signed tangents `[left, right, up, down]` of the eye `fov`'s
/// pixel rectangle `r` in an image of `width`×`height` pixels: the
/// projection is linear in the tangents, columns left to right and rows
/// top (`up`) to bottom (`down`), as `projection::reverse_z_infinite`
/// maps them. What the inset's own culling volume is built from: every
/// point whose pixel lies in `r` lies within these tangents.
pub fn rect_tangents(fov: &Fov, r: &PixelRect, width: u32, height: u32) -> [f64; 4] {
    let [tl, tr, tu, td] = fov.tangents();
    let (w, h) = (width.max(1) as f64, height.max(1) as f64);
    let col = |x: u32| tl + x as f64 / w * (tr - tl);
    let row = |y: u32| tu - y as f64 / h * (tu - td);
    [col(r.x0), col(r.x1), row(r.y0), row(r.y1)]
}

/// Four-view multiview (`inset` under multiview where the device draws
/// four views in one scope): every view shares one render area and one
/// viewport, so the wide view is drawn at its own size into a region of an
/// eye-sized layer. The region is `wide` (width, height) pixels, centred
/// on the inset `r` and kept inside the `width`×`height` image, so that
/// when the inset fits in it the render area is the region alone.
pub fn wide_region(r: &PixelRect, width: u32, height: u32, wide: (u32, u32)) -> PixelRect {
    let place = |lo: u32, hi: u32, size: u32, span: u32| {
        let span = span.clamp(1, size.max(1));
        let centre = (lo + hi) / 2;
        let start = centre.saturating_sub(span / 2).min(size.max(1) - span);
        (start, start + span)
    };
    let (x0, x1) = place(r.x0, r.x1, width, wide.0);
    let (y0, y1) = place(r.y0, r.y1, height, wide.1);
    PixelRect { x0, y0, x1, y1 }
}

/// The smallest rectangle holding both `a` and `b` (four-view's render
/// area: the wide region and the inset).
pub fn bounding(a: &PixelRect, b: &PixelRect) -> PixelRect {
    PixelRect {
        x0: a.x0.min(b.x0),
        y0: a.y0.min(b.y0),
        x1: a.x1.max(b.x1),
        y1: a.y1.max(b.y1),
    }
}

/// The FOV of a `width`×`height` layer in which the eye `fov`, drawn at
/// `region`'s size, fills exactly `region`'s pixels: the projection is
/// linear in the tangents, so each pixel spans (tan_r − tan_l) / region
/// width of tangent, and the layer's edges lie `x0` pixels before the
/// region and `width − x1` after it at that step (rows likewise, top
/// (`up`) to bottom). A view with this FOV and the eye's pose puts a point
/// at the pixel the wide view alone would, moved by the region's origin.
pub fn layer_fov(fov: &Fov, region: &PixelRect, width: u32, height: u32) -> Fov {
    let [tl, tr, tu, td] = fov.tangents();
    let sx = (tr - tl) / region.width().max(1) as f64;
    let sy = (tu - td) / region.height().max(1) as f64;
    let left = tl - region.x0 as f64 * sx;
    let up = tu + region.y0 as f64 * sy;
    Fov {
        left: left.atan(),
        right: (left + width as f64 * sx).atan(),
        up: up.atan(),
        down: (up - height as f64 * sy).atan(),
    }
}

/// The inset's weight at the centre of pixel (x, y): 1 deeper than
/// `feather` pixels inside the rectangle, falling linearly to 0 at its
/// edge, 0 outside (what `shaders/inset_composite.comp` computes).
pub fn weight(r: &PixelRect, x: u32, y: u32, feather: f32) -> f32 {
    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
    let d = (px - r.x0 as f32)
        .min(r.x1 as f32 - px)
        .min(py - r.y0 as f32)
        .min(r.y1 as f32 - py);
    (d / feather.max(1e-6)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A symmetric eye whose edges lie at tangent `t`.
    fn sym(t: f64) -> Fov {
        Fov::symmetric(t.atan(), t.atan())
    }

    #[test]
    fn a_centred_inset_of_a_symmetric_eye_is_centred_and_sized_by_the_angle() {
        // ±45° eye (tan 1) at 1000 px: ±20° is tan 0.364 → 364 px wide.
        let r = inset_rect(&[sym(1.0)], [0.0, 0.0], 20.0, 1000, 1000);
        let w = (20f64.to_radians().tan() * 1000.0) as u32;
        assert!(r.width().abs_diff(w) <= 2, "{r:?} vs {w}");
        assert_eq!(r.x0 + r.x1, 1000, "{r:?}");
        assert_eq!(r.y0 + r.y1, 1000);
        assert_eq!(weight(&r, 500, 500, FEATHER_PX), 1.0);
        assert_eq!(weight(&r, r.x0.saturating_sub(1), 500, FEATHER_PX), 0.0);
        assert!(weight(&r, r.x0 + 2, 500, FEATHER_PX) < 1.0);
    }

    #[test]
    fn a_wide_angle_covers_the_image_and_the_gaze_moves_it() {
        let full = inset_rect(&[sym(1.0)], [0.0, 0.0], 80.0, 640, 480);
        assert_eq!(
            full,
            PixelRect {
                x0: 0,
                y0: 0,
                x1: 640,
                y1: 480
            }
        );
        let right = inset_rect(&[sym(1.0)], [0.5, 0.0], 10.0, 640, 480);
        let centre = inset_rect(&[sym(1.0)], [0.0, 0.0], 10.0, 640, 480);
        assert!(right.x0 > centre.x0 + 100 && right.width().abs_diff(centre.width()) <= 1);
        // Off the image: clamped, never empty.
        let off = inset_rect(&[sym(1.0)], [9.0, -9.0], 1.0, 640, 480);
        assert!(off.width() >= 1 && off.height() >= 1 && off.x1 == 640 && off.y0 == 0);
    }

    proptest! {
        /// Against the projection: a direction in the eye lands, through
        /// [`layer_fov`] in the whole layer, at the pixel the eye's own
        /// projection gives it in an image of the region's size, moved by
        /// the region's origin (brute force over directions).
        #[test]
        fn the_layer_fov_puts_the_wide_view_in_its_region(
            l in 0.2..1.4f64, r in 0.2..1.4f64, u in 0.2..1.4f64, d in 0.2..1.4f64,
            gx in -0.9..0.9f32, gy in -0.9..0.9f32, a in 1.0..40.0f64, scale in 0.2..0.9f64,
            tx in -1.0..1.0f64, ty in -1.0..1.0f64,
        ) {
            let fov = Fov { left: -l, right: r, up: u, down: -d };
            let (w, h) = (2016u32, 2240u32);
            let wide = ((w as f64 * scale).round() as u32, (h as f64 * scale).round() as u32);
            let rect = inset_rect(&[fov], [gx, gy], a, w, h);
            let region = wide_region(&rect, w, h, wide);
            let layer = layer_fov(&fov, &region, w, h);
            let [el, er, eu, ed] = fov.tangents();
            let x = el + (tx + 1.0) * 0.5 * (er - el);
            let y = ed + (ty + 1.0) * 0.5 * (eu - ed);
            let pixel = |f: &Fov, pw: u32, ph: u32| {
                let p = crate::view::projection::reverse_z_infinite(f, 0.1)
                    * glam::DVec4::new(x, y, -1.0, 1.0);
                ((p.x / p.w + 1.0) * 0.5 * pw as f64, (p.y / p.w + 1.0) * 0.5 * ph as f64)
            };
            let (px, py) = pixel(&fov, wide.0, wide.1);
            let (qx, qy) = pixel(&layer, w, h);
            prop_assert!((qx - (region.x0 as f64 + px)).abs() < 1e-6, "{qx} vs {} + {px}", region.x0);
            prop_assert!((qy - (region.y0 as f64 + py)).abs() < 1e-6, "{qy} vs {} + {py}", region.y0);
        }

        /// The region has the wide view's size, lies in the image, and
        /// holds the inset whenever the inset is no larger (then the
        /// render area, [`bounding`], is the region itself); otherwise
        /// the bounding box holds both.
        #[test]
        fn the_wide_region_holds_the_inset_when_it_fits(
            x0 in 0u32..300, y0 in 0u32..300, rw in 1u32..300, rh in 1u32..300,
            ww in 1u32..300, wh in 1u32..300, w in 300u32..700, h in 300u32..700,
        ) {
            let rect = PixelRect { x0, y0, x1: (x0 + rw).min(w), y1: (y0 + rh).min(h) };
            let region = wide_region(&rect, w, h, (ww, wh));
            prop_assert_eq!((region.width(), region.height()), (ww, wh));
            prop_assert!(region.x1 <= w && region.y1 <= h);
            let area = bounding(&region, &rect);
            if rect.width() <= ww && rect.height() <= wh {
                prop_assert_eq!(area, region, "{:?} does not hold {:?}", region, rect);
            }
            for (x, y) in [(rect.x0, rect.y0), (rect.x1 - 1, rect.y1 - 1), (region.x0, region.y1 - 1)] {
                prop_assert!(area.contains(x, y));
            }
        }

        /// The focus rectangle holds every pixel whose centre lies in an
        /// eye's focus tangents, and is the smallest such: each edge
        /// pulled in by a pixel leaves out some eye's focus, unless the
        /// edge is the image's own (brute force over pixel centres);
        /// its tangents in each eye hold that eye's focus.
        #[test]
        fn the_focus_rectangle_is_the_least_holding_both_focus_views(
            l in 0.3..1.5f64, r in 0.3..1.5f64, u in 0.3..1.5f64, d in 0.3..1.5f64,
            sh in -0.1..0.1f64, k in 0.05..1.3f64, fx in -0.1..0.1f64, fy in -0.1..0.1f64,
            w in 32u32..200, h in 32u32..200,
        ) {
            // Tangents of the eyes (the right one shifted by sh) and of
            // their focus views (k times the eye's, moved by fx, fy): each
            // focus overlaps its eye by more than a pixel.
            let eye = |s: f64| [-l + s, r + s, u, -d];
            let eyes_t = [eye(0.0), eye(sh)];
            let focus_t: Vec<[f64; 4]> = eyes_t
                .iter()
                .map(|t| [t[0] * k + fx, t[1] * k + fx, t[2] * k + fy, t[3] * k + fy])
                .collect();
            let fov = |t: &[f64; 4]| Fov { left: t[0].atan(), right: t[1].atan(), up: t[2].atan(), down: t[3].atan() };
            let fovs: Vec<Fov> = eyes_t.iter().map(fov).collect();
            let focus: Vec<Fov> = focus_t.iter().map(fov).collect();
            let rect = focus_rect(&fovs, &focus, w, h);
            prop_assert!(rect.x0 < rect.x1 && rect.x1 <= w && rect.y0 < rect.y1 && rect.y1 <= h);
            // Pixel centres in tangents, per eye.
            let covered = |e: usize, x: u32, y: u32| {
                let [tl, tr, tu, td] = eyes_t[e];
                let [gl, gr, gu, gd] = focus_t[e];
                let cx = tl + (x as f64 + 0.5) / w as f64 * (tr - tl);
                let cy = tu - (y as f64 + 0.5) / h as f64 * (tu - td);
                cx >= gl && cx <= gr && cy <= gu && cy >= gd
            };
            let mut any = PixelRect { x0: w, y0: h, x1: 0, y1: 0 };
            for e in 0..2 {
                for y in 0..h {
                    for x in 0..w {
                        if covered(e, x, y) {
                            prop_assert!(rect.contains(x, y), "pixel {x},{y} of eye {e} outside {rect:?}");
                            any = PixelRect { x0: any.x0.min(x), y0: any.y0.min(y), x1: any.x1.max(x + 1), y1: any.y1.max(y + 1) };
                        }
                    }
                }
            }
            // Least: no more than a pixel beyond the covered centres on
            // each side (a focus edge may cut a pixel short of its centre).
            if any.x0 < any.x1 {
                prop_assert!(rect.x0 + 1 >= any.x0 && rect.x1 <= any.x1 + 1, "{rect:?} wider than {any:?}");
                prop_assert!(rect.y0 + 1 >= any.y0 && rect.y1 <= any.y1 + 1, "{rect:?} taller than {any:?}");
            }
            for e in 0..2 {
                let t = rect_tangents(&fovs[e], &rect, w, h);
                let [tl, tr, tu, td] = eyes_t[e];
                let [gl, gr, gu, gd] = focus_t[e];
                let eps = 1e-9;
                prop_assert!(t[0] <= gl.max(tl) + eps && t[1] >= gr.min(tr) - eps, "{t:?} vs {:?}", focus_t[e]);
                prop_assert!(t[2] >= gu.min(tu) - eps && t[3] <= gd.max(td) + eps, "{t:?} vs {:?}", focus_t[e]);
                let back = rect_fov(&fovs[e], &rect, w, h).tangents();
                for i in 0..4 {
                    prop_assert!((back[i] - t[i]).abs() < 1e-9);
                }
            }
        }

        /// At the size [`focus_density_size`] gives, the focus rectangle
        /// holds at least the focus view's recommended pixels on each axis
        /// and at most a pixel more than the eye's pixels per focus pixel
        /// allow (brute force through [`focus_rect`]).
        #[test]
        fn an_eye_of_the_focus_density_size_gives_the_focus_its_pixels(
            l in 0.3..1.5f64, r in 0.3..1.5f64, u in 0.3..1.5f64, d in 0.3..1.5f64,
            k in 0.1..0.9f64, fx in -0.1..0.1f64, pw in 16u32..400, ph in 16u32..400,
        ) {
            let eye = Fov { left: -l.atan(), right: r.atan(), up: u.atan(), down: -d.atan() };
            let t = [-l * k + fx, r * k + fx, u * k, -d * k];
            let focus = Fov { left: t[0].atan(), right: t[1].atan(), up: t[2].atan(), down: t[3].atan() };
            let (w, h) = focus_density_size(&eye, &focus, (pw, ph)).unwrap();
            let rect = focus_rect(&[eye], &[focus], w, h);
            // At least the focus pixels (up to the f32 rounding allowance).
            prop_assert!(rect.width() + 1 >= pw && rect.height() + 1 >= ph, "{rect:?} for {pw}x{ph} in {w}x{h}");
            prop_assert!(rect.width() <= pw + 3 && rect.height() <= ph + 3, "{rect:?} for {pw}x{ph} in {w}x{h}");
            // Empty or outside: none.
            let outside = Fov { left: 1.4, right: 1.45, up: 0.1, down: -0.1 };
            prop_assert!(focus_density_size(&eye, &outside, (pw, ph)).is_none() || r.atan() > 1.4);
        }

        /// Against the projection itself: a direction projects into the
        /// rectangle's pixels exactly when its tangents lie within
        /// [`rect_tangents`] (away from the edges by a millionth).
        #[test]
        fn the_rectangle_tangents_hold_what_projects_into_it(
            l in 0.2..1.4f64, r in 0.2..1.4f64, u in 0.2..1.4f64, d in 0.2..1.4f64,
            gx in -0.9..0.9f32, gy in -0.9..0.9f32, a in 1.0..40.0f64,
            tx in -1.0..1.0f64, ty in -1.0..1.0f64,
        ) {
            let fov = Fov { left: -l, right: r, up: u, down: -d };
            let (w, h) = (320, 240);
            let rect = inset_rect(&[fov], [gx, gy], a, w, h);
            let t = rect_tangents(&fov, &rect, w, h);
            // A direction anywhere in the eye: tangents by (tx, ty) across it.
            let [el, er, eu, ed] = fov.tangents();
            let x = el + (tx + 1.0) * 0.5 * (er - el);
            let y = ed + (ty + 1.0) * 0.5 * (eu - ed);
            let p = crate::view::projection::reverse_z_infinite(&fov, 0.1)
                * glam::DVec4::new(x, y, -1.0, 1.0);
            let (nx, ny) = (p.x / p.w, p.y / p.w);
            let px = (nx + 1.0) * 0.5 * w as f64;
            let py = (ny + 1.0) * 0.5 * h as f64;
            let inside_px = px >= rect.x0 as f64 && px < rect.x1 as f64
                && py >= rect.y0 as f64 && py < rect.y1 as f64;
            let inside_t = x >= t[0] && x <= t[1] && y <= t[2] && y >= t[3];
            let near_edge = [x - t[0], t[1] - x, t[2] - y, y - t[3]]
                .iter()
                .any(|e| e.abs() < 1e-6);
            prop_assert!(near_edge || inside_px == inside_t, "{rect:?} {t:?} ({x}, {y}) at ({px}, {py})");
            prop_assert!(t[0] >= el - 1e-12 && t[1] <= er + 1e-12 && t[2] <= eu + 1e-12 && t[3] >= ed - 1e-12);
        }

        /// The rectangle stays in the image, holds the gaze pixel, grows
        /// with the angle, and covers every pixel whose centre is within
        /// the angle's tangent range of the gaze and none more than a pixel
        /// and a half beyond it (brute force).
        #[test]
        fn inside_the_image_around_the_gaze_and_covering_the_angle(
            l in 0.3..1.5f64, r in 0.3..1.5f64, u in 0.3..1.5f64, d in 0.3..1.5f64,
            gx in -0.9..0.9f32, gy in -0.9..0.9f32, a in 1.0..40.0f64,
            w in 8u32..400, h in 8u32..400,
        ) {
            // l, r, u, d are the edges' tangents; the FOV holds angles.
            let fov = Fov { left: -l.atan(), right: r.atan(), up: u.atan(), down: -d.atan() };
            let rect = inset_rect(&[fov], [gx, gy], a, w, h);
            prop_assert!(rect.x0 < rect.x1 && rect.x1 <= w && rect.y0 < rect.y1 && rect.y1 <= h);
            let gpx = (((gx as f64 + 1.0) * 0.5 * w as f64) as u32).min(w - 1);
            let gpy = (((gy as f64 + 1.0) * 0.5 * h as f64) as u32).min(h - 1);
            prop_assert!(rect.contains(gpx, gpy), "{rect:?} misses the gaze pixel {gpx},{gpy}");
            let bigger = inset_rect(&[fov], [gx, gy], a + 5.0, w, h);
            prop_assert!(bigger.x0 <= rect.x0 && bigger.x1 >= rect.x1);
            let t = a.to_radians().tan();
            // Tangent of pixel centre x: linear from left to right.
            let tan_x = |x: u32| -l + (x as f64 + 0.5) / w as f64 * (l + r);
            let gaze_tan = -l + (gx as f64 + 1.0) * 0.5 * (l + r);
            // And no wider: a column more than a pixel and a half beyond
            // the angle is left out.
            let pixel = (l + r) / w as f64;
            for x in 0..w {
                let off = (tan_x(x) - gaze_tan).abs();
                if off <= t * 0.999 {
                    prop_assert!(rect.x0 <= x && x < rect.x1, "column {x} within the angle");
                }
                if off > t + 1.5 * pixel {
                    prop_assert!(!(rect.x0 <= x && x < rect.x1), "column {x} beyond the angle in {rect:?}");
                }
            }
        }
    }
}
