//! Point clouds in ASTM E57 (the `e57` crate): every scan of the file, its
//! pose applied and spherical coordinates turned Cartesian by the crate,
//! colour (normalised by the file's colour limits) or else intensity as
//! grey. Points the file marks invalid are skipped. E57 is z up, as LAS
//! is: (x, y, z) becomes vergence's (x, z, −y). The cloud's origin is its
//! first point to the metre; the same checks as LAS apply (count within
//! [`super::points::MAX_POINTS`], finite coordinates, extent within
//! [`super::points::MAX_EXTENT_M`]). The file is read once, a data packet
//! at a time, each point checked and written straight into the cloud as an
//! f32 offset, so reading holds no more than the cloud's own 17 bytes a
//! point.

use super::points::{PointCloud, Survey, MAX_POINTS};
use crate::error::{Error, Result};
use e57::{Record, RecordDataType, RecordName, RecordValue};
use glam::DVec3;
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
    // One pass: each point goes straight into the cloud as an f32 offset
    // from the first point (to the metre), while the bounds are checked.
    // An offset from the first point is at most the extent, against half
    // of it from the bounds' centre: one bit of an f32's 24 is the price
    // of reading the file once (a second pass to find the centre first
    // nearly doubled the reading time).
    let mut survey = Survey::new();
    let mut cloud = PointCloud::default();
    // Room for the points the file lists, no more than a point a byte (the
    // pages are touched only as points arrive).
    let room = total.min(size) as usize;
    cloud.positions.reserve(room);
    cloud.colors.reserve(room);
    cloud.classification.reserve(room);
    each_point(path, &mut reader, &scans, |w, color| {
        survey.add(path, w)?;
        if survey.count == 1 {
            cloud.origin = w.round();
        }
        cloud.push_world(w, color, 0);
        Ok(())
    })?;
    survey.check_extent(path)?;
    Ok(cloud)
}

/// One pass over every scan's points (the crate's simple reader: the scan's
/// pose applied, spherical coordinates turned Cartesian, colour and
/// intensity normalised by the file's limits), handing each valid point to
/// `each` turned y up, with its colour (grey from the intensity when the
/// file has no colour) and the intensity's byte. Returns the points handed.
fn each_point<R: std::io::Read + std::io::Seek>(
    path: &Path,
    reader: &mut e57::E57Reader<R>,
    scans: &[e57::PointCloud],
    mut each: impl FnMut(DVec3, [u8; 4]) -> Result<()>,
) -> Result<u64> {
    let mut handed = 0u64;
    for (k, scan) in scans.iter().enumerate() {
        let points = reader
            .pointcloud_simple(scan)
            .map_err(|e| bad(path, format!("scan {k}: {e}")))?;
        for p in points {
            let p = p.map_err(|e| bad(path, format!("scan {k}, point {handed}: {e}")))?;
            let e57::CartesianCoordinate::Valid { x, y, z } = p.cartesian else {
                continue;
            };
            let grey = p
                .intensity
                .map_or(255, |i| (i.clamp(0.0, 1.0) * 255.0).round() as u8);
            let rgb = p.color.map_or([grey; 3], |c| {
                [c.red, c.green, c.blue].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            });
            each(DVec3::new(x, z, -y), [rgb[0], rgb[1], rgb[2], grey])?;
            handed += 1;
        }
    }
    Ok(handed)
}

/// Writes `cloud` as an E57 file of one scan: Cartesian coordinates as
/// doubles, turned back to z up ((x, y, z) → (x, −z, y)), so the world
/// positions (origin + f32 offset, exact in f64) read back bit for bit;
/// 8-bit colour and the intensity's byte. E57 has no standard field for a
/// classification; it is not written. Written beside `path` and renamed
/// over it when complete.
pub fn write_e57(path: &Path, cloud: &PointCloud) -> Result<()> {
    let out = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    crate::fsio::prepare_output(path)?;
    let tmp = crate::fsio::TempFile::beside(path).map_err(|e| out(e.to_string()))?;
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let guid = format!("vergence-{}-{nanos}", std::process::id());
    write_points(tmp.file(), &guid, cloud).map_err(|e| out(e.to_string()))?;
    tmp.persist(path).map_err(|e| out(e.to_string()))
}

fn write_points(file: &std::fs::File, guid: &str, cloud: &PointCloud) -> e57::Result<()> {
    let double = |name| Record {
        name,
        data_type: RecordDataType::Double {
            min: None,
            max: None,
        },
    };
    let byte = |name| Record {
        name,
        data_type: RecordDataType::Integer { min: 0, max: 255 },
    };
    let prototype = vec![
        double(RecordName::CartesianX),
        double(RecordName::CartesianY),
        double(RecordName::CartesianZ),
        byte(RecordName::ColorRed),
        byte(RecordName::ColorGreen),
        byte(RecordName::ColorBlue),
        byte(RecordName::Intensity),
    ];
    let mut writer = e57::E57Writer::new(file, guid)?;
    {
        let mut scan = writer.add_pointcloud(&format!("{guid}-scan"), prototype)?;
        for i in 0..cloud.len() {
            let p = cloud.world(i);
            let c = cloud.colors[i];
            scan.add_point(vec![
                RecordValue::Double(p.x),
                RecordValue::Double(-p.z),
                RecordValue::Double(p.y),
                RecordValue::Integer(c[0].into()),
                RecordValue::Integer(c[1].into()),
                RecordValue::Integer(c[2].into()),
                RecordValue::Integer(c[3].into()),
            ])?;
        }
        scan.finalize()?;
    }
    writer.finalize()
}
