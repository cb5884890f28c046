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

/// The most raw sample bytes an image may decode to per encoded byte,
/// beyond [`FREE_DECODE_BYTES`]: Deflate (PNG) cannot exceed about
/// 1032:1, and JPEG of a flat image stays below that; a crafted lossless
/// WebP goes far beyond (a few kilobytes claiming a gigabyte). For PNG the
/// raw samples are the file's own pixel format (a flat 1-bit grey image
/// is fine at 32 times the ratio of its RGBA8 output); for other formats
/// they are taken as RGBA8.
pub const MAX_DECODE_RATIO: u64 = 1100;
/// Decoded bytes a scene's images may take together beyond their ratio:
/// flat textures (placeholder roughness or occlusion maps, flat lossy
/// WebP) compress further than [`MAX_DECODE_RATIO`].
pub const FREE_DECODE_BYTES: u64 = 256 << 20;

/// The most RGBA8 bytes `encoded` bytes of this image may decode to under
/// [`MAX_DECODE_RATIO`]: scaled by 32 over the PNG's bits per pixel (from
/// its IHDR: bit depth × channels of its colour type).
pub fn ratio_limit(bytes: &[u8]) -> u64 {
    let encoded = bytes.len() as u64;
    let png_bits = (bytes.len() >= 29 && bytes.starts_with(b"\x89PNG\r\n\x1a\n")).then(|| {
        let depth = u64::from(bytes[24]);
        let channels = match bytes[25] {
            2 => 3,
            4 => 2,
            6 => 4,
            _ => 1,
        };
        (depth * channels).clamp(1, 64)
    });
    let scale = png_bits.map_or(1.0, |bits| 32.0 / bits as f64);
    (encoded as f64 * MAX_DECODE_RATIO as f64 * scale) as u64
}

/// The decoded size (RGBA8 bytes) of an encoded image, read from its
/// header only (PNG, JPEG, WebP, or KTX2 when `ktx2`), with the texture
/// limits checked; nothing is decoded.
pub fn decoded_bytes(bytes: &[u8], ktx2: bool) -> Result<u64, String> {
    let (w, h) = if ktx2 {
        // The `ktx2` crate's descriptor parser overflows on some block
        // dimensions; they are checked first, as decoding does.
        check_dfd_block_dimensions(bytes)?;
        let r = ktx2::Reader::new(bytes).map_err(|e| format!("invalid KTX2 container: {e}"))?;
        let h = r.header();
        (h.pixel_width, h.pixel_height.max(1))
    } else {
        image::ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| e.to_string())?
            .into_dimensions()
            .map_err(|e| e.to_string())?
    };
    if w == 0 || h == 0 {
        return Err(format!("image is {w}x{h}"));
    }
    if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE || w as u64 * h as u64 > MAX_TEXTURE_PIXELS {
        return Err(format!(
            "image is {w}x{h}, over the limits ({MAX_TEXTURE_SIDE} per side, {MAX_TEXTURE_PIXELS} pixels)"
        ));
    }
    Ok(w as u64 * h as u64 * 4)
}

/// Decodes PNG, JPEG or WebP `bytes` into RGBA8, refusing images over the
/// limits.
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

