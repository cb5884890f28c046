//! Every SPIR-V module the renderer embeds passes spirv-val (Vulkan 1.3
//! rules) and starts with the SPIR-V magic number, and the renderer embeds
//! one module per shader source in `shaders/`.

use std::process::Command;

#[test]
fn every_spirv_module_validates() {
    let modules = vergence::render::shader_modules();
    let mut sources: Vec<String> =
        std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".vert") || n.ends_with(".frag") || n.ends_with(".comp"))
            .collect();
    sources.sort();
    let mut names: Vec<String> = modules.iter().map(|(n, _)| n.to_string()).collect();
    names.sort();
    assert_eq!(
        names, sources,
        "one embedded module per shaders/*.vert, *.frag, *.comp"
    );
    let dir = std::env::temp_dir().join(format!("vergence-spv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let have_val = Command::new("spirv-val")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have_val && std::env::var("VERGENCE_REQUIRE_SPIRV_VAL").is_ok() {
        panic!("spirv-val is required (apt-get install spirv-tools)");
    }
    let mut validated = 0;
    for &(name, bytes) in &modules {
        assert_eq!(
            bytes.len() % 4,
            0,
            "{name}: SPIR-V length is a multiple of 4"
        );
        assert_eq!(
            u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
            0x0723_0203,
            "{name}: magic"
        );
        if have_val {
            let path = dir.join(format!("{name}.spv"));
            std::fs::write(&path, bytes).unwrap();
            let out = Command::new("spirv-val")
                .args(["--target-env", "vulkan1.3"])
                .arg(&path)
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "{name}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            validated += 1;
        } else {
            eprintln!("spirv-val not installed: {name} checked for magic and size only");
        }
    }
    if have_val {
        assert_eq!(
            validated,
            modules.len(),
            "every module went through spirv-val"
        );
    }
}
