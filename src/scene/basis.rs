//! Basis Universal payloads of KTX2 textures (KHR_texture_basisu): ETC1S
//! (BasisLZ supercompression) and UASTC (optionally Zstandard
//! supercompressed), transcoded to RGBA8 with the pure-Rust `basisu`
//! transcoder, a port of Binomial's reference C++ transcoder.

use basisu::{DecodeFlags, SourceFormat, TargetFormat, Transcoder};

/// Transcodes level 0 of a Basis Universal KTX2 file whose header (already
/// checked against the texture limits) says `w`×`h` into RGBA8.
pub fn transcode_rgba8(bytes: &[u8], w: u32, h: u32) -> Result<image::RgbaImage, String> {
    let fail = |what: &str, e: basisu::Error| {
        format!("KTX2 image's Basis Universal payload {what}: {e:?}")
    };
    let t = Transcoder::new(bytes).map_err(|e| fail("cannot be read", e))?;
    if t.base_dimensions() != (w, h) {
        return Err(format!(
            "KTX2 image's Basis Universal payload is {:?}, but its header says {w}x{h}",
            t.base_dimensions()
        ));
    }
    match t.source_format() {
        SourceFormat::Etc1s | SourceFormat::UastcLdr => {}
        other => {
            return Err(format!(
                "KTX2 image holds Basis Universal {other:?}; only ETC1S and UASTC (LDR) are decoded"
            ))
        }
    }
    // The transcoder reports a block stream it cannot decode as an
    // unsupported feature; for a payload that passed the checks above
    // that means corrupt data.
    let rgba = t
        .transcode(0, TargetFormat::Rgba32, DecodeFlags::NONE)
        .map_err(|e| match e {
            basisu::Error::UnsupportedFeature(_) => {
                "KTX2 image's Basis Universal payload cannot be transcoded: its level 0 data is corrupt".to_string()
            }
            e => fail("cannot be transcoded", e),
        })?;
    image::RgbaImage::from_raw(w, h, rgba)
        .ok_or_else(|| "KTX2 image's transcoded level 0 does not match its size".to_string())
}
