//! Lens distortion: how an HMD's lens maps the pixels of its panel to view
//! directions, per colour channel, and back.
//!
//! Coordinates, per eye:
//! - **panel uv**: (x + ½)/W, (y + ½)/H on a W×H-pixel panel, y down;
//! - **lens coordinates** q = ((u − c_u)/unit_u, (v − c_v)/unit_v): the panel
//!   point relative to the lens centre c, in lens units (`unit` is the panel
//!   fraction one lens unit spans along each axis, so q is isotropic when
//!   the pixels are square), with radius r = |q|;
//! - **undistorted coordinates** q' = q·D_k(r) for channel k, where D_k is
//!   the radial factor of the model ([`panotools`], [`dpoly3`]);
//! - **tangent** t = (q'_x·tan_x + a_x, −q'_y·tan_y + a_y): the view
//!   direction (x/−z, y/−z) the panel point shows, y up as in OpenXR, where
//!   a = `axis` is the direction of the lens axis (0 when it is the view
//!   axis);
//! - **eye uv**: where t lies in the rendered eye image of the view's FOV,
//!   u = (t_x − tan l)/(tan r − tan l), v = (tan u − t_y)/(tan u − tan d).
//!
//! The forward map (panel → eye image, per channel) is what a distortion
//! pass samples with; the inverse (eye image → panel, for the mesh methods)
//! is radial too: the direction of q and q' agree, and the radius comes from
//! [`inverse::solve_increasing`]. Only the panel disc r ≤ `r_max` is the
//! visible lens; the profile loader checks that r·D_k(r) increases strictly
//! on [0, r_max] for every channel, so both maps are one-to-one there.

pub mod density;
pub mod dpoly3;
pub mod fold;
pub mod inverse;
pub mod mesh;
pub mod panotools;

use super::Fov;
use serde::Deserialize;

/// The radial model of a lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radial {
    /// r' = r·s_k·(a r³ + b r² + c r + d) ([`panotools`]).
    Panotools(panotools::Panotools),
    /// Valve's DPOLY3 as Monado evaluates it ([`dpoly3`]).
    Dpoly3(dpoly3::Dpoly3),
}

impl Radial {
    /// D_k(r) and its derivative for channel `channel` (0 red, 1 green, 2 blue).
    pub fn factor(&self, channel: usize, r: f64) -> (f64, f64) {
        match self {
            Radial::Panotools(p) => p.factor(channel, r),
            Radial::Dpoly3(p) => p.factor(channel, r),
        }
    }

    /// The model's name as profiles write it.
    pub fn name(&self) -> &'static str {
        match self {
            Radial::Panotools(_) => "panotools",
            Radial::Dpoly3(_) => "dpoly3",
        }
    }

    /// g_k(r) = r·D_k(r) (the undistorted radius) and g_k'(r) = D_k + r·D_k'.
    pub fn radius(&self, channel: usize, r: f64) -> (f64, f64) {
        let (d, dd) = self.factor(channel, r);
        (r * d, d + r * dd)
    }
}

/// A lens of one view: its radial model and where it sits on the panel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// The radial model.
    pub radial: Radial,
    /// The lens centre on the panel, in panel uv.
    pub centre: [f64; 2],
    /// The panel fraction one lens unit spans, along x and y.
    pub unit: [f64; 2],
    /// Tangent of the view angle per undistorted lens unit, along x and y.
    pub tangent: [f64; 2],
    /// The tangent (x, y) of the lens axis.
    pub axis: [f64; 2],
    /// The visible lens radius in lens units.
    pub r_max: f64,
    /// Panel pixels (width, height).
    pub panel: [u32; 2],
}

