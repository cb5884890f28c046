//! Point files by their extension: the one place that knows every point
//! reader and writer (LAS/LAZ in [`super::points`], PLY in [`super::ply`], E57 in
//! [`super::e57`]), so the readers need not know each other.

use super::points::{is_las, read_las, write_las, PointCloud};
use crate::error::Result;
use std::path::Path;

/// Reads a point file by its extension: PLY ([`super::ply::read_ply`]),
/// E57 ([`super::e57::read_e57`]), else LAS or LAZ ([`read_las`]).
pub fn read_file(path: &Path) -> Result<PointCloud> {
    if super::ply::is_ply(path) {
        super::ply::read_ply(path)
    } else if super::e57::is_e57(path) {
        super::e57::read_e57(path)
    } else {
        read_las(path)
    }
}

/// LAS coordinates' step when vergence writes them, metres (half a
/// millimetre: below any scanner's range noise).
pub const LAS_SCALE_M: f64 = 0.0005;

/// Whether [`write_file`] writes a file of that name: `.las`, `.laz` or
/// `.e57`.
pub fn writes(path: &Path) -> bool {
    is_las(path) || super::e57::is_e57(path)
}

/// Writes a point file by its extension: E57 ([`super::e57::write_e57`]),
/// else LAS or LAZ ([`write_las`] at [`LAS_SCALE_M`]).
pub fn write_file(path: &Path, cloud: &PointCloud) -> Result<()> {
    if cloud.is_empty() {
        return Err(crate::error::Error::Output {
            path: path.to_path_buf(),
            message: "no points to write (a point file without points is not readable)".into(),
        });
    }
    if super::e57::is_e57(path) {
        super::e57::write_e57(path, cloud)
    } else {
        write_las(path, cloud, LAS_SCALE_M)
    }
}