/// The 12-byte KTX 2.0 file identifier (KTX 2.0 specification §3.1).
pub const KTX2_MAGIC: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// Decodes level 0 of a KTX2 texture (KHR_texture_basisu) into RGBA8.
/// The container is parsed and bounds-checked with the `ktx2` crate
/// (header, data format descriptor, level index) and its size checked
/// against the texture limits first. Basis Universal payloads (BasisLZ/ETC1S
/// or UASTC, what KHR_texture_basisu files hold) are transcoded
/// ([`super::basis`]); otherwise only uncompressed 2D `R8G8B8A8_UNORM` /
/// `R8G8B8A8_SRGB` data without supercompression is decoded.
pub fn decode_ktx2_rgba8(bytes: &[u8]) -> Result<image::RgbaImage, String> {
    check_dfd_block_dimensions(bytes)?;
    check_key_values(bytes)?;
    let r = ktx2::Reader::new(bytes).map_err(|e| format!("invalid KTX2 container: {e}"))?;
    let h = r.header();
    let (w, ht) = (h.pixel_width, h.pixel_height.max(1));
    if h.pixel_depth > 1 || h.layer_count > 1 || h.face_count != 1 {
        return Err(format!(
            "KTX2 image is not a plain 2D texture (depth {}, layers {}, faces {})",
            h.pixel_depth, h.layer_count, h.face_count
        ));
    }
    if w > MAX_TEXTURE_SIDE || ht > MAX_TEXTURE_SIDE || w as u64 * ht as u64 > MAX_TEXTURE_PIXELS {
        return Err(format!(
            "image is {w}x{ht}, over the limits ({MAX_TEXTURE_SIDE} per side, {MAX_TEXTURE_PIXELS} pixels)"
        ));
    }
    // Basis Universal: ETC1S is always BasisLZ-supercompressed; UASTC has
    // VK_FORMAT_UNDEFINED, with or without Zstandard.
    let basis = matches!(
        (h.supercompression_scheme, h.format),
        (Some(ktx2::SupercompressionScheme::BasisLZ), _)
            | (None | Some(ktx2::SupercompressionScheme::Zstandard), None)
    );
    if basis {
        // The transcoder allocates each level's declared uncompressed size
        // before inflating it: a level index that lies would ask for
        // gigabytes. A Basis level holds at most 16 bytes (UASTC) per 4×4
        // block of its size (ETC1S under BasisLZ declares 0).
        for (i, level) in r.levels().enumerate() {
            let side = |v: u32| (v >> i.min(31)).max(1).div_ceil(4) as u64;
            let most = 16 * side(w) * side(ht);
            if level.uncompressed_byte_length > most {
                return Err(format!(
                    "KTX2 image's level {i} declares {} uncompressed bytes, more than the {most} its {w}x{ht} size allows",
                    level.uncompressed_byte_length
                ));
            }
        }
        return super::basis::transcode_rgba8(bytes, w, ht);
    }
    if let Some(s) = h.supercompression_scheme {
        return Err(format!(
            "KTX2 image uses supercompression {s:?} with format {:?}, which vergence does not decode (only Basis Universal and uncompressed R8G8B8A8)",
            h.format
        ));
    }
    let rgba8 = [ktx2::Format::R8G8B8A8_UNORM, ktx2::Format::R8G8B8A8_SRGB];
    match h.format {
        Some(f) if !rgba8.contains(&f) => {
            return Err(format!(
                "KTX2 image format {f:?} is not decoded (only Basis Universal and uncompressed R8G8B8A8)"
            ))
        }
        _ => {}
    }
    let level = r.levels().next().ok_or("KTX2 image has no levels")?;
    let need = w as usize * ht as usize * 4;
    if level.data.len() < need {
        return Err(format!(
            "KTX2 level 0 holds {} bytes, but {w}x{ht} RGBA8 needs {need}",
            level.data.len()
        ));
    }
    image::RgbaImage::from_raw(w, ht, level.data[..need].to_vec())
        .ok_or_else(|| "KTX2 level 0 does not match its size".to_string())
}

