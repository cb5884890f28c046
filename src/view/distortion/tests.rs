use super::*;
use crate::view::profile::HmdProfile;
use proptest::prelude::*;

fn lenses(profile: &str) -> Vec<(Lens, Fov)> {
    let p = HmdProfile::load(profile).expect("profile loads");
    p.views
        .iter()
        .map(|v| (v.lens.expect("profile has a lens"), v.fov))
        .collect()
}

#[test]
fn published_centre_and_edge_factors() {
    // OpenHMD's DK1: d = 0.599 at the centre, a + b + c + d = 1.000 at r = 1.
    for (lens, _) in lenses("rift-dk1") {
        let (d0, _) = lens.radial.factor(1, 0.0);
        let (d1, _) = lens.radial.factor(1, 1.0);
        assert!((d0 - 0.599).abs() < 1e-12);
        assert!((d1 - 1.0).abs() < 1e-12);
        // The left edge of the panel (r = 1 on the lens's wide side)
        // shows the eye image's outer edge.
        let (r_edge, _) = lens.radial.radius(1, 1.0);
        assert!((r_edge - 1.0).abs() < 1e-12);
    }
    // The Vive: 1 at the centre (k4 = 0); at the cut-off radius the green
    // channel samples 1/(1 + k1 s + k2 s² + k3 s³) farther out.
    // By hand from the dump: left s = 1.1407, B = 0.6493; right s = 1.1253,
    // B = 0.6575.
    for ((lens, _), by_hand) in lenses("vive").into_iter().zip([1.540, 1.521]) {
        assert_eq!(lens.radial.factor(1, 0.0).0, 1.0);
        let s = lens.r_max * lens.r_max;
        let Radial::Dpoly3(p) = lens.radial else {
            panic!("dpoly3")
        };
        let [k1, k2, k3, _] = p.k[1];
        let expect = 1.0 / (1.0 + k1 * s + k2 * s * s + k3 * s * s * s);
        assert!((lens.radial.factor(1, lens.r_max).0 - expect).abs() < 1e-12);
        assert!((expect - by_hand).abs() < 1e-3, "{expect}");
    }
}

#[test]
fn chromatic_channels_separate_red_inside_blue_outside() {
    for profile in ["rift-dk1", "vive"] {
        for (lens, _) in lenses(profile) {
            for i in 1..=20 {
                let r = lens.r_max * i as f64 / 20.0;
                let [red, green, blue] = [0, 1, 2].map(|c| lens.radial.radius(c, r).0);
                assert!(
                    red < green && green < blue,
                    "{profile} r {r}: {red} {green} {blue}"
                );
            }
        }
    }
}

#[test]
fn forward_then_inverse_is_the_identity_over_the_visible_lens() {
    for profile in ["rift-dk1", "vive"] {
        for (lens, _) in lenses(profile) {
            let n = 200;
            let mut worst = 0.0f64;
            for j in 0..=n {
                for i in 0..=n {
                    let uv = [i as f64 / n as f64, j as f64 / n as f64];
                    for channel in 0..3 {
                        let Some(t) = lens.tangent_of_panel(uv, channel) else {
                            continue;
                        };
                        let back = lens.panel_of_tangent(t, channel).expect("inverse exists");
                        worst = worst.max((back[0] - uv[0]).abs().max((back[1] - uv[1]).abs()));
                    }
                }
            }
            assert!(worst <= 1e-5, "{profile}: {worst}");
        }
    }
}

#[test]
fn a_straight_line_bends_outward_under_barrel_sampling() {
    // A panel column away from the centre samples the eye image along a
    // curve: with D increasing in r (pincushion sampling of a barrel lens),
    // the column's ends, farther from the axis, sample farther out than its
    // middle does.
    for (lens, fov) in lenses("vive") {
        let u = lens.centre[0] + 0.3;
        let at = |v: f64| eye_uv(&fov, lens.tangent_of_panel([u, v], 1).unwrap());
        let (top, mid, bottom) = (
            at(lens.centre[1] - 0.3),
            at(lens.centre[1]),
            at(lens.centre[1] + 0.3),
        );
        let centre_u = eye_uv(&fov, lens.tangent_of_panel(lens.centre, 1).unwrap())[0];
        assert!(
            top[0] - centre_u > mid[0] - centre_u + 0.01,
            "{top:?} {mid:?}"
        );
        assert!(
            bottom[0] - centre_u > mid[0] - centre_u + 0.01,
            "{bottom:?} {mid:?}"
        );
    }
}

fn dk1_table(k: &str, extra: &str) -> String {
    format!(
        "name = \"t\"\nrefresh_hz = 60.0\n[[views]]\nposition = [0.0, 0.0, 0.0]\norientation = [0.0, 0.0, 0.0, 1.0]\n\
         fov = {{ left = -1.0, right = 1.0, up = 1.0, down = -1.0 }}\nresolution = [64, 64]\n\
         [views.lens]\nmodel = \"panotools\"\nk = {k}\nchroma = [0.99, 1.0, 1.01]\n\
         centre = [0.5, 0.5]\nunit = [0.5, 0.5]\ntangent = [1.0, 1.0]\n{extra}"
    )
}

