//! Point files by their extension: the one place that knows every point
//! reader (LAS/LAZ in [`super::points`], PLY in [`super::ply`], E57 in
//! [`super::e57`]), so the readers need not know each other.

use super::points::{read_las, PointCloud};
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
