//! Compiles shaders/*.{vert,frag,comp} to SPIR-V with glslc (Debian/Ubuntu package
//! `glslc`; `cargo xtask` installs it). The SPIR-V lands in OUT_DIR and is
//! embedded with include_bytes!.

use std::path::Path;
use std::process::Command;

fn main() {
    let out = std::env::var("OUT_DIR").expect("OUT_DIR is set by cargo");
    println!("cargo:rerun-if-changed=shaders");
    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
    let mut sources: Vec<_> = std::fs::read_dir("shaders")
        .expect("shaders/ exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("vert" | "frag" | "comp")
            )
        })
        .collect();
    sources.sort();
    for src in sources {
        let name = src.file_name().unwrap().to_string_lossy().into_owned();
        let dst = Path::new(&out).join(format!("{name}.spv"));
        // Compute shaders target Vulkan 1.2: for 1.3 glslc declares the
        // workgroup size with LocalSizeId, which needs maintenance4.
        let env = if name.ends_with(".comp") {
            "--target-env=vulkan1.2"
        } else {
            "--target-env=vulkan1.3"
        };
        let status = Command::new(&glslc)
            .args([env, "-O", "-Ishaders", "-o"])
            .arg(&dst)
            .arg(&src)
            .status();
        match status {
            Ok(s) if s.success() => {}
            Ok(s) => panic!("glslc failed on {} ({s})", src.display()),
            Err(e) => panic!(
                "cannot run glslc ({e}). Install it with `apt-get install glslc` (or run `cargo xtask test`, which installs it), or set GLSLC to its path."
            ),
        }
    }
}
