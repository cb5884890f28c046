//! Image bytes → texture decoding within limits. Any Err is fine; a panic,
//! an abort (allocation failure) or a hang is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(img) = vergence::scene::image_decode::decode_rgba8(data) {
        assert!(img.width() <= vergence::scene::image_decode::MAX_TEXTURE_SIDE);
    }
});
