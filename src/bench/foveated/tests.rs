//! The foveated error against its definition and brute force.

use super::*;
use proptest::prelude::*;

/// A `w` × `h` image from a seed: smooth gradients plus fine noise, so
/// every pyramid level differs.
fn image(w: u32, h: u32, seed: u64) -> image::RgbaImage {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    image::RgbaImage::from_fn(w, h, |x, y| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let noise = (s % 96) as u8;
        let g = ((x * 255) / w.max(1)) as u8 / 2;
        image::Rgba([
            g.saturating_add(noise),
            noise,
            ((y * 200) / h.max(1)) as u8,
            255,
        ])
    })
}

#[test]
fn acuity_falls_with_eccentricity_as_geisler_and_perry_fit_it() {
    // f_c(0) = ln 64 / 0.106.
    assert!((cutoff_cpd(0.0) - 64f64.ln() / 0.106).abs() < 1e-9);
    assert!((cutoff_cpd(0.0) - 39.23).abs() < 0.01);
    // Half of the foveal cutoff at e = e2.
    assert!((cutoff_cpd(2.3) - cutoff_cpd(0.0) / 2.0).abs() < 1e-9);
    let mut last = f64::INFINITY;
    for e in 0..90 {
        let f = cutoff_cpd(e as f64);
        assert!(f < last && f > 0.0);
        last = f;
    }
    // A display coarser than the fovea: level 0 at the gaze.
    assert_eq!(level(0.0, 20.0), 0.0);
    assert!(level(40.0, 20.0) > 1.0);
    assert_eq!(level(1e9, 20.0), MAX_LEVEL as f32);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn eccentricity_is_the_angle_to_the_gaze_ray(
        l in 0.2f64..1.2, r in 0.2f64..1.2, u in 0.2f64..1.2, d in 0.2f64..1.2,
        gx in -1.0f64..1.0, gy in -1.0f64..1.0,
    ) {
        let fov = Fov { left: -l, right: r, up: u, down: -d };
        let (w, h) = (9u32, 7u32);
        let e = eccentricity(w, h, &fov, [gx, gy]);
        let [tl, tr, tu, td] = fov.tangents();
        let g = [tl + (gx + 1.0) / 2.0 * (tr - tl), tu + (gy + 1.0) / 2.0 * (td - tu)];
        for y in 0..h {
            for x in 0..w {
                let t = [
                    tl + (x as f64 + 0.5) / w as f64 * (tr - tl),
                    tu + (y as f64 + 0.5) / h as f64 * (td - tu),
                ];
                let norm = |v: [f64; 2]| (v[0] * v[0] + v[1] * v[1] + 1.0).sqrt();
                let cos = (t[0] * g[0] + t[1] * g[1] + 1.0) / (norm(t) * norm(g));
                let brute = cos.clamp(-1.0, 1.0).acos().to_degrees();
                let got = e[(y * w + x) as usize] as f64;
                prop_assert!((got - brute).abs() < 1e-3, "{got} vs {brute}");
            }
        }
    }

    #[test]
    fn the_foveated_map_is_flip_at_the_fovea_never_more_and_falls_with_eccentricity(
        seed in 0u64..1000, e1 in 0.0f64..60.0, de in 0.0f64..30.0,
    ) {
        let (w, h) = (40u32, 30u32);
        let (a, b) = (image(w, h, seed), image(w, h, seed + 7));
        let ppd = 12.0f32;
        let flip = metrics::flip(&a, &b, ppd).unwrap().errors;
        let hidden = vec![false; (w * h) as usize];
        let uniform = |e: f64| vec![level(e, ppd as f64); (w * h) as usize];
        let at = |e: f64| flip_map(&a, &b, (ppd, &uniform(e), &hidden), None).unwrap();
        // At the fovea (level 0 everywhere): FLIP itself.
        prop_assert_eq!(&at(0.0), &flip);
        let (near, far) = (at(e1), at(e1 + de));
        for i in 0..flip.len() {
            prop_assert!(near[i] <= flip[i] + 1e-6);
            prop_assert!(far[i] <= near[i] + 1e-6, "pixel {i}: {} then {}", near[i], far[i]);
        }
    }
}

#[test]
fn detail_the_periphery_cannot_resolve_costs_little_there() {
    // A one-pixel checkerboard against flat grey of the same mean: at the
    // gaze a full FLIP error, 40 degrees out almost none.
    let (w, h) = (48u32, 36u32);
    let grey = image::RgbaImage::from_pixel(w, h, image::Rgba([188, 188, 188, 255]));
    let checker = image::RgbaImage::from_fn(w, h, |x, y| {
        let v = if (x + y) % 2 == 0 { 255 } else { 0 };
        image::Rgba([v, v, v, 255])
    });
    let ppd = 14.0f32;
    let hidden = vec![false; (w * h) as usize];
    let mean = |m: &[f32]| m.iter().map(|&v| v as f64).sum::<f64>() / m.len() as f64;
    let flip = mean(&metrics::flip(&grey, &checker, ppd).unwrap().errors);
    let far = vec![level(40.0, ppd as f64); (w * h) as usize];
    let foveated = mean(&flip_map(&grey, &checker, (ppd, &far, &hidden), None).unwrap());
    assert!(flip > 0.1, "{flip}");
    assert!(foveated < 0.25 * flip, "{foveated} vs {flip}");
}

#[test]
fn the_foveated_flicker_is_the_flicker_at_the_fovea_and_less_far_out() {
    let (w, h) = (32u32, 24u32);
    let test: Vec<_> = (0..4).map(|k| image(w, h, k)).collect();
    let reference: Vec<_> = (0..4).map(|k| image(w, h, 100 + k)).collect();
    let hidden = vec![false; (w * h) as usize];
    let plain = flicker::per_pixel(&test, &reference).unwrap();
    let zero = vec![0.0f32; (w * h) as usize];
    assert_eq!(
        flicker_map(&test, &reference, &zero, &hidden).unwrap(),
        plain
    );
    let far = vec![level(50.0, 14.0); (w * h) as usize];
    let out = flicker_map(&test, &reference, &far, &hidden).unwrap();
    assert!(out.iter().zip(&plain).all(|(f, p)| f <= p));
    assert!(out.iter().sum::<f32>() < 0.5 * plain.iter().sum::<f32>());
}

#[test]
fn what_the_lens_hides_does_not_leak_into_the_foveated_flicker() {
    // The test changes only in the hidden left half; the reference is
    // still. The visible half must score no flicker at any level.
    let (w, h) = (32u32, 16u32);
    let hidden: Vec<bool> = (0..w * h).map(|i| i % w < w / 2).collect();
    let still = image::RgbaImage::from_pixel(w, h, image::Rgba([90, 90, 90, 255]));
    let test: Vec<_> = (0..3u8)
        .map(|k| {
            image::RgbaImage::from_fn(w, h, |x, _| {
                let v = if x < w / 2 { 60 * k } else { 90 };
                image::Rgba([v, v, v, 255])
            })
        })
        .collect();
    let reference = vec![still.clone(), still.clone(), still];
    let far = vec![level(60.0, 14.0); (w * h) as usize];
    let map = flicker_map(&test, &reference, &far, &hidden).unwrap();
    for (i, v) in map.iter().enumerate() {
        if !hidden[i] {
            assert_eq!(*v, 0.0, "pixel {i}");
        }
    }
}
