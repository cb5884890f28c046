//! glTF / GLB bytes → parsing, resource resolution (inside an empty scene
//! folder) and scene building. Any Err is fine; a panic, abort or hang is a
//! bug. A loaded scene's bounds must be finite.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = std::env::temp_dir().join("vergence-fuzz-scene");
    let _ = std::fs::create_dir_all(&dir);
    if let Ok(scene) = vergence::scene::gltf_load::load_bytes(&dir.join("fuzz.glb"), data) {
        for (lo, hi) in scene.world_aabbs() {
            assert!(lo.is_finite() && hi.is_finite(), "non-finite bounds");
        }
    }
});