/// The `[views.lens]` table of an HMD profile.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LensToml {
    /// "panotools" or "dpoly3".
    pub model: String,
    /// PanoTools a, b, c, d.
    #[serde(default, deserialize_with = "opt4")]
    pub k: Option<[f64; 4]>,
    /// PanoTools per-channel scales (red, green, blue).
    #[serde(default, deserialize_with = "opt3")]
    pub chroma: Option<[f64; 3]>,
    /// DPOLY3 coefficients k1..k4 of the red channel.
    #[serde(default, deserialize_with = "opt4")]
    pub red: Option<[f64; 4]>,
    /// DPOLY3 coefficients of the green channel.
    #[serde(default, deserialize_with = "opt4")]
    pub green: Option<[f64; 4]>,
    /// DPOLY3 coefficients of the blue channel.
    #[serde(default, deserialize_with = "opt4")]
    pub blue: Option<[f64; 4]>,
    /// The lens centre in panel uv.
    #[serde(deserialize_with = "super::strict::exact")]
    pub centre: [f64; 2],
    /// Panel fraction per lens unit along x and y.
    #[serde(deserialize_with = "super::strict::exact")]
    pub unit: [f64; 2],
    /// Tangent per undistorted lens unit along x and y.
    #[serde(deserialize_with = "super::strict::exact")]
    pub tangent: [f64; 2],
    /// Tangent of the lens axis (default: the view axis, [0, 0]).
    #[serde(default, deserialize_with = "opt2")]
    pub axis: Option<[f64; 2]>,
    /// Visible lens radius (default: the farthest panel corner).
    pub r_max: Option<f64>,
    /// Panel pixels (default: the view's resolution).
    #[serde(default, deserialize_with = "opt2u")]
    pub panel: Option<[u32; 2]>,
}

fn opt_exact<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    super::strict::exact::<D, T, N>(d).map(Some)
}

fn opt4<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 4]>, D::Error> {
    opt_exact::<D, f64, 4>(d)
}

fn opt3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    opt_exact::<D, f64, 3>(d)
}

fn opt2<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
    opt_exact::<D, f64, 2>(d)
}

fn opt2u<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[u32; 2]>, D::Error> {
    opt_exact::<D, u32, 2>(d)
}

/// Samples of r per unit lens radius when checking monotonicity.
const CHECK_STEPS: usize = 4096;

impl LensToml {
    /// The lens this table describes for a view of `resolution` pixels,
    /// validated ([`Lens::validate`]).
    pub fn lens(&self, resolution: [u32; 2]) -> Result<Lens, String> {
        let need = |v: Option<[f64; 4]>, key: &str| {
            v.ok_or_else(|| format!("lens: model \"{}\" needs `{key}`", self.model))
        };
        let refuse = |present: bool, key: &str| {
            if present {
                Err(format!(
                    "lens: `{key}` does not belong to model \"{}\"",
                    self.model
                ))
            } else {
                Ok(())
            }
        };
        let radial = match self.model.as_str() {
            "panotools" => {
                refuse(self.red.is_some(), "red")?;
                refuse(self.green.is_some(), "green")?;
                refuse(self.blue.is_some(), "blue")?;
                Radial::Panotools(panotools::Panotools {
                    k: need(self.k, "k")?,
                    chroma: self
                        .chroma
                        .ok_or_else(|| "lens: model \"panotools\" needs `chroma`".to_string())?,
                })
            }
            "dpoly3" => {
                refuse(self.k.is_some(), "k")?;
                refuse(self.chroma.is_some(), "chroma")?;
                Radial::Dpoly3(dpoly3::Dpoly3 {
                    k: [
                        need(self.red, "red")?,
                        need(self.green, "green")?,
                        need(self.blue, "blue")?,
                    ],
                })
            }
            other => {
                return Err(format!(
                    "lens: unknown model \"{other}\" (known: panotools, dpoly3)"
                ))
            }
        };
        let panel = self.panel.unwrap_or(resolution);
        let mut lens = Lens {
            radial,
            centre: self.centre,
            unit: self.unit,
            tangent: self.tangent,
            axis: self.axis.unwrap_or([0.0, 0.0]),
            r_max: 0.0,
            panel,
        };
        lens.r_max = match self.r_max {
            Some(r) => r,
            None => lens.corner_radius(),
        };
        lens.validate()?;
        Ok(lens)
    }
}

