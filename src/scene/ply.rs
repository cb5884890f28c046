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
//! [`super::points::MAX_EXTENT_M`]). The file is streamed twice, a record
//! at a time (the parser's per-element calls): once to check it and find
//! the bounds and intensity range, once to write each vertex straight into
//! the cloud, so reading holds no more than the cloud's own 17 bytes a
//! point.

use super::points::{PointCloud, Survey, MAX_POINTS};
use crate::error::{Error, Result};
use glam::DVec3;
use ply_rs_bw::{parser, ply};
use std::io::BufRead;
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
    let mut cloud = read_from(path, size, file, || {
        super::points::open_point_file(path).map(|(file, _)| file)
    })?;
    cloud.source = Some(path.to_path_buf());
    Ok(cloud)
}

/// [`read_ply`] of a file's bytes in memory (`name` names it in errors;
/// what the fuzz target reads).
pub fn read_ply_bytes(name: &Path, bytes: &[u8]) -> Result<PointCloud> {
    let open = || std::io::Cursor::new(bytes);
    read_from(name, bytes.len() as u64, open(), || Ok(open()))
}

/// The cloud in two streaming passes over the file (`first` is read by the
/// first, `again` opens it for the second):
/// the first checks every record and finds the bounds and the intensity
/// range, the second converts each vertex straight into the cloud's f32
/// offsets, colours and classes. Memory holds one record besides the
/// cloud itself (17 bytes a point), not the file's points as read.
fn read_from<R: BufRead>(
    path: &Path,
    size: u64,
    first: R,
    again: impl FnOnce() -> Result<R>,
) -> Result<PointCloud> {
    let mut survey = Survey::new();
    let mut top_intensity: f64 = 0.0;
    each_vertex(path, first, size, true, |_, v| {
        survey.add(path, y_up(v))?;
        if let Some(t) = v.intensity {
            top_intensity = top_intensity.max(t);
        }
        Ok(())
    })?;
    let mut cloud = survey.empty_cloud(path)?;
    let grey_scale = if top_intensity <= 1.0 {
        255.0
    } else if top_intensity <= 255.0 {
        1.0
    } else {
        255.0 / top_intensity
    };
    let second = each_vertex(path, again()?, size, false, |_, v| {
        let grey = v
            .intensity
            .map_or(255.0, |i| (i * grey_scale).clamp(0.0, 255.0)) as u8;
        let c = v
            .rgb
            .map_or([grey; 3], |c| c.map(|x| (x * 255.0).round() as u8));
        cloud.push_world(y_up(v), [c[0], c[1], c[2], grey], v.class);
        Ok(())
    })?;
    if second != survey.count || cloud.len() as u64 != survey.count {
        return Err(bad(path, "the file changed while it was read"));
    }
    Ok(cloud)
}

/// A vertex's position with z up turned to y up: (x, y, z) → (x, z, −y).
fn y_up(v: &Vertex) -> DVec3 {
    DVec3::new(v.p[0], v.p[2], -v.p[1])
}

/// One pass over `read`: parses the header (checking it as [`read_ply`]
/// documents), reads past the elements before `vertex` record by record,
/// hands each vertex to `each` with its index, and with `rest` reads past
/// the elements after it (so a file cut short there is an error) — else it
/// stops after the last vertex. Returns the vertex count.
fn each_vertex<R: BufRead>(
    path: &Path,
    read: R,
    size: u64,
    rest: bool,
    mut each: impl FnMut(u64, &Vertex) -> Result<()>,
) -> Result<u64> {
    let mut reader = parser::Reader::new(read);
    let vertex_parser = parser::Parser::<Vertex>::new();
    let other_parser = parser::Parser::<ply::DefaultElement>::new();
    let header = vertex_parser.read_header(&mut reader).map_err(|e| {
        bad(
            path,
            format!("not a PLY file, or its header is malformed: {e}"),
        )
    })?;
    if !header.elements.contains_key("vertex") {
        return Err(bad(path, "the file has no vertex element"));
    }
    let mut count = None;
    let mut line = String::new();
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
        let vertex = name == "vertex";
        if vertex {
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
        } else if count.is_some() && !rest {
            break;
        }
        let what = if vertex {
            "vertex data".to_string()
        } else {
            format!("'{name}' data")
        };
        let fail = |e: ply_rs_bw::parser::ParseError| bad(path, format!("{what}: {e}"));
        for i in 0..element.count as u64 {
            let inner = reader.get_mut();
            if matches!(header.encoding, ply::Encoding::Ascii) {
                read_line(path, inner, &mut line, &what, i, element.count)?;
            }
            if vertex {
                let v = read_record(&vertex_parser, &header.encoding, inner, &line, element)
                    .map_err(fail)?;
                each(i, &v)?;
            } else {
                read_record(&other_parser, &header.encoding, inner, &line, element)
                    .map_err(fail)?;
            }
        }
        if vertex {
            count = Some(element.count as u64);
        }
    }
    Ok(count.unwrap_or(0))
}

/// One record of `element` by `parser` in `encoding`: an ASCII record from
/// `line` (already read), a binary one from `read`.
fn read_record<E: ply::PropertyAccess, R: BufRead>(
    parser: &parser::Parser<E>,
    encoding: &ply::Encoding,
    read: &mut R,
    line: &str,
    element: &ply::ElementDef,
) -> std::result::Result<E, parser::ParseError> {
    match encoding {
        ply::Encoding::Ascii => parser.read_ascii_element(line, element),
        ply::Encoding::BinaryLittleEndian => parser.read_little_endian_element(read, element),
        ply::Encoding::BinaryBigEndian => parser.read_big_endian_element(read, element),
    }
}

/// Reads record `i` of `count` of an ASCII element (one line) into `line`;
/// the end of the file before it is an error naming `what`.
fn read_line<R: BufRead>(
    path: &Path,
    read: &mut R,
    line: &mut String,
    what: &str,
    i: u64,
    count: usize,
) -> Result<()> {
    line.clear();
    let n = read.read_line(line).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    if n == 0 {
        return Err(bad(
            path,
            format!("{what}: the file ends after {i} of {count} records"),
        ));
    }
    Ok(())
}
