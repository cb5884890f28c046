//! Resource URIs in glTF files, confined to the scene file's folder.
//!
//! A scene file from elsewhere must not make vergence read anything outside
//! its folder: absolute paths, `..` that climbs out, symbolic links that point
//! out, and URLs with a scheme (`http:`, `file:`, ...) are rejected; data:
//! URIs are decoded with a size limit; files are size-checked before they are
//! read. glTF 2.0 §3.2 ("URIs"): relative references resolve against the
//! glTF file's location; percent-encoding per RFC 3986 §2.1.

use base64::Engine;
use std::path::{Component, Path, PathBuf};

/// Largest payload a data: URI may decode to.
pub const MAX_DATA_URI_BYTES: usize = 256 << 20;
/// Largest external buffer or image file read.
pub const MAX_RESOURCE_FILE_BYTES: u64 = crate::fsio::MAX_SCENE_FILE_BYTES;

/// Reads the resource `uri` refers to from `dir` (the scene file's folder),
/// or decodes it when it is a data: URI. The error says why it was refused.
pub fn read(dir: &Path, uri: &str) -> Result<Vec<u8>, String> {
    read_within(dir, uri, u64::MAX)
}

/// Like [`read`], refusing (before allocating) a resource larger than
/// `max_bytes`: what is left of a scene's total resource budget.
pub fn read_within(dir: &Path, uri: &str, max_bytes: u64) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let payload = rest
            .split_once(";base64,")
            .map_or(0, |(_, p)| p.len() as u64);
        if payload / 4 * 3 > max_bytes {
            return Err(format!(
                "data URI would exceed the scene's remaining resource budget of {max_bytes} bytes"
            ));
        }
        return decode_data(rest);
    }
    let file = confine(dir, uri)?;
    let meta = std::fs::metadata(&file).map_err(|e| format!("{}: {e}", file.display()))?;
    if meta.is_file() && meta.len() > max_bytes {
        return Err(format!(
            "{} ({} bytes) would exceed the scene's remaining resource budget of {max_bytes} bytes",
            file.display(),
            meta.len()
        ));
    }
    crate::fsio::read_bounded(&file, max_bytes.min(MAX_RESOURCE_FILE_BYTES))
        .map_err(|e| format!("{}: {e}", file.display()))
}

fn decode_data(rest: &str) -> Result<Vec<u8>, String> {
    let (_, payload) = rest
        .split_once(";base64,")
        .ok_or("data URI is not base64-encoded")?;
    // Four base64 characters carry three bytes: bound the output before
    // allocating it.
    let max_out = payload.len() / 4 * 3 + 3;
    if max_out > MAX_DATA_URI_BYTES + 3 {
        return Err(format!(
            "data URI of {} base64 characters exceeds the {MAX_DATA_URI_BYTES} byte limit",
            payload.len()
        ));
    }
    base64::engine::general_purpose::STANDARD
        .decode(payload)
        .map_err(|e| format!("invalid base64 in data URI: {e}"))
}

/// Whether `uri` starts with an RFC 3986 scheme (`ALPHA *( ALPHA / DIGIT /
/// "+" / "-" / "." ) ":"`), or a Windows drive letter, which parses as one.
fn has_scheme(uri: &str) -> bool {
    match uri.split_once(':') {
        Some((scheme, _)) => {
            let mut c = scheme.chars();
            c.next().is_some_and(|f| f.is_ascii_alphabetic())
                && c.all(|ch| ch.is_ascii_alphanumeric() || "+-.".contains(ch))
        }
        None => false,
    }
}