impl Lens {
    /// Lens coordinates of a panel uv.
    pub fn lens_of_panel(&self, uv: [f64; 2]) -> [f64; 2] {
        [
            (uv[0] - self.centre[0]) / self.unit[0],
            (uv[1] - self.centre[1]) / self.unit[1],
        ]
    }

    /// Panel uv of lens coordinates.
    pub fn panel_of_lens(&self, q: [f64; 2]) -> [f64; 2] {
        [
            self.centre[0] + q[0] * self.unit[0],
            self.centre[1] + q[1] * self.unit[1],
        ]
    }

    /// The largest lens radius of the panel's four corners.
    pub fn corner_radius(&self) -> f64 {
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
            .iter()
            .map(|&c| {
                let q = self.lens_of_panel(c);
                q[0].hypot(q[1])
            })
            .fold(0.0, f64::max)
    }

    /// The tangent a panel uv shows in channel `channel`; None outside the
    /// visible lens (r > r_max).
    pub fn tangent_of_panel(&self, uv: [f64; 2], channel: usize) -> Option<[f64; 2]> {
        let q = self.lens_of_panel(uv);
        let r = q[0].hypot(q[1]);
        // NaN (a non-finite uv) is outside too.
        if r.is_nan() || r > self.r_max {
            return None;
        }
        let (d, _) = self.radial.factor(channel, r);
        Some(self.tangent_of_undistorted([q[0] * d, q[1] * d]))
    }

    /// The tangent of undistorted lens coordinates q'.
    pub fn tangent_of_undistorted(&self, qd: [f64; 2]) -> [f64; 2] {
        [
            qd[0] * self.tangent[0] + self.axis[0],
            -qd[1] * self.tangent[1] + self.axis[1],
        ]
    }

    /// The undistorted lens coordinates q' of a tangent.
    pub fn undistorted_of_tangent(&self, t: [f64; 2]) -> [f64; 2] {
        [
            (t[0] - self.axis[0]) / self.tangent[0],
            -(t[1] - self.axis[1]) / self.tangent[1],
        ]
    }

    /// The panel uv that shows tangent `t` in channel `channel` (the
    /// inverse of [`Lens::tangent_of_panel`]); None when no visible panel
    /// point shows it.
    pub fn panel_of_tangent(&self, t: [f64; 2], channel: usize) -> Option<[f64; 2]> {
        let qd = self.undistorted_of_tangent(t);
        let rho = qd[0].hypot(qd[1]);
        let r = inverse::solve_increasing(|r| self.radial.radius(channel, r), rho, self.r_max)?;
        if rho == 0.0 {
            return Some(self.centre);
        }
        let s = r / rho;
        Some(self.panel_of_lens([qd[0] * s, qd[1] * s]))
    }

