//! Fixed (or gaze-centred) foveated rendering through a
//! VK_KHR_fragment_shading_rate attachment: one rate per texel of
//! `texel` pixels (the device's shading-rate texel size), coarser with
//! distance from the gaze centre. The rings follow Meta's fixed foveated
//! rendering levels in spirit (full rate in the centre, 2×2 then 4×4 in the
//! periphery; Meta reports 21–36 % savings), expressed here as radii in NDC
//! units measured from the gaze centre (image corners are at √2 from the
//! centre).
//!
//! Rate encoding (Vulkan spec, "Fragment Shading Rate Attachment"): a texel
//! holds `(log2(width) << 2) | log2(height)`, so 1×1 = 0, 2×2 = 5, 4×4 = 10.
//! Rates the device cannot do at the frame's sample count are clamped by
//! the implementation.
//!
//! This is the pure math (levels, the rate image, the shaded fraction);
//! `render::shading_rate` uploads the image and attaches it.

/// How strongly the periphery is coarsened.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Level {
    /// No foveation.
    #[default]
    Off,
    /// Full rate inside 0.6, 2×2 outside.
    Low,
    /// Full rate inside 0.45, 2×2 to 0.8, 4×4 outside.
    Medium,
    /// Full rate inside 0.3, 2×2 to 0.6, 4×4 outside.
    High,
    /// `foveation=auto`: full rate inside the NDC radius (in thousandths)
    /// beyond which the HMD's lens reads at least two eye pixels per panel
    /// pixel, 2×2 outside ([`super::distortion::density`]); 0 until the
    /// profile's lens resolves it.
    Lens(u16),
}

impl std::str::FromStr for Level {
    type Err = String;
    fn from_str(s: &str) -> Result<Level, String> {
        match s {
            "off" => Ok(Level::Off),
            "low" => Ok(Level::Low),
            "medium" => Ok(Level::Medium),
            "high" => Ok(Level::High),
            "auto" => Ok(Level::Lens(0)),
            other => Err(format!(
                "foveation level '{other}' (known: off, low, medium, high, auto)"
            )),
        }
    }
}

/// Encoded rate of a `w`×`h` fragment.
pub const fn rate(w: u32, h: u32) -> u8 {
    ((w.trailing_zeros() << 2) | h.trailing_zeros()) as u8
}

impl Level {
    /// (outer radius, fragment size) rings from the centre out, the last
    /// reaching to infinity (repeated to fill the array when a level has
    /// fewer rings); no allocation, as rate images ask it per texel.
    pub fn rings(self) -> [(f32, u32); 3] {
        const INF: f32 = f32::INFINITY;
        match self {
            Level::Off => [(INF, 1); 3],
            Level::Low => [(0.6, 1), (INF, 2), (INF, 2)],
            Level::Medium => [(0.45, 1), (0.8, 2), (INF, 4)],
            Level::High => [(0.3, 1), (0.6, 2), (INF, 4)],
            Level::Lens(r) => [(f32::from(r) / 1000.0, 1), (INF, 2), (INF, 2)],
        }
    }

    /// Fragment size (square) at NDC distance `d` from the gaze centre.
    pub fn size_at(self, d: f32) -> u32 {
        self.rings()
            .iter()
            .find(|(r, _)| d < *r)
            .map_or(1, |(_, s)| *s)
    }
}

/// The rate image for a `width`×`height` view: `ceil(width / texel.0)` ×
/// `ceil(height / texel.1)` texels, row-major, each rated by the distance
/// of its centre from `gaze` (NDC, +y down as in Vulkan).
pub fn rate_image(
    level: Level,
    gaze: [f32; 2],
    width: u32,
    height: u32,
    texel: (u32, u32),
) -> (u32, u32, Vec<u8>) {
    let (w, h) = (width as f32, height as f32);
    rate_image_mapped(level, gaze, (width, height), texel, |p| {
        [p[0] / w * 2.0 - 1.0, p[1] / h * 2.0 - 1.0]
    })
}

/// The rate image of a `size` target whose pixel `p` (continuous) shows
/// the eye's NDC point `to_ndc(p)`: each texel takes the rate of the eye
/// point its centre shows, so the rings stay where they are in the eye
/// when the target is not rectilinear (lens-matched shading's image,
/// [`super::lms::Layout::eye_ndc`]).
pub fn rate_image_mapped(
    level: Level,
    gaze: [f32; 2],
    size: (u32, u32),
    texel: (u32, u32),
    to_ndc: impl Fn([f32; 2]) -> [f32; 2],
) -> (u32, u32, Vec<u8>) {
    let (width, height) = size;
    let tw = width.div_ceil(texel.0.max(1));
    let th = height.div_ceil(texel.1.max(1));
    let mut out = Vec::with_capacity((tw * th) as usize);
    for ty in 0..th {
        for tx in 0..tw {
            let cx = ((tx as f32 + 0.5) * texel.0 as f32).min(width as f32);
            let cy = ((ty as f32 + 0.5) * texel.1 as f32).min(height as f32);
            let [nx, ny] = to_ndc([cx, cy]);
            let d = ((nx - gaze[0]).powi(2) + (ny - gaze[1]).powi(2)).sqrt();
            let s = level.size_at(d);
            out.push(rate(s, s));
        }
    }
    (tw, th, out)
}

