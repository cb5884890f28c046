//! The decoders behind glTF extensions, fed directly: meshopt streams
//! (EXT_meshopt_compression, every mode and filter, strides and counts
//! from the first bytes) and KTX2 containers (KHR_texture_basisu). Any Err
//! is fine; a panic, abort, out-of-bounds access or hang is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;
use vergence::scene::gltf_data::Meshopt;

const MODES: [&str; 4] = ["ATTRIBUTES", "TRIANGLES", "INDICES", "ATTRIBUTES"];
const FILTERS: [&str; 5] = ["NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR"];

fuzz_target!(|data: &[u8]| {
    let _ = vergence::scene::image_decode::decode_ktx2_rgba8(data);
    if data.len() < 4 {
        return;
    }
    let m = Meshopt {
        buffer: 0,
        byte_offset: 0,
        byte_length: data.len() - 4,
        byte_stride: (data[1] as usize % 65) * 4 + (data[0] as usize >> 6) % 3,
        count: u16::from_le_bytes([data[2], data[3]]) as usize,
        mode: MODES[data[0] as usize % 4].into(),
        filter: FILTERS[(data[0] as usize >> 2) % 5].into(),
    };
    if let Ok((words, len)) = m.decode(&data[4..]) {
        assert!(len <= words.len() * 4);
    }
});