    /// Checks that every number is finite and sensible and that r·D_k(r)
    /// increases strictly on [0, r_max] for every channel (the lens does
    /// not fold over inside the visible disc).
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(format!(
                    "lens: `{name}` = {v:?} has a value that is not finite"
                ))
            }
        };
        match &self.radial {
            Radial::Panotools(p) => {
                finite("k", &p.k)?;
                finite("chroma", &p.chroma)?;
                if p.chroma.iter().any(|&s| s <= 0.0) {
                    return Err(format!("lens: `chroma` = {:?} must be positive", p.chroma));
                }
            }
            Radial::Dpoly3(p) => {
                for (name, k) in ["red", "green", "blue"].iter().zip(&p.k) {
                    finite(name, k)?;
                }
            }
        }
        finite("centre", &self.centre)?;
        finite("unit", &self.unit)?;
        finite("tangent", &self.tangent)?;
        finite("axis", &self.axis)?;
        if self.centre.iter().any(|&c| !(-1.0..=2.0).contains(&c)) {
            return Err(format!(
                "lens: `centre` = {:?} must lie within one panel of the panel (each in [-1, 2])",
                self.centre
            ));
        }
        let big = |v: &[f64]| v.iter().any(|x| x.abs() > 1e3);
        if big(&self.unit) || big(&self.tangent) || big(&self.axis) {
            return Err(format!(
                "lens: `unit` {:?}, `tangent` {:?} and `axis` {:?} must be within ±1000",
                self.unit, self.tangent, self.axis
            ));
        }
        if self.unit.iter().any(|&u| u <= 0.0) || self.tangent.iter().any(|&t| t <= 0.0) {
            return Err(format!(
                "lens: `unit` {:?} and `tangent` {:?} must be positive",
                self.unit, self.tangent
            ));
        }
        finite("r_max", &[self.r_max])?;
        if self.r_max <= 0.0 || self.r_max > 1e3 {
            return Err(format!(
                "lens: `r_max` = {} must be in (0, 1000]",
                self.r_max
            ));
        }
        let [w, h] = self.panel;
        if w == 0 || h == 0 || w > 16384 || h > 16384 {
            return Err(format!("lens: panel {w}x{h} must be within 1..=16384"));
        }
        self.exact_fold_check()?;
        let steps = ((CHECK_STEPS as f64 * self.r_max.max(1.0)).ceil() as usize).min(1 << 20);
        for (channel, name) in ["red", "green", "blue"].iter().enumerate() {
            let mut last = 0.0;
            for i in 1..=steps {
                let r = self.r_max * i as f64 / steps as f64;
                let (g, slope) = self.radial.radius(channel, r);
                let (d, _) = self.radial.factor(channel, r);
                if !g.is_finite() || !slope.is_finite() || d <= 0.0 || g <= last {
                    return Err(format!(
                        "lens: the {name} channel's undistorted radius r·D(r) does not increase at r = {r:.4} \
                         (the lens folds over inside the visible radius {:.4}; lower `r_max` or fix the coefficients)",
                        self.r_max
                    ));
                }
                last = g;
            }
        }
        Ok(())
    }
}

impl Lens {
    /// [`fold`]'s exact checks on [0, r_max]: PanoTools' g' positive,
    /// DPOLY3's denominator without a root (a pole).
    fn exact_fold_check(&self) -> Result<(), String> {
        let r = self.r_max;
        for (channel, name) in ["red", "green", "blue"].iter().enumerate() {
            match &self.radial {
                Radial::Panotools(p) => {
                    let [a, b, c, d] = p.k;
                    let s = p.chroma[channel];
                    let slope = [s * d, s * 2.0 * c, s * 3.0 * b, s * 4.0 * a];
                    if fold::cubic_min(slope, 0.0, r) <= 0.0 {
                        return Err(format!(
                            "lens: the {name} channel's undistorted radius r·D(r) does not increase everywhere inside the visible radius {r:.4} \
                             (the lens folds over; lower `r_max` or fix the coefficients)"
                        ));
                    }
                }
                Radial::Dpoly3(p) => {
                    let [k1, k2, k3, _] = p.k[channel];
                    if fold::cubic_min([1.0, k1, k2, k3], 0.0, r * r) <= 0.0 {
                        return Err(format!(
                            "lens: the {name} channel's DPOLY3 denominator 1 + k1·r² + k2·r⁴ + k3·r⁶ reaches zero inside the visible radius {r:.4} \
                             (a pole); lower `r_max` or fix the coefficients"
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// Where tangent `t` lies in the eye image of `fov` (eye uv, y down).
pub fn eye_uv(fov: &Fov, t: [f64; 2]) -> [f64; 2] {
    let [l, r, u, d] = fov.tangents();
    [(t[0] - l) / (r - l), (u - t[1]) / (u - d)]
}

/// The tangent at eye uv `uv` of the eye image of `fov` (inverse of [`eye_uv`]).
pub fn tangent_of_eye(fov: &Fov, uv: [f64; 2]) -> [f64; 2] {
    let [l, r, u, d] = fov.tangents();
    [l + uv[0] * (r - l), u - uv[1] * (u - d)]
}

#[cfg(test)]
mod tests;
