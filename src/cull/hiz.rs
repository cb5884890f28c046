//! Hierarchical-Z occlusion (`occlusion`): the depth pyramid's shape, the
//! screen footprint of an instance box and the conservative occlusion test,
//! in the form `shaders/hiz_*.comp` and `shaders/gpu_cull.comp` evaluate
//! them. Pure math: no Vulkan types.
//!
//! The scheme is Greene, Kass and Miller, "Hierarchical Z-Buffer
//! Visibility" (SIGGRAPH 1993), in the two-phase form of Haar and Aaltonen,
//! "GPU-Driven Rendering Pipelines" (SIGGRAPH 2015 course): draw what was
//! visible last frame, reduce this frame's depth to a pyramid, test the rest
//! against it. Depth is reverse-Z (1 at the near plane, 0 infinitely far),
//! so a pyramid texel keeps the *minimum* — the farthest depth — of what it
//! covers, and a box is hidden when its nearest depth (its maximum) is
//! smaller than the farthest depth under its whole footprint.
//!
//! Conservative by construction (the pitfalls of niagara's history and
//! bevy #14062 — a power-of-two pyramid over a non-power-of-two image
//! drops texels, and a level picked from the footprint's size alone can
//! miss its last row):
//! - Level 0 has `ceil(w / 2) × ceil(h / 2)` texels, each the minimum of
//!   the (up to) 2×2 pixels and all their samples; level `k + 1` halves
//!   level `k` the same way, rounding up, clamping at the edge. Texel `x`
//!   of level `k` therefore covers exactly pixels `[x·2^(k+1),
//!   (x+1)·2^(k+1))`: the integer mapping loses nothing.
//! - The footprint is the pixel range `floor(min)..=floor(max)` of the
//!   projected corners (widened by [`PIXEL_SLACK`]); the level is the
//!   smallest at which that range spans at most two texels per axis, and
//!   all (up to) four are read.
//! - A box any of whose corners lies at or behind the near plane is
//!   visible (its projection is unbounded).

use glam::{Mat4, Vec3, Vec4};

/// Pixels the footprint is widened by on each side, for the f32 rounding
/// of the projection (well over the few ulps of a 4×4 product at screen
/// coordinates below 2^13).
pub const PIXEL_SLACK: f32 = 0.5;

/// Relative slack on the box's nearest depth (a few f32 ulps).
pub const DEPTH_SLACK: f32 = 1e-6;

/// One level of a depth pyramid stored in one flat array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Level {
    /// Texels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Index of the level's first texel in the array.
    pub offset: u32,
}

/// The pyramid levels over an image of `width` × `height` pixels, level 0
/// first (2×2 pixels per texel), down to one texel; texel counts are
/// rounded up at every level.
pub fn levels(width: u32, height: u32) -> Vec<Level> {
    let mut out = Vec::new();
    let (mut w, mut h) = (width.max(1), height.max(1));
    let mut offset = 0u32;
    loop {
        w = w.div_ceil(2);
        h = h.div_ceil(2);
        out.push(Level {
            width: w,
            height: h,
            offset,
        });
        offset += w * h;
        if w == 1 && h == 1 {
            return out;
        }
    }
}

/// Texels of the whole pyramid (one eye).
pub fn texels(levels: &[Level]) -> u32 {
    levels.last().map_or(0, |l| l.offset + l.width * l.height)
}

/// Where a box lands on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Footprint {
    /// The box reaches the near plane or behind it: treat as visible.
    Near,
    /// The box lies wholly off screen: not visible in this view.
    Outside,
    /// Inclusive pixel ranges and the box's nearest depth.
    Rect {
        /// First and last pixel column.
        x: (u32, u32),
        /// First and last pixel row.
        y: (u32, u32),
        /// Largest reverse-Z depth of the box (its nearest point).
        depth: f32,
    },
}

/// The footprint of the box with centre `c` and half-extents `e` (relative
/// to the render origin) under `view_proj` (reverse-Z, origin-relative, as
/// the frame uniforms hold it) on an image of `width` × `height` pixels;
/// `near` is the near plane distance (corners with w below it are "near").
pub fn footprint(
    view_proj: &Mat4,
    c: Vec3,
    e: Vec3,
    width: u32,
    height: u32,
    near: f32,
) -> Footprint {
    let mut lo = glam::Vec2::splat(f32::INFINITY);
    let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
    let mut depth = 0.0f32;
    for k in 0..8 {
        let s = Vec3::new(
            if k & 1 == 0 { -1.0 } else { 1.0 },
            if k & 2 == 0 { -1.0 } else { 1.0 },
            if k & 4 == 0 { -1.0 } else { 1.0 },
        );
        let clip: Vec4 = *view_proj * (c + s * e).extend(1.0);
        if clip.w.is_nan() || clip.w <= near {
            return Footprint::Near;
        }
        let ndc = clip.truncate() / clip.w;
        lo = lo.min(ndc.truncate());
        hi = hi.max(ndc.truncate());
        depth = depth.max(ndc.z);
    }
    // NDC to pixels: x = (ndc + 1) / 2 · width, y likewise (Vulkan's
    // viewport with y down; the projection already flips).
    let size = glam::Vec2::new(width as f32, height as f32);
    let px_lo = (lo + 1.0) * 0.5 * size - PIXEL_SLACK;
    let px_hi = (hi + 1.0) * 0.5 * size + PIXEL_SLACK;
    if px_hi.x < 0.0 || px_hi.y < 0.0 || px_lo.x >= size.x || px_lo.y >= size.y {
        return Footprint::Outside;
    }
    let clamp = |v: f32, n: u32| (v.max(0.0).floor() as u32).min(n - 1);
    Footprint::Rect {
        x: (clamp(px_lo.x, width), clamp(px_hi.x, width)),
        y: (clamp(px_lo.y, height), clamp(px_hi.y, height)),
        depth: depth * (1.0 + DEPTH_SLACK),
    }
}

