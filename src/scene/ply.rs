//! Point clouds in PLY (ASCII, binary little- and big-endian; the
//! maintained `ply-rs-bw` parser): the `vertex` element's `x`, `y`, `z`
//! (any numeric type), its colour (`red`/`green`/`blue` or `r`/`g`/`b`:
//! 8-bit, 16-bit or 0–1 floats), an intensity (`intensity` or
//! `scalar_intensity`) used as grey when there is no colour, and a
//! classification (`classification` or `scalar_classification`). Other
//! elements (faces of a mesh) are read past and not used. Scans store z up,
//! as LAS does: (x, y, z) becomes vergence's (x, z, −y). The cloud's origin
//! is its bounds' centre to the metre; the same checks as LAS apply (count
//! within [`super::points::MAX_POINTS`], finite coordinates, extent within
//! [`super::points::MAX_EXTENT_M`]).

use super::points::{PointCloud, MAX_POINTS};
use crate::error::{Error, Result};
use ply_rs_bw::{parser, ply};
use std::path::Path;

/// One vertex as read.
#[derive(Clone, Copy, Debug, Default)]
struct Vertex {
    p: [f64; 3],
    /// Colour as 0–1, when the file has one.
    rgb: Option<[f32; 3]>,
    intensity: Option<f64>,
    class: u8,
}

fn number(p: &ply::Property) -> Option<f64> {
    use ply::Property as P;
    Some(match *p {
        P::Char(v) => v as f64,
        P::UChar(v) => v as f64,
        P::Short(v) => v as f64,
        P::UShort(v) => v as f64,
        P::Int(v) => v as f64,
        P::UInt(v) => v as f64,
        P::Float(v) => v as f64,
        P::Double(v) => v,
        _ => return None,
    })
}

/// A colour channel as 0–1: 8-bit and 16-bit integers by their range,
/// floats as they are.
fn channel(p: &ply::Property) -> Option<f32> {
    use ply::Property as P;
    Some(match *p {
        P::UChar(v) => v as f32 / 255.0,
        P::UShort(v) => v as f32 / 65535.0,
        P::Float(v) => v.clamp(0.0, 1.0),
        P::Double(v) => v.clamp(0.0, 1.0) as f32,
        _ => number(p)?.clamp(0.0, 255.0) as f32 / 255.0,
    })
}

impl ply::PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }

    fn set_property(&mut self, key: &str, property: ply::Property) -> ply::PropertyAccessResult {
        let axis = match key {
            "x" => Some(0),
            "y" => Some(1),
            "z" => Some(2),
            _ => None,
        };
        if let Some(a) = axis {
            return match number(&property) {
                Some(v) => {
                    self.p[a] = v;
                    ply::PropertyAccessResult::Set
                }
                None => ply::PropertyAccessResult::UnsupportedType,
            };
        }
        let colour = match key {
            "red" | "r" => Some(0),
            "green" | "g" => Some(1),
            "blue" | "b" => Some(2),
            _ => None,
        };
        if let Some(c) = colour {
            return match channel(&property) {
                Some(v) => {
                    self.rgb.get_or_insert([0.0; 3])[c] = v;
                    ply::PropertyAccessResult::Set
                }
                None => ply::PropertyAccessResult::UnsupportedType,
            };
        }
        match key {
            "intensity" | "scalar_intensity" => {
                self.intensity = number(&property);
                ply::PropertyAccessResult::Set
            }
            "classification" | "scalar_classification" => {
                self.class = number(&property).map_or(0, |v| v.clamp(0.0, 255.0) as u8);
                ply::PropertyAccessResult::Set
            }
            _ => ply::PropertyAccessResult::Ignored,
        }
    }
}

/// The error for `path`, its message on one line (the parser's messages
/// carry tabs and line breaks).
fn bad(path: &Path, message: impl Into<String>) -> Error {
    let message: String = message.into();
    Error::Scene {
        path: path.to_path_buf(),
        message: message.split_whitespace().collect::<Vec<_>>().join(" "),
    }
}