#[test]
fn bad_lens_values_are_one_clear_error() {
    let err = |text: String| HmdProfile::parse("t", &text).unwrap_err().to_string();
    let e = err(dk1_table("[1.0, -3.0, 0.4, 0.6]", ""));
    assert!(e.contains("does not increase"), "{e}");
    let e = err(dk1_table("[0.0, 0.0, 0.0, 1.0]", "r_max = nan\n"));
    assert!(e.contains("r_max"), "{e}");
    let e = err(dk1_table(
        "[0.0, 0.0, 0.0, 1.0]",
        "red = [0.0, 0.0, 0.0, 0.0]\n",
    ));
    assert!(e.contains("does not belong"), "{e}");
    let e = err(dk1_table("[0.0, 0.0, 0.0]", ""));
    assert!(e.contains("4 numbers"), "{e}");
    let e = err(dk1_table("[0.0, 0.0, 0.0, 1.0]", "wobble = 1\n").replace("panotools", "fisheye"));
    assert!(e.contains("wobble") || e.contains("fisheye"), "{e}");
    let e = err(dk1_table("[0.0, 0.0, 0.0, 1.0]", "").replace("panotools", "fisheye"));
    assert!(e.contains("unknown model \"fisheye\""), "{e}");
    assert!(HmdProfile::parse("t", &dk1_table("[0.0, 0.0, 0.0, 1.0]", "")).is_ok());
}

proptest! {
    /// Against brute force: the inverse of a random increasing PanoTools
    /// lens agrees with the nearest of a dense grid of forward samples.
    #[test]
    fn inverse_agrees_with_forward_sampling(a in -0.1f64..0.4, b in -0.1f64..0.4, c in 0.0f64..0.4,
                                            u in 0.05f64..0.95, v in 0.05f64..0.95) {
        let lens = Lens {
            radial: Radial::Panotools(panotools::Panotools { k: [a, b, c, 1.0], chroma: [0.99, 1.0, 1.01] }),
            centre: [0.5, 0.5],
            unit: [0.5, 0.5],
            tangent: [1.0, 1.0],
            axis: [0.05, -0.02],
            r_max: std::f64::consts::SQRT_2,
            panel: [64, 64],
        };
        prop_assume!(lens.validate().is_ok());
        let t = lens.tangent_of_panel([u, v], 1).unwrap();
        let back = lens.panel_of_tangent(t, 1).unwrap();
        prop_assert!((back[0] - u).abs() < 1e-9 && (back[1] - v).abs() < 1e-9);
        // Brute force: the grid point whose forward image lies nearest t.
        let n = 400;
        let mut best = (f64::MAX, [0.0, 0.0]);
        for j in 0..=n {
            for i in 0..=n {
                let p = [i as f64 / n as f64, j as f64 / n as f64];
                if let Some(f) = lens.tangent_of_panel(p, 1) {
                    let d = (f[0] - t[0]).hypot(f[1] - t[1]);
                    if d < best.0 { best = (d, p); }
                }
            }
        }
        prop_assert!((best.1[0] - u).abs() <= 2.0 / n as f64 && (best.1[1] - v).abs() <= 2.0 / n as f64);
    }
}

/// A DPOLY3 profile whose three channels use `k` (k1, k2, k3, k4).
fn dpoly3_table(k: [f64; 4], extra: &str) -> String {
    let k = format!("[{}, {}, {}, {}]", k[0], k[1], k[2], k[3]);
    format!(
        "name = \"t\"\nrefresh_hz = 60.0\n[[views]]\nposition = [0.0, 0.0, 0.0]\norientation = [0.0, 0.0, 0.0, 1.0]\n\
         fov = {{ left = -1.0, right = 1.0, up = 1.0, down = -1.0 }}\nresolution = [64, 64]\n\
         [views.lens]\nmodel = \"dpoly3\"\nred = {k}\ngreen = {k}\nblue = {k}\n\
         centre = [0.5, 0.5]\nunit = [0.5, 0.5]\ntangent = [1.0, 1.0]\nr_max = 1.0\n{extra}"
    )
}

#[test]
fn a_pole_between_samples_and_a_far_centre_are_refused() {
    let err = |text: String| HmdProfile::parse("t", &text).unwrap_err().to_string();
    // 1 + k1 q + k2 q² + k3 q³ = ((q − m)²(q + 1) − δ) / (m² − δ): zero
    // only within about 1e-5 of q = m, between any two checked samples.
    let (m, delta) = (0.50037f64, 1e-10);
    let c = m * m - delta;
    let k = [(m * m - 2.0 * m) / c, (1.0 - 2.0 * m) / c, 1.0 / c, 0.0];
    let e = err(dpoly3_table(k, ""));
    assert!(e.contains("pole"), "{e}");
    // The same cubic lifted clear of zero is a lens.
    HmdProfile::parse("t", &dpoly3_table([-0.2, -0.03, -0.04, 0.0], "")).unwrap();
    let e = err(dk1_table("[0.0, 0.0, 0.0, 1.0]", "")
        .replace("centre = [0.5, 0.5]", "centre = [1e300, 0.5]"));
    assert!(e.contains("centre"), "{e}");
}