/// The level at which pixel ranges `x` and `y` span at most two texels per
/// axis (level `k` texels are `2^(k+1)` pixels wide).
pub fn level_for(x: (u32, u32), y: (u32, u32), levels: &[Level]) -> usize {
    let mut k = 0;
    while k + 1 < levels.len() {
        let shift = k as u32 + 1;
        if (x.1 >> shift) - (x.0 >> shift) <= 1 && (y.1 >> shift) - (y.0 >> shift) <= 1 {
            break;
        }
        k += 1;
    }
    k
}

/// Whether the footprint is hidden behind the pyramid `pyramid` (one eye,
/// laid out by `levels`): its nearest depth is smaller than the farthest
/// depth of every texel covering it.
pub fn occluded(fp: Footprint, pyramid: &[f32], levels: &[Level]) -> bool {
    match fp {
        Footprint::Near => false,
        Footprint::Outside => true,
        Footprint::Rect { x, y, depth } => {
            let k = level_for(x, y, levels);
            let l = levels[k];
            let shift = k as u32 + 1;
            let mut farthest = f32::INFINITY;
            for ty in (y.0 >> shift)..=(y.1 >> shift).min(l.height - 1) {
                for tx in (x.0 >> shift)..=(x.1 >> shift).min(l.width - 1) {
                    farthest = farthest.min(pyramid[(l.offset + ty * l.width + tx) as usize]);
                }
            }
            depth < farthest
        }
    }
}

