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
    for (k, scan) in scans.iter().enumerate() {
        if scan.records > 0 && record_bits(&scan.prototype) == 0 {
            return Err(bad(
                path,
                format!(
                    "scan {k}: every field of its prototype takes no bits (integer fields with minimum == maximum), so the file cannot bound its {} points",
                    scan.records
                ),
            ));
        }
    }
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

/// The bits one record of `prototype` takes in the file's byte streams
/// (ASTM E57 §8.4.19: an integer field of range [min, max] packs into
/// ⌈log2(max − min + 1)⌉ bits, none when min == max; floats take 32 or
/// 64). The `e57` crate fills a zero-bit field's queue up to its other
/// fields' lengths, without limit when no field takes a bit.
pub fn record_bits(prototype: &[Record]) -> u64 {
    let int_bits = |min: i64, max: i64| -> u64 {
        let range = (i128::from(max) - i128::from(min)).max(0) as u128;
        u64::from(128 - range.leading_zeros())
    };
    prototype
        .iter()
        .map(|r| match r.data_type {
            RecordDataType::Single { .. } => 32,
            RecordDataType::Double { .. } => 64,
            RecordDataType::ScaledInteger { min, max, .. } => int_bits(min, max),
            RecordDataType::Integer { min, max } => int_bits(min, max),
        })
        .sum()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An E57 file of `n` points whose coordinate fields are
    /// ScaledIntegers of range [`lo`, `hi`] (the crate writes the values).
    fn scaled_file(n: usize, lo: i64, hi: i64) -> Vec<u8> {
        let field = |name| Record {
            name,
            data_type: RecordDataType::ScaledInteger {
                min: lo,
                max: hi,
                scale: 0.001,
                offset: 0.0,
            },
        };
        let prototype = vec![
            field(RecordName::CartesianX),
            field(RecordName::CartesianY),
            field(RecordName::CartesianZ),
        ];
        let mut out = std::io::Cursor::new(Vec::new());
        {
            let mut w = e57::E57Writer::new(&mut out, "zero-bits").unwrap();
            let mut scan = w.add_pointcloud("scan", prototype).unwrap();
            for _ in 0..n {
                let v = RecordValue::ScaledInteger(lo);
                scan.add_point(vec![v.clone(), v.clone(), v]).unwrap();
            }
            scan.finalize().unwrap();
            w.finalize().unwrap();
        }
        out.into_inner()
    }

    /// CRC-32C (Castagnoli), as E57 pages carry it (big-endian).
    fn crc32c(data: &[u8]) -> u32 {
        !data.iter().fold(!0u32, |mut c, &b| {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    (c >> 1) ^ 0x82F6_3B78
                } else {
                    c >> 1
                };
            }
            c
        })
    }

    /// `bytes` with every `from` replaced by `to` (same length) and the
    /// CRCs of the 1024-byte pages touched written again.
    fn patch(mut bytes: Vec<u8>, from: &[u8], to: &[u8]) -> Vec<u8> {
        let mut at = 0;
        while let Some(k) = bytes[at..].windows(from.len()).position(|w| w == from) {
            let i = at + k;
            bytes[i..i + to.len()].copy_from_slice(to);
            for page in [i / 1024, (i + to.len()) / 1024] {
                let p = page * 1024;
                let crc = crc32c(&bytes[p..p + 1020]).to_be_bytes();
                bytes[p + 1020..p + 1024].copy_from_slice(&crc);
            }
            at = i + to.len();
        }
        bytes
    }

    #[test]
    fn a_prototype_of_zero_bit_fields_is_refused_before_reading() {
        // The crate will not write zero-bit fields; a one-bit file's
        // prototype is edited to range [5, 5].
        let one = scaled_file(100, 5, 6);
        let bytes = patch(one, b"maximum=\"6\"", b"maximum=\"5\"");
        let e = read_e57_bytes(Path::new("zero.e57"), &bytes)
            .unwrap_err()
            .to_string();
        assert!(e.contains("takes no bits"), "{e}");
        // One bit a field reads as before.
        let ok = read_e57_bytes(Path::new("one.e57"), &scaled_file(100, 5, 6)).unwrap();
        assert_eq!(ok.len(), 100);
    }

    #[test]
    fn record_bits_follow_the_integer_range() {
        let int = |min, max| Record {
            name: RecordName::Intensity,
            data_type: RecordDataType::Integer { min, max },
        };
        assert_eq!(record_bits(&[int(3, 3)]), 0);
        assert_eq!(record_bits(&[int(0, 1)]), 1);
        assert_eq!(record_bits(&[int(0, 255)]), 8);
        assert_eq!(record_bits(&[int(0, 256)]), 9);
        assert_eq!(record_bits(&[int(i64::MIN, i64::MAX)]), 64);
        assert_eq!(record_bits(&[int(4, 2)]), 0);
    }
}
