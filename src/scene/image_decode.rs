//! Texture decoding within limits: the header's dimensions are checked
//! before any pixel memory is allocated, so a small file that claims a huge
//! image (a decompression bomb) is an error, not an out-of-memory abort.

use std::io::Cursor;

/// Largest texture side accepted (Vulkan's guaranteed 2D image limit is
/// 4096; desktop GPUs offer 16384 or more).
pub const MAX_TEXTURE_SIDE: u32 = 16384;
/// Largest pixel count accepted (256 MiB as RGBA8).
pub const MAX_TEXTURE_PIXELS: u64 = 64 << 20;
/// Largest allocation the decoder may make.
pub const MAX_DECODE_ALLOC: u64 = 1 << 30;

/// Decodes PNG or JPEG `bytes` into RGBA8, refusing images over the limits.
pub fn decode_rgba8(bytes: &[u8]) -> Result<image::RgbaImage, String> {
    let reader = || {
        image::ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| e.to_string())
    };
    let (w, h) = reader()?.into_dimensions().map_err(|e| e.to_string())?;
    if w == 0 || h == 0 {
        return Err(format!("image is {w}x{h}"));
    }
    if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE || w as u64 * h as u64 > MAX_TEXTURE_PIXELS {
        return Err(format!(
            "image is {w}x{h}, over the limits ({MAX_TEXTURE_SIDE} per side, {MAX_TEXTURE_PIXELS} pixels)"
        ));
    }
    let mut r = reader()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(MAX_DECODE_ALLOC);
    r.limits(limits);
    Ok(r.decode().map_err(|e| e.to_string())?.to_rgba8())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(w: u32, h: u32) -> Vec<u8> {
        let mut out = Vec::new();
        image::RgbaImage::new(w, h)
            .write_to(&mut Cursor::new(&mut out), image::ImageFormat::Png)
            .unwrap();
        out
    }

    /// CRC-32 (ISO 3309, as PNG uses it), bit by bit.
    fn crc32(data: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in data {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        c ^ 0xFFFF_FFFF
    }

    #[test]
    fn small_images_decode() {
        let img = decode_rgba8(&png(3, 2)).unwrap();
        assert_eq!(img.dimensions(), (3, 2));
    }

    #[test]
    fn a_header_claiming_a_huge_image_is_refused_before_decoding() {
        // A 1x1 PNG whose IHDR (with a correct CRC) claims 100000 x 100000:
        // 40 GB of pixels from a 70-byte file.
        let mut bytes = png(1, 1);
        bytes[16..20].copy_from_slice(&100_000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&100_000u32.to_be_bytes());
        let crc = crc32(&bytes[12..29]);
        bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = decode_rgba8(&bytes).unwrap_err();
        assert!(e.contains("over the limits"), "{e}");
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(decode_rgba8(b"not an image").is_err());
        assert!(decode_rgba8(&png(4, 4)[..30]).is_err());
    }
}