/// The pyramid of a single-sample depth image (`depth[y * width + x]`),
/// as the compute passes build it: the reference for tests.
pub fn build(depth: &[f32], width: u32, height: u32) -> (Vec<Level>, Vec<f32>) {
    let ls = levels(width, height);
    let mut out = vec![0.0f32; texels(&ls) as usize];
    let (mut sw, mut sh) = (width, height);
    for (k, l) in ls.iter().enumerate() {
        for y in 0..l.height {
            for x in 0..l.width {
                let mut m = f32::INFINITY;
                for (sx, sy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (px, py) = ((2 * x + sx).min(sw - 1), (2 * y + sy).min(sh - 1));
                    let v = if k == 0 {
                        depth[(py * width + px) as usize]
                    } else {
                        let p = ls[k - 1];
                        out[(p.offset + py * p.width + px) as usize]
                    };
                    m = m.min(v);
                }
                out[(l.offset + y * l.width + x) as usize] = m;
            }
        }
        sw = l.width;
        sh = l.height;
    }
    (ls, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::projection::view_projection_f32;
    use crate::view::{Fov, Pose};
    use glam::DVec3;
    use proptest::prelude::*;

    #[test]
    fn levels_round_up_and_end_at_one_texel() {
        let ls = levels(2016, 2240);
        assert_eq!((ls[0].width, ls[0].height), (1008, 1120));
        assert_eq!(ls.last().map(|l| (l.width, l.height)), Some((1, 1)));
        let ls = levels(5, 3);
        let dims: Vec<_> = ls.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(dims, vec![(3, 2), (2, 1), (1, 1)]);
        assert_eq!(texels(&ls), 6 + 2 + 1);
        assert_eq!(levels(1, 1).len(), 1);
    }

    proptest! {
        /// Every texel of every level is the minimum of exactly the pixels
        /// it covers (brute force over the image): no texel is lost at odd
        /// sizes.
        #[test]
        fn texels_cover_exactly_their_pixels(w in 1u32..40, h in 1u32..40, seed in any::<u64>()) {
            let mut s = seed | 1;
            let depth: Vec<f32> = (0..w * h).map(|_| {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                (s % 1000) as f32 / 1000.0
            }).collect();
            let (ls, pyr) = build(&depth, w, h);
            for (k, l) in ls.iter().enumerate() {
                let span = 1u32 << (k + 1);
                for ty in 0..l.height {
                    for tx in 0..l.width {
                        let mut m = f32::INFINITY;
                        for py in ty * span..((ty + 1) * span).min(h) {
                            for px in tx * span..((tx + 1) * span).min(w) {
                                m = m.min(depth[(py * w + px) as usize]);
                            }
                        }
                        prop_assert_eq!(pyr[(l.offset + ty * l.width + tx) as usize], m);
                    }
                }
            }
        }

        /// The test never hides a rectangle that has a pixel at least as
        /// near as the box (brute force over the rectangle's pixels), and
        /// the chosen level spans at most 2×2 texels.
        #[test]
        fn occlusion_is_conservative(
            w in 1u32..48, h in 1u32..48, seed in any::<u64>(),
            x0 in 0u32..48, x1 in 0u32..48, y0 in 0u32..48, y1 in 0u32..48, d in 0.0f32..1.0,
        ) {
            let mut s = seed | 1;
            let depth: Vec<f32> = (0..w * h).map(|_| {
                s ^= s << 13; s ^= s >> 7; s ^= s << 17;
                (s % 1000) as f32 / 1000.0
            }).collect();
            let (ls, pyr) = build(&depth, w, h);
            let x = (x0.min(x1).min(w - 1), x0.max(x1).min(w - 1));
            let y = (y0.min(y1).min(h - 1), y0.max(y1).min(h - 1));
            let k = level_for(x, y, &ls);
            let shift = k as u32 + 1;
            prop_assert!((x.1 >> shift) - (x.0 >> shift) <= 1 || k + 1 == ls.len());
            prop_assert!((y.1 >> shift) - (y.0 >> shift) <= 1 || k + 1 == ls.len());
            let fp = Footprint::Rect { x, y, depth: d };
            let mut farthest = f32::INFINITY;
            for py in y.0..=y.1 {
                for px in x.0..=x.1 {
                    farthest = farthest.min(depth[(py * w + px) as usize]);
                }
            }
            if occluded(fp, &pyr, &ls) {
                prop_assert!(d < farthest, "hid a box at {} over a pixel at {}", d, farthest);
            }
        }

        /// Every point of a box in front of the eye projects inside its
        /// footprint, at a depth no nearer than the footprint's.
        #[test]
        fn footprint_contains_the_projected_box(
            cx in -4.0f32..4.0, cy in -4.0f32..4.0, cz in -30.0f32..-1.0,
            ex in 0.01f32..2.0, ey in 0.01f32..2.0, ez in 0.01f32..0.9,
            u in 0.0f32..1.0, v in 0.0f32..1.0, t in 0.0f32..1.0,
        ) {
            let fov = Fov { left: -0.9, right: 0.8, up: 0.85, down: -0.95 };
            let m = view_projection_f32(&Pose::default(), &fov, 0.05, DVec3::ZERO);
            let (c, e) = (Vec3::new(cx, cy, cz), Vec3::new(ex, ey, ez));
            let (w, h) = (200u32, 180u32);
            let p = c + (Vec3::new(u, v, t) * 2.0 - 1.0) * e;
            let clip = m * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let px = (ndc.x + 1.0) * 0.5 * w as f32;
            let py = (ndc.y + 1.0) * 0.5 * h as f32;
            match footprint(&m, c, e, w, h, 0.05) {
                Footprint::Near => prop_assert!(cz + ez > -0.05 - 1e-3),
                Footprint::Outside => prop_assert!(px < 0.0 || py < 0.0 || px >= w as f32 || py >= h as f32),
                Footprint::Rect { x, y, depth } => {
                    prop_assert!(ndc.z <= depth);
                    if (0.0..w as f32).contains(&px) && (0.0..h as f32).contains(&py) {
                        prop_assert!((x.0..=x.1).contains(&(px as u32)), "{} not in {:?}", px, x);
                        prop_assert!((y.0..=y.1).contains(&(py as u32)), "{} not in {:?}", py, y);
                    }
                }
            }
        }
    }

    /// A wall in front of a box hides it; the box beside the wall is not
    /// hidden; a box in front of the wall is not.
    #[test]
    fn a_wall_hides_what_is_behind_it() {
        let fov = Fov::symmetric(0.8, 0.8);
        let m = view_projection_f32(&Pose::default(), &fov, 0.05, DVec3::ZERO);
        let (w, h) = (64u32, 64u32);
        // The wall at z = -5 covers the middle half of the image.
        let wall = 0.05 / 5.0;
        let depth: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (16..48).contains(&x) && (16..48).contains(&y) {
                    wall
                } else {
                    0.0
                }
            })
            .collect();
        let (ls, pyr) = build(&depth, w, h);
        let test =
            |c: Vec3, e: f32| occluded(footprint(&m, c, Vec3::splat(e), w, h, 0.05), &pyr, &ls);
        assert!(test(Vec3::new(0.0, 0.0, -10.0), 0.5));
        assert!(!test(Vec3::new(0.0, 0.0, -4.0), 0.5));
        assert!(!test(Vec3::new(7.0, 0.0, -10.0), 0.5));
        assert!(
            !test(Vec3::new(0.0, 0.0, -0.5), 1.0),
            "a box around the eye is visible"
        );
    }
}