/// The fraction of pixels shaded relative to full rate for `level`
/// (each s×s fragment shades once): a CPU estimate reported in stats.
pub fn shaded_fraction(
    level: Level,
    gaze: [f32; 2],
    width: u32,
    height: u32,
    texel: (u32, u32),
) -> f64 {
    let (tw, th, img) = rate_image(level, gaze, width, height, texel);
    let per_texel: f64 = img
        .iter()
        .map(|&r| {
            let (w, h) = (1u32 << (r >> 2), 1u32 << (r & 3));
            1.0 / (w * h) as f64
        })
        .sum();
    per_texel / (tw * th).max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_encoding_matches_the_spec() {
        assert_eq!(rate(1, 1), 0);
        assert_eq!(rate(1, 2), 1);
        assert_eq!(rate(2, 1), 4);
        assert_eq!(rate(2, 2), 5);
        assert_eq!(rate(4, 4), 10);
    }

    #[test]
    fn centre_is_full_rate_and_corners_coarse() {
        for level in [Level::Low, Level::Medium, Level::High] {
            let (tw, th, img) = rate_image(level, [0.0, 0.0], 2016, 2240, (16, 16));
            assert_eq!((tw, th), (126, 140));
            let at = |x: u32, y: u32| img[(y * tw + x) as usize];
            assert_eq!(at(tw / 2, th / 2), 0, "{level:?} centre");
            let corner = at(0, 0);
            assert!(
                corner == rate(2, 2) || corner == rate(4, 4),
                "{level:?} corner {corner}"
            );
        }
        let (_, _, off) = rate_image(Level::Off, [0.0, 0.0], 100, 100, (8, 8));
        assert!(off.iter().all(|&r| r == 0));
    }

    #[test]
    fn gaze_moves_the_full_rate_region() {
        let (tw, _, img) = rate_image(Level::High, [0.8, -0.8], 1000, 1000, (10, 10));
        let at = |x: u32, y: u32| img[(y * tw + x) as usize];
        assert_eq!(at(90, 10), 0, "near the gaze (upper right)");
        assert_eq!(at(10, 90), rate(4, 4), "far from it");
    }

    #[test]
    fn higher_levels_shade_less() {
        let f = |l| shaded_fraction(l, [0.0, 0.0], 2016, 2240, (16, 16));
        let (off, low, med, high) = (
            f(Level::Off),
            f(Level::Low),
            f(Level::Medium),
            f(Level::High),
        );
        assert_eq!(off, 1.0);
        assert!(low < off && med < low && high < med, "{low} {med} {high}");
        assert!(high > 0.1);
    }

    /// Through lens-matched shading's map the full-rate texels are those
    /// whose centre shows an eye point inside the full-rate ring, and
    /// with no scaling the pattern is the eye image's own.
    #[test]
    fn the_lms_pattern_keeps_the_rings_in_the_eye() {
        use super::super::lms::{Coefficients, Layout};
        let texel = (16, 16);
        let plain = Coefficients::uniform(0.0);
        let layout = Layout::new(&plain, [2016, 2240]);
        let mapped = |c: Coefficients, l: Layout| {
            let size = (l.size[0], l.size[1]);
            rate_image_mapped(Level::High, [0.0; 2], size, texel, |p| {
                let q = l.eye_ndc(&c, [p[0] as f64, p[1] as f64]);
                [q[0] as f32, q[1] as f32]
            })
        };
        assert_eq!(
            mapped(plain, layout),
            rate_image(Level::High, [0.0; 2], 2016, 2240, texel)
        );
        let c = Coefficients::uniform(0.4);
        let l = Layout::new(&c, [2016, 2240]);
        let (tw, th, img) = mapped(c, l);
        let inner = Level::High.rings()[0].0 as f64;
        for ty in 0..th {
            for tx in 0..tw {
                let p = [(tx as f64 + 0.5) * 16.0, (ty as f64 + 0.5) * 16.0];
                let p = [p[0].min(l.size[0] as f64), p[1].min(l.size[1] as f64)];
                let q = l.eye_ndc(&c, p);
                let full = (q[0] * q[0] + q[1] * q[1]).sqrt() < inner - 1e-4;
                let r = img[(ty * tw + tx) as usize];
                if full {
                    assert_eq!(r, 0, "texel {tx},{ty} shows {q:?}");
                } else if (q[0] * q[0] + q[1] * q[1]).sqrt() > inner + 1e-4 {
                    assert_ne!(r, 0, "texel {tx},{ty} shows {q:?}");
                }
            }
        }
        let full = |img: &[u8]| img.iter().filter(|&&r| r == 0).count();
        let eye = rate_image(Level::High, [0.0; 2], 2016, 2240, texel).2;
        assert!(full(&img) < full(&eye), "the LMS image is denser nowhere");
    }

    #[test]
    fn partial_texels_at_the_edge_are_covered() {
        let (tw, th, img) = rate_image(Level::Medium, [0.0, 0.0], 100, 50, (16, 16));
        assert_eq!((tw, th), (7, 4));
        assert_eq!(img.len(), 28);
    }
}
