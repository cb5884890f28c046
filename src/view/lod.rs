//! Level-of-detail selection (`lod`): which level of a mesh's simplified
//! chain an instance draws, from the level's geometric error projected at
//! the profile's pixel density. Pure math: `shaders/gpu_cull.comp` evaluates
//! the same test in f32.
//!
//! A world-space deviation `e` seen at distance `d` subtends at most `e / d`
//! radians; at the centre of a rectilinear image of `w` pixels over the
//! tangent range `[l, r]` one radian spans `w / (r − l)` pixels (the
//! derivative of `tan` is 1 there). So the projected error is
//! `density · e / d` pixels with `density` the larger of that figure over
//! both eyes and both axes — the pixel density the issue asks for. The
//! distance is taken to the nearest point of the instance's bounding
//! sphere, less the eyes' distance from the head (the render origin), so it
//! never exceeds an eye's true distance to any point of the instance.
//! (Towards the image edge a rectilinear image has `sec²θ` more pixels per
//! radian, but the lens blurs them: the centre density is what the
//! display resolves.)
//!
//! A level is drawn when its error projects to at most the bound (default
//! 1 px); the coarsest such level is chosen. The chain's last, implicit
//! step drops the instance: its error is the bounding sphere's diameter,
//! so an instance smaller than the bound on screen is not drawn at all.

use crate::view::Fov;

/// Default error bound in pixels.
pub const DEFAULT_BOUND_PX: f64 = 1.0;

/// Most levels in a chain (the original included).
pub const MAX_LEVELS: usize = 8;

/// Pixels per radian at the image centre of the denser eye: each eye's
/// `extent` (width, height) over its FOV's tangent range, the larger of the
/// two axes and the two eyes.
pub fn pixel_density(eyes: &[(Fov, (u32, u32))]) -> f64 {
    eyes.iter()
        .map(|(fov, (w, h))| {
            // Over the tangent range: the FOV's fields are angles.
            let [l, r, u, d] = fov.tangents();
            let x = *w as f64 / (r - l);
            let y = *h as f64 / (u - d);
            x.max(y)
        })
        .fold(0.0, f64::max)
}

/// The distance used for selection: from the render origin to the nearest
/// point of a bounding sphere at distance `center_distance` with radius
/// `radius`, less `eye_slack` (the eyes' largest distance from the
/// origin), and at least `near`.
pub fn selection_distance(center_distance: f64, radius: f64, eye_slack: f64, near: f64) -> f64 {
    (center_distance - radius - eye_slack).max(near)
}

/// Projected error in pixels of a world-space error `e` at distance `d`.
pub fn projected_px(e: f64, d: f64, density: f64) -> f64 {
    density * e / d
}

/// The level to draw: the coarsest of `errors` (object-space, ascending,
/// level 0 first with error 0) whose error, scaled by the instance's
/// largest axis scale `scale`, projects to at most `bound` pixels at
/// distance `d`; None when even the whole instance (bounding sphere of
/// world radius `radius`) projects to at most `bound` — it is dropped.
pub fn select(
    errors: &[f64],
    scale: f64,
    radius: f64,
    d: f64,
    density: f64,
    bound: f64,
) -> Option<usize> {
    if projected_px(2.0 * radius, d, density) <= bound {
        return None;
    }
    let mut level = 0;
    for (j, e) in errors.iter().enumerate().skip(1) {
        if projected_px(e * scale, d, density) <= bound {
            level = j;
        } else {
            break;
        }
    }
    Some(level)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn density_is_the_denser_axis_and_eye() {
        // Edges at tangent ±1 (±45°): 200 pixels over a tangent range of 2.
        let a = 1f64.atan();
        let fov = Fov::symmetric(a, a);
        assert!((pixel_density(&[(fov, (200, 100))]) - 100.0).abs() < 1e-9);
        let narrow = Fov {
            left: -0.5f64.atan(),
            right: 0.5f64.atan(),
            ..fov
        };
        let both = pixel_density(&[(fov, (200, 100)), (narrow, (200, 100))]);
        assert!((both - 200.0).abs() < 1e-9, "{both}");
    }

    proptest! {
        /// Against brute force: the density is the pixels per radian of
        /// the centre of a rectilinear image, measured as the angle
        /// subtended by the central pixels of each axis.
        #[test]
        fn density_is_the_centre_pixels_per_radian(
            l in 0.2..1.4f64, r in 0.2..1.4f64, u in 0.2..1.4f64, d in 0.2..1.4f64,
            w in 100u32..4000, h in 100u32..4000,
        ) {
            // l, r, u, d: the edges' angles.
            let fov = Fov { left: -l, right: r, up: u, down: -d };
            let [tl, tr, tu, td] = fov.tangents();
            // The angle between the view axis and the ray through a pixel
            // one pixel right of the axis's pixel position (the projection
            // is linear in tangents).
            let per_axis = |t0: f64, t1: f64, n: u32| {
                let step = (t1 - t0) / n as f64;
                1.0 / step.atan()
            };
            let want = per_axis(tl, tr, w).max(per_axis(td, tu, h));
            let got = pixel_density(&[(fov, (w, h))]);
            prop_assert!((got - want).abs() <= want * 1e-3, "{got} vs {want}");
        }
    }

    proptest! {
        /// The chosen level's projected error is within the bound and the
        /// next level's is not (brute force over the chain); a dropped
        /// instance projects to at most the bound.
        #[test]
        fn the_chosen_level_is_the_coarsest_within_the_bound(
            steps in proptest::collection::vec(0.0f64..0.05, 1..MAX_LEVELS),
            scale in 0.1f64..10.0, radius in 0.01f64..5.0,
            d in 0.05f64..500.0, density in 100.0f64..3000.0, bound in 0.25f64..4.0,
        ) {
            let mut errors = vec![0.0];
            for s in steps {
                let last = *errors.last().unwrap();
                errors.push(last + s);
            }
            match select(&errors, scale, radius, d, density, bound) {
                None => prop_assert!(projected_px(2.0 * radius, d, density) <= bound),
                Some(j) => {
                    prop_assert!(projected_px(errors[j] * scale, d, density) <= bound);
                    if let Some(next) = errors.get(j + 1) {
                        prop_assert!(projected_px(next * scale, d, density) > bound);
                    }
                }
            }
        }

        /// The selection distance never exceeds any eye's distance to any
        /// point of the sphere (so projected errors are never understated).
        #[test]
        fn the_selection_distance_is_a_lower_bound(
            c in 0.0f64..100.0, r in 0.0f64..10.0, slack in 0.0f64..0.1,
            u in -1.0f64..1.0, v in -1.0f64..1.0,
        ) {
            let d = selection_distance(c, r, slack, 0.05);
            // A point of the sphere at distance c + r·u from the origin,
            // seen from an eye displaced by slack·v: at least c − r − slack.
            let actual = (c + r * u).abs() - slack * v.abs();
            prop_assert!(d <= actual.max(0.05) + 1e-12);
        }
    }
}
