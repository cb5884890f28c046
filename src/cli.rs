//! Value parsers and upper bounds of the command line. Every count,
//! duration, thread number and real-valued option has a documented range;
//! a value outside it is one error naming the option (clap prints it and
//! exits with status 2). The parsers live in the library so the fuzz
//! targets can reach them.

use crate::view::Pose;
use glam::DVec3;

/// Most seconds `run --seconds` accepts (about 11.6 days).
pub const MAX_RUN_SECONDS: f64 = 1e6;
/// Most frames `run --frames` accepts.
pub const MAX_RUN_FRAMES: u64 = 1_000_000_000;
/// Most frames `cull-bench --frames` accepts.
pub const MAX_CULL_BENCH_FRAMES: u64 = 1_000_000;
/// Most worker threads `cull-bench --threads` accepts.
pub const MAX_THREADS: usize = 64;
/// Largest `cull-bench --leaf-size`.
pub const MAX_LEAF_SIZE: usize = 65_536;
/// Largest per-eye `--width` / `--height` in pixels.
pub const MAX_EYE_PIXELS: u32 = 16_384;
/// Largest distance (metres) a pose, near plane or draw distance may give.
pub const MAX_DISTANCE_M: f64 = 1e9;

/// A finite number in `lo..=hi` (`lo` excluded when `open_lo`).
fn ranged(s: &str, lo: f64, hi: f64, open_lo: bool) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    let ok = v.is_finite() && (if open_lo { v > lo } else { v >= lo }) && v <= hi;
    if ok {
        Ok(v)
    } else {
        Err(format!(
            "{s} must be a number in {}{lo}, {hi}]",
            if open_lo { "(" } else { "[" }
        ))
    }
}

/// `--seconds`: a duration in (0, [`MAX_RUN_SECONDS`]] seconds.
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, MAX_RUN_SECONDS, true)
}

/// `--lens-half-angle`: radians in (0, π/2).
pub fn parse_lens_half_angle(s: &str) -> Result<f64, String> {
    match ranged(s, 0.0, std::f64::consts::FRAC_PI_2, true) {
        Ok(v) if v < std::f64::consts::FRAC_PI_2 => Ok(v),
        _ => Err(format!(
            "{s} must be an angle in radians in (0, π/2) (a cone narrower than a half space)"
        )),
    }
}

/// Largest head turn rate `render --head-turn` accepts (degrees per second).
pub const MAX_HEAD_TURN_DEG_S: f64 = 3600.0;

/// `render --head-turn`: degrees per second in
/// [−[`MAX_HEAD_TURN_DEG_S`], [`MAX_HEAD_TURN_DEG_S`]].
pub fn parse_head_turn(s: &str) -> Result<f64, String> {
    ranged(s, -MAX_HEAD_TURN_DEG_S, MAX_HEAD_TURN_DEG_S, false)
}

/// `--near`: metres in (0, 1000].
pub fn parse_near(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, 1e3, true)
}

/// `--draw-distance`: metres in (0, [`MAX_DISTANCE_M`]].
pub fn parse_distance(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, MAX_DISTANCE_M, true)
}

/// A positive real up to 1e6 (`--budget-ms`, `--scale` and the like).
pub fn parse_positive(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, 1e6, true)
}

/// A real in [0, 1e6] (`--max-flip`).
pub fn parse_non_negative(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, 1e6, false)
}

/// `scan --noise`: the range noise's standard deviation in metres, in
/// [0, 10] (a scanner's noise is millimetres; larger values would only
/// throw points past what a point file's coordinates hold).
pub fn parse_scan_noise(s: &str) -> Result<f64, String> {
    ranged(s, 0.0, 10.0, false)
}

/// `--ppd`: pixels per degree in [0.01, 1000) (a positive f32 after
/// narrowing; found by the property test: a tiny f64 rounds to 0).
pub fn parse_ppd(s: &str) -> Result<f32, String> {
    match ranged(s, 0.01, 1000.0, false) {
        Ok(v) if v < 1000.0 => Ok(v as f32),
        _ => Err(format!("{s} must be a number in [0.01, 1000)")),
    }
}

