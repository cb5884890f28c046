//! Point clouds in ASTM E57 (the `e57` crate): every scan of the file, its
//! pose applied and spherical coordinates turned Cartesian by the crate,
//! colour (normalised by the file's colour limits) or else intensity as
//! grey. Points the file marks invalid are skipped. E57 is z up, as LAS
//! is: (x, y, z) becomes vergence's (x, z, −y). The cloud's origin is its
//! bounds' centre to the metre; the same checks as LAS apply (count within
//! [`super::points::MAX_POINTS`], finite coordinates, extent within
//! [`super::points::MAX_EXTENT_M`]). The points are held as f64 while read
//! (about 30 bytes a point) before the cloud keeps them as f32 offsets.

use super::points::{PointCloud, MAX_POINTS};
use crate::error::{Error, Result};
use std::path::Path;

fn bad(path: &Path, message: impl Into<String>) -> Error {
    Error::Scene {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Whether `path` names an E57 file (by extension).
pub fn is_e57(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("e57"))
}

/// Reads an E57 point cloud (all its scans together).
pub fn read_e57(path: &Path) -> Result<PointCloud> {
    let (file, size) = super::points::open_point_file(path)?;
    let mut cloud = read_from(path, file, size)?;
    cloud.source = Some(path.to_path_buf());
    Ok(cloud)
}

/// [`read_e57`] of a file's bytes in memory (`name` names it in errors;
/// what the fuzz target reads).
pub fn read_e57_bytes(name: &Path, bytes: &[u8]) -> Result<PointCloud> {
    read_from(name, std::io::Cursor::new(bytes), bytes.len() as u64)
}

fn read_from<R: std::io::Read + std::io::Seek>(
    path: &Path,
    read: R,
    size: u64,
) -> Result<PointCloud> {
    let mut reader = e57::E57Reader::new(read)
        .map_err(|e| bad(path, format!("not a readable E57 file: {e}")))?;
    let scans = reader.pointclouds();
    let total: u64 = scans.iter().map(|s| s.records).sum();
    if total > MAX_POINTS {
        return Err(bad(
            path,
            format!("the file lists {total} points, over the {MAX_POINTS}-point limit"),
        ));
    }
    // Every record takes at least a bit of the file.
    if total > size.saturating_mul(8) {
        return Err(bad(
            path,
            format!("the file lists {total} points, more than its {size} bytes hold"),
        ));
    }
    let mut world: Vec<[f64; 3]> = Vec::new();
    let mut colors: Vec<[u8; 4]> = Vec::new();
    for (k, scan) in scans.iter().enumerate() {
        let points = reader
            .pointcloud_simple(scan)
            .map_err(|e| bad(path, format!("scan {k}: {e}")))?;
        for p in points {
            let p = p.map_err(|e| bad(path, format!("scan {k}, point {}: {e}", world.len())))?;
            let e57::CartesianCoordinate::Valid { x, y, z } = p.cartesian else {
                continue;
            };
            if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                return Err(bad(
                    path,
                    format!("scan {k}: point {} is not finite", world.len()),
                ));
            }
            let grey = p
                .intensity
                .map_or(255, |i| (i.clamp(0.0, 1.0) * 255.0).round() as u8);
            let rgb = p.color.map_or([grey; 3], |c| {
                [c.red, c.green, c.blue].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            });
            world.push([x, z, -y]);
            colors.push([rgb[0], rgb[1], rgb[2], grey]);
        }
    }
    let classes = vec![0; colors.len()];
    super::points::cloud_of_world(path, &world, colors, classes)
}