/// Whether `path` names a PLY file (by extension).
pub fn is_ply(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("ply"))
}

/// Reads a PLY point cloud.
pub fn read_ply(path: &Path) -> Result<PointCloud> {
    let (file, size) = super::points::open_point_file(path)?;
    let mut cloud = read_from(path, file, size)?;
    cloud.source = Some(path.to_path_buf());
    Ok(cloud)
}

/// [`read_ply`] of a file's bytes in memory (`name` names it in errors;
/// what the fuzz target reads).
pub fn read_ply_bytes(name: &Path, bytes: &[u8]) -> Result<PointCloud> {
    read_from(name, std::io::Cursor::new(bytes), bytes.len() as u64)
}

fn read_from<R: std::io::BufRead>(path: &Path, read: R, size: u64) -> Result<PointCloud> {
    let mut reader = parser::Reader::new(read);
    let vertex_parser = parser::Parser::<Vertex>::new();
    let other_parser = parser::Parser::<ply::DefaultElement>::new();
    let header = vertex_parser.read_header(&mut reader).map_err(|e| {
        bad(
            path,
            format!("not a PLY file, or its header is malformed: {e}"),
        )
    })?;
    let mut vertices: Option<Vec<Vertex>> = None;
    for (name, element) in &header.elements {
        // Every element takes at least a byte a record: a count past the
        // file's size is a lie.
        if element.count as u64 > size {
            return Err(bad(
                path,
                format!(
                    "the header says {} '{name}' elements, more than the file's {size} bytes hold",
                    element.count
                ),
            ));
        }
        if name == "vertex" {
            if element.count as u64 > MAX_POINTS {
                return Err(bad(
                    path,
                    format!(
                        "the header says {} points, over the {MAX_POINTS}-point limit",
                        element.count
                    ),
                ));
            }
            for axis in ["x", "y", "z"] {
                if !element.properties.contains_key(axis) {
                    return Err(bad(
                        path,
                        format!("the vertex element has no '{axis}' property"),
                    ));
                }
            }
            let v = vertex_parser
                .read_payload_for_element(&mut reader, element, &header)
                .map_err(|e| bad(path, format!("vertex data: {e}")))?;
            vertices = Some(v);
        } else {
            other_parser
                .read_payload_for_element(&mut reader, element, &header)
                .map_err(|e| bad(path, format!("'{name}' data: {e}")))?;
        }
    }
    let vertices = vertices.ok_or_else(|| bad(path, "the file has no vertex element"))?;
    cloud_of(path, &vertices)
}

/// The cloud of `vertices`: z up turned to y up, intensity scaled to a
/// byte (0–1, 0–255 or wider ranges), checked and re-centred by
/// [`super::points::cloud_of_world`].
fn cloud_of(path: &Path, vertices: &[Vertex]) -> Result<PointCloud> {
    let top = vertices
        .iter()
        .filter_map(|v| v.intensity)
        .fold(0.0f64, f64::max);
    let grey_scale = if top <= 1.0 {
        255.0
    } else if top <= 255.0 {
        1.0
    } else {
        255.0 / top
    };
    let world: Vec<[f64; 3]> = vertices.iter().map(|v| [v.p[0], v.p[2], -v.p[1]]).collect();
    let colors = vertices
        .iter()
        .map(|v| {
            let grey = v
                .intensity
                .map_or(255.0, |i| (i * grey_scale).clamp(0.0, 255.0)) as u8;
            let c = v
                .rgb
                .map_or([grey; 3], |c| c.map(|x| (x * 255.0).round() as u8));
            [c[0], c[1], c[2], grey]
        })
        .collect();
    let classes = vertices.iter().map(|v| v.class).collect();
    super::points::cloud_of_world(path, &world, colors, classes)
}