/// `--pose x,y,z,yaw,pitch,roll`: metres within ±[`MAX_DISTANCE_M`],
/// degrees within ±36000.
pub fn parse_pose(s: &str) -> Result<Pose, String> {
    let v = six_numbers(s, "x,y,z,yaw,pitch,roll", |i| {
        if i < 3 {
            (MAX_DISTANCE_M, " (metres)")
        } else {
            (36_000.0, " (degrees)")
        }
    })?;
    Ok(Pose::from_euler_deg(
        DVec3::new(v[0], v[1], v[2]),
        v[3],
        v[4],
        v[5],
    ))
}

/// Six comma-separated numbers, the i-th finite and within ±`bound(i).0`
/// (`bound(i).1` follows the limit in the error); `names` lists them in
/// the error for a wrong count.
fn six_numbers(
    s: &str,
    names: &str,
    bound: impl Fn(usize) -> (f64, &'static str),
) -> Result<[f64; 6], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 6 {
        return Err(format!("expected 6 numbers {names}, got {}", parts.len()));
    }
    let mut v = [0.0f64; 6];
    for (i, p) in parts.iter().enumerate() {
        let x: f64 = p
            .trim()
            .parse()
            .map_err(|_| format!("'{p}' is not a number"))?;
        let (max, unit) = bound(i);
        if !(x.is_finite() && x.abs() <= max) {
            return Err(format!("'{p}' must be finite and within ±{max}{unit}"));
        }
        v[i] = x;
    }
    Ok(v)
}

/// `--section x,y,z,nx,ny,nz`: a plane through the point (metres within
/// ±[`MAX_DISTANCE_M`]) with the normal pointing into the side cut away, as
/// (n.x, n.y, n.z, d) with a unit normal and `n · x + d = 0` on the plane.
pub fn parse_section(s: &str) -> Result<[f64; 4], String> {
    let v = six_numbers(
        s,
        "x,y,z,nx,ny,nz (a point and the normal of the side cut away)",
        |_| (MAX_DISTANCE_M, ""),
    )?;
    let point = DVec3::new(v[0], v[1], v[2]);
    let raw = DVec3::new(v[3], v[4], v[5]);
    if raw.length() <= 1e-9 {
        return Err(format!(
            "the normal {},{},{} has no direction",
            v[3], v[4], v[5]
        ));
    }
    let n = raw.normalize();
    Ok([n.x, n.y, n.z, -n.dot(point)])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pose's `--pose` value ([`Pose::pose_arg`]) parses to the same
    /// pose, from a micrometre to the distance limit.
    #[test]
    fn a_pose_argument_parses_back_to_its_pose() {
        for (x, yaw, pitch, roll) in [
            (0.0, 0.0, 0.0, 0.0),
            (512_000.25, 37.5, -20.0, 3.0),
            (-4_100_000.5, -179.0, 88.0, -170.0),
        ] {
            let p = Pose::from_euler_deg(glam::DVec3::new(x, 1.6, -x), yaw, pitch, roll);
            let back = parse_pose(&p.pose_arg()).unwrap();
            assert!((back.position - p.position).length() < 1e-5);
            assert!(back.orientation.dot(p.orientation).abs() > 1.0 - 1e-10);
        }
    }

    #[test]
    fn values_outside_their_range_are_named() {
        assert_eq!(parse_seconds("2.5"), Ok(2.5));
        for bad in ["1e20", "0", "-1", "nan", "inf", "x", ""] {
            assert!(parse_seconds(bad).is_err(), "{bad}");
        }
        assert!(parse_seconds("1e20").unwrap_err().contains("(0, 1000000]"));
        assert!(parse_lens_half_angle("NaN").is_err());
        assert!(parse_lens_half_angle("1.5707963267948966").is_err());
        assert_eq!(parse_lens_half_angle("0.7"), Ok(0.7));
        assert!(parse_ppd("1000").is_err());
        assert!(parse_pose("1,2,3,0,0").unwrap_err().contains("got 5"));
        assert!(parse_pose("1e300,0,0,0,0,0").is_err());
        assert!(parse_pose("0,1.7,0,90,-10,0").is_ok());
        assert_eq!(parse_section("0,0,2,0,0,-3"), Ok([0.0, 0.0, -1.0, 2.0]));
        assert!(parse_section("0,0,0,0,0,0")
            .unwrap_err()
            .contains("no direction"));
        assert!(parse_section("0,0,0,1,0").unwrap_err().contains("got 5"));
        assert!(parse_section("0,0,0,1,0,nan").is_err());
        assert!(parse_section("1e300,0,0,1,0,0").is_err());
    }
}