/// Refuses basic data format descriptor blocks whose texel block
/// dimension bytes are 255 (a dimension of 256, which `ktx2` 0.5 adds one
/// to in a `u8` and unwraps as non-zero: a panic found by fuzzing). Walks
/// the DFD as KTX 2.0 §3.10 lays it out (a u32 total size, then blocks of
/// an 8-byte header whose last u16 is the block size); anything out of
/// range is left for the `ktx2` parser to report.
fn check_dfd_block_dimensions(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |o: usize| {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (Some(off), Some(len)) = (u32_at(48), u32_at(52)) else {
        return Ok(());
    };
    let Some(dfd) = off
        .checked_add(len)
        .and_then(|end| bytes.get(off.checked_add(4)?..end))
    else {
        return Ok(());
    };
    let mut rest = dfd;
    while rest.len() >= 16 {
        let size = u16::from_le_bytes([rest[6], rest[7]]) as usize;
        let basic = rest[..4] == [0, 0, 0, 0] && rest[4..6] == [2, 0];
        if basic && rest[12..16].contains(&255) {
            return Err(
                "invalid KTX2 container: a texel block dimension of 256 is out of range".into(),
            );
        }
        if size < 8 || size > rest.len() {
            break;
        }
        rest = &rest[size..];
    }
    Ok(())
}

/// The key/value data of a KTX2 file (KTX 2.0 §3.11: entries of a `u32`
/// length and `key\0value`, each padded to 4 bytes, padding included in
/// `kvdByteLength`): every entry and its padding within the data. The Basis
/// transcoder walks these entries with unchecked arithmetic, so an entry
/// whose padding runs past the end is refused here first.
fn check_key_values(bytes: &[u8]) -> Result<(), String> {
    let word = |at: usize| -> Option<usize> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (Some(start), Some(length)) = (word(56), word(60)) else {
        return Ok(());
    };
    if length == 0 {
        return Ok(());
    }
    let end = start
        .checked_add(length)
        .filter(|&e| e <= bytes.len())
        .ok_or("KTX2 key/value data runs past the end of the file")?;
    let mut p = start;
    while end - p > 4 {
        let l = word(p).ok_or("KTX2 key/value data is cut short")?;
        p += 4;
        if l > end - p {
            return Err(format!(
                "KTX2 key/value entry at byte {} is {l} bytes long, past the data's end",
                p - 4
            ));
        }
        p += l;
        let padded = p + ((4 - (p & 3)) & 3);
        if padded > end {
            return Err(format!(
                "KTX2 key/value entry ending at byte {p}: its padding runs past the data's end ({end})"
            ));
        }
        p = padded;
    }
    Ok(())
}

/// Builds a minimal KTX2 file (one level, no supercompression) holding
/// `rgba` as `R8G8B8A8_UNORM`, with the basic data format descriptor the
/// KTX 2.0 specification (§4 and Khronos Data Format 1.3 §5.6) requires.
/// For tests and the bad-input generator.
pub fn encode_ktx2_rgba8(w: u32, h: u32, rgba: &[u8]) -> Vec<u8> {
    let level_offset = 80 + 24 + 4 + 88;
    let mut out = Vec::new();
    out.extend_from_slice(&KTX2_MAGIC);
    for v in [37u32, 1, w, h, 0, 0, 1, 1, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    // Index: dfd offset/length, kvd offset/length, sgd offset/length (u64).
    for v in [80u32 + 24, 4 + 88, 0, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u64.to_le_bytes());
    out.extend_from_slice(&0u64.to_le_bytes());
    // Level index: byteOffset, byteLength, uncompressedByteLength.
    for v in [level_offset as u64, rgba.len() as u64, rgba.len() as u64] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    // DFD: total size, then one basic block of 24 + 4 × 16 bytes.
    out.extend_from_slice(&(4u32 + 88).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // vendor 0, type 0
    out.extend_from_slice(&(2u32 | (88 << 16)).to_le_bytes()); // version 2, size 88
    out.extend_from_slice(&[1, 1, 1, 0]); // RGBSDA, BT.709, linear, no flags
    out.extend_from_slice(&[0, 0, 0, 0]); // texel block dimensions 1×1×1×1
    out.extend_from_slice(&[4, 0, 0, 0, 0, 0, 0, 0]); // bytes per plane
    for (c, off) in [(0u8, 0u16), (1, 8), (2, 16), (15, 24)] {
        out.extend_from_slice(&off.to_le_bytes());
        out.push(7); // bit length - 1
        out.push(c);
        out.extend_from_slice(&[0, 0, 0, 0]); // sample positions
        out.extend_from_slice(&0u32.to_le_bytes()); // lower
        out.extend_from_slice(&255u32.to_le_bytes()); // upper
    }
    debug_assert_eq!(out.len(), level_offset);
    out.extend_from_slice(rgba);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ktx2_rgba8_round_trips_and_basis_is_refused() {
        let px: Vec<u8> = (0..2 * 3 * 4).map(|i| i as u8 * 9).collect();
        let file = encode_ktx2_rgba8(2, 3, &px);
        let img = decode_ktx2_rgba8(&file).unwrap();
        assert_eq!(img.dimensions(), (2, 3));
        assert_eq!(img.as_raw(), &px);
        // A BasisLZ or UASTC header over RGBA8 bytes is no Basis payload:
        // 24 bytes for a 2×3 image is more than a Basis level of that size
        // holds (one 4×4 block, 16 bytes), refused before transcoding.
        let mut basis = file.clone();
        basis[44..48].copy_from_slice(&1u32.to_le_bytes());
        let e = decode_ktx2_rgba8(&basis).unwrap_err();
        assert!(
            e.contains("declares 24 uncompressed bytes, more than the 16"),
            "{e}"
        );
        let mut uastc = file.clone();
        uastc[12..16].copy_from_slice(&0u32.to_le_bytes());
        let e = decode_ktx2_rgba8(&uastc).unwrap_err();
        assert!(
            e.contains("declares 24 uncompressed bytes, more than the 16"),
            "{e}"
        );
        // With a length a Basis level can hold, the payload itself is
        // refused by the transcoder.
        let mut short = uastc.clone();
        short[96..104].copy_from_slice(&16u64.to_le_bytes());
        let e = decode_ktx2_rgba8(&short).unwrap_err();
        assert!(e.contains("Basis Universal payload"), "{e}");
        let mut bad_level = file.clone();
        bad_level[80..88].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let e = decode_ktx2_rgba8(&bad_level).unwrap_err();
        assert!(e.contains("invalid KTX2"), "{e}");
        let mut dims = file.clone();
        dims[108 + 12] = 255;
        let e = decode_ktx2_rgba8(&dims).unwrap_err();
        assert!(e.contains("texel block dimension"), "{e}");
        let e = decode_ktx2_rgba8(&file[..100]).unwrap_err();
        assert!(e.contains("invalid KTX2"), "{e}");
    }

    #[test]
    fn a_png_is_held_to_the_ratio_of_its_own_samples() {
        // A 4000-byte 8-bit grey PNG (its IHDR's depth and colour type
        // are what count) may claim 2048² pixels: 1024:1 of its grey
        // samples, 4096:1 of the RGBA8 they become.
        let mut png = vec![0u8; 4000];
        png[..8].copy_from_slice(b"\x89PNG\r\n\x1a\n");
        png[24] = 8;
        png[25] = 0;
        let rgba = 2048u64 * 2048 * 4;
        assert!(rgba > png.len() as u64 * MAX_DECODE_RATIO);
        assert!(rgba <= ratio_limit(&png));
        // As RGBA (colour type 6), or not a PNG, the same bytes may not.
        png[25] = 6;
        assert!(rgba > ratio_limit(&png));
        png[0] = 0;
        assert!(rgba > ratio_limit(&png));
        // 1-bit grey: 32 times the ratio of its RGBA8 output.
        png[..8].copy_from_slice(b"\x89PNG\r\n\x1a\n");
        png[24] = 1;
        png[25] = 0;
        assert_eq!(ratio_limit(&png), 4000 * MAX_DECODE_RATIO * 32);
    }

    #[test]
    fn webp_decodes() {
        let mut out = Vec::new();
        image::RgbaImage::from_pixel(5, 4, image::Rgba([10, 200, 30, 255]))
            .write_to(&mut Cursor::new(&mut out), image::ImageFormat::WebP)
            .unwrap();
        let img = decode_rgba8(&out).unwrap();
        assert_eq!(img.dimensions(), (5, 4));
        assert_eq!(img.get_pixel(2, 2).0, [10, 200, 30, 255]);
    }

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