/// The file `uri` names inside `dir`, or why it is refused. Checked twice:
/// lexically (no scheme, not absolute, no `..` above `dir`), then after
/// resolving symbolic links (the real path must lie inside `dir`'s real
/// path).
pub fn confine(dir: &Path, uri: &str) -> Result<PathBuf, String> {
    if has_scheme(uri) {
        return Err(format!(
            "URI '{uri}' has a scheme; only relative paths inside the scene folder and data: URIs are allowed"
        ));
    }
    let decoded = percent_decode(uri);
    if decoded.contains('\0') {
        return Err(format!("URI '{uri}' contains a NUL character"));
    }
    let rel = Path::new(&decoded);
    if decoded.starts_with(['/', '\\']) || rel.is_absolute() {
        return Err(format!(
            "URI '{uri}' is an absolute path; it must be relative to the scene folder"
        ));
    }
    let mut depth = 0usize;
    for c in rel.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir => {
                depth = depth.checked_sub(1).ok_or_else(|| {
                    format!("URI '{uri}' climbs out of the scene folder with '..'")
                })?
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err(format!("URI '{uri}' is an absolute path"))
            }
        }
    }
    let file = dir.join(rel);
    let real_dir = std::fs::canonicalize(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    })
    .map_err(|e| format!("scene folder {}: {e}", dir.display()))?;
    match std::fs::canonicalize(&file) {
        Ok(real) if real.starts_with(&real_dir) => Ok(real),
        Ok(real) => Err(format!(
            "URI '{uri}' resolves to {}, outside the scene folder {} (through a symbolic link)",
            real.display(),
            real_dir.display()
        )),
        Err(e) => Err(format!("URI '{uri}' ({}): {e}", file.display())),
    }
}

/// Percent-decoding (RFC 3986 §2.1); invalid escapes are kept as they are.
pub fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let (h, l) = (bytes[i + 1], bytes[i + 2]);
            if let (true, Some(v)) = (
                h.is_ascii_hexdigit() && l.is_ascii_hexdigit(),
                std::str::from_utf8(&bytes[i + 1..i + 3])
                    .ok()
                    .and_then(|x| u8::from_str_radix(x, 16).ok()),
            ) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("vergence-uri-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("scene/tex")).unwrap();
        std::fs::write(d.join("scene/tex/a.png"), b"x").unwrap();
        std::fs::write(d.join("scene/b.bin"), b"yz").unwrap();
        std::fs::write(d.join("secret.txt"), b"secret").unwrap();
        d
    }

    #[test]
    fn inside_paths_resolve() {
        let d = tmp("ok");
        let dir = d.join("scene");
        assert_eq!(read(&dir, "b.bin").unwrap(), b"yz");
        assert_eq!(read(&dir, "tex/../b.bin").unwrap(), b"yz");
        assert_eq!(read(&dir, "./tex/a.png").unwrap(), b"x");
        assert_eq!(read(&dir, "tex%2Fa.png").unwrap(), b"x");
    }

    #[test]
    fn escapes_are_refused() {
        let d = tmp("bad");
        let dir = d.join("scene");
        let abs = d.join("secret.txt").display().to_string();
        for (uri, want) in [
            ("../secret.txt", "climbs out"),
            ("tex/../../secret.txt", "climbs out"),
            ("%2E%2E/secret.txt", "climbs out"),
            (abs.as_str(), "absolute"),
            ("file:///etc/passwd", "scheme"),
            ("http://example.com/a.bin", "scheme"),
            ("C:/Windows/win.ini", "scheme"),
            ("b.bin%00.png", "NUL"),
            ("tex", "not a regular file"),
            ("missing.bin", "missing.bin"),
        ] {
            let e = read(&dir, uri).unwrap_err();
            assert!(e.contains(want), "{uri}: {e}");
        }
        std::os::unix::fs::symlink(d.join("secret.txt"), dir.join("link.txt")).unwrap();
        let e = read(&dir, "link.txt").unwrap_err();
        assert!(e.contains("outside the scene folder"), "{e}");
    }

    #[test]
    fn data_uris_decode_with_a_limit() {
        assert_eq!(
            decode_data("application/octet-stream;base64,AAEC").unwrap(),
            [0, 1, 2]
        );
        assert!(decode_data("text/plain,hello")
            .unwrap_err()
            .contains("base64"));
        let huge = format!(";base64,{}", "A".repeat(MAX_DATA_URI_BYTES / 3 * 4 + 16));
        assert!(decode_data(&huge).unwrap_err().contains("limit"));
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b%zz%4"), "a b%zz%4");
        assert_eq!(percent_decode("%"), "%");
        assert_eq!(percent_decode("é%41"), "éA");
        assert_eq!(percent_decode("%+F"), "%+F");
    }
}
