//! Bad input: every case gives one clear error naming the file and the
//! problem, a non-zero exit code, and no panic.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs vergence and returns stderr, asserting failure without a panic.
fn fails(args: &[&str]) -> String {
    common::fails_with_one_error(Command::new(env!("CARGO_BIN_EXE_vergence")).args(args))
}

fn inspect_fails(path: &Path, expect: &[&str]) {
    let stderr = fails(&["inspect", path.to_str().unwrap()]);
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(
        stderr.contains(&*name),
        "error names the file {name}: {stderr}"
    );
    for e in expect {
        assert!(stderr.contains(e), "error mentions '{e}': {stderr}");
    }
}

fn copy_asset(dir: &Path, asset: &str, files: &[&str]) {
    for f in files {
        std::fs::copy(root().join("assets").join(asset).join(f), dir.join(f)).unwrap();
    }
}

fn edit_json(path: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(path, serde_json::to_string(&v).unwrap()).unwrap();
}

#[test]
fn missing_file() {
    let p = common::scratch("bad", "missing").join("nothing-here.gltf");
    inspect_fails(&p, &["cannot read file"]);
}

#[test]
fn not_a_gltf_file() {
    let dir = common::scratch("bad", "notgltf");
    let p = dir.join("picture.gltf");
    std::fs::copy(root().join("assets/BoxTextured/CesiumLogoFlat.png"), &p).unwrap();
    inspect_fails(&p, &["not a glTF file"]);
}

#[test]
fn truncated_glb() {
    let dir = common::scratch("bad", "truncated");
    let bytes = std::fs::read(root().join("assets/retroufo/retroufo.glb")).unwrap();
    let p = dir.join("cut.glb");
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    inspect_fails(&p, &[".glb"]);
}

#[test]
fn missing_bin() {
    let dir = common::scratch("bad", "nobin");
    copy_asset(&dir, "Box", &["Box.gltf"]);
    inspect_fails(&dir.join("Box.gltf"), &["buffer 0", "Box0.bin"]);
}

#[test]
fn missing_image() {
    let dir = common::scratch("bad", "noimage");
    copy_asset(
        &dir,
        "BoxTextured",
        &["BoxTextured.gltf", "BoxTextured0.bin"],
    );
    inspect_fails(
        &dir.join("BoxTextured.gltf"),
        &["image 0", "CesiumLogoFlat.png"],
    );
}

#[test]
fn undecodable_image() {
    let dir = common::scratch("bad", "badimage");
    copy_asset(
        &dir,
        "BoxTextured",
        &["BoxTextured.gltf", "BoxTextured0.bin"],
    );
    std::fs::write(
        dir.join("CesiumLogoFlat.png"),
        b"\x89PNG\r\n\x1a\nthis is not a png body",
    )
    .unwrap();
    inspect_fails(
        &dir.join("BoxTextured.gltf"),
        &["CesiumLogoFlat.png", "cannot be decoded"],
    );
}

#[test]
fn unsupported_required_extension() {
    let dir = common::scratch("bad", "ext");
    copy_asset(&dir, "Box", &["Box.gltf", "Box0.bin"]);
    edit_json(&dir.join("Box.gltf"), |v| {
        v["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
        v["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    });
    inspect_fails(
        &dir.join("Box.gltf"),
        &["KHR_draco_mesh_compression", "does not support"],
    );
}

#[test]
fn accessor_out_of_range_of_its_buffer_view() {
    let dir = common::scratch("bad", "accessor");
    copy_asset(&dir, "Box", &["Box.gltf", "Box0.bin"]);
    edit_json(&dir.join("Box.gltf"), |v| {
        v["accessors"][1]["count"] = serde_json::json!(1_000_000)
    });
    inspect_fails(&dir.join("Box.gltf"), &["accessor 1", "out of range"]);
}

#[test]
fn accessor_reference_out_of_range() {
    let dir = common::scratch("bad", "accref");
    copy_asset(&dir, "Box", &["Box.gltf", "Box0.bin"]);
    edit_json(&dir.join("Box.gltf"), |v| {
        v["meshes"][0]["primitives"][0]["indices"] = serde_json::json!(42)
    });
    inspect_fails(&dir.join("Box.gltf"), &["invalid glTF", "indices"]);
}

#[test]
fn index_value_out_of_range() {
    // Three vertices, indices 0, 1, 7 (u16), all in a data: URI.
    let mut bin = Vec::new();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 7, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    use base64::Engine;
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri, "byteLength": bin.len()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    let dir = common::scratch("bad", "index");
    let p = dir.join("bad-index.gltf");
    std::fs::write(&p, gltf.to_string()).unwrap();
    inspect_fails(&p, &["index 7 is out of range"]);
}

#[test]
fn malformed_scene_manifest() {
    let dir = common::scratch("bad", "manifest");
    let p = dir.join("scene.toml");
    std::fs::write(&p, "name = \"x\"\n[[gltf]]\nfile = 3\n").unwrap();
    inspect_fails(&p, &["malformed scene manifest"]);
}

#[test]
fn unknown_hmd_profile() {
    let out = common::scratch("bad", "hmd-unknown");
    let stderr = fails(&[
        "render",
        "--scene",
        "factory:10",
        "--hmd",
        "no-such-headset",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        stderr.contains("no-such-headset") && stderr.contains("unknown profile"),
        "{stderr}"
    );
}

#[test]
fn malformed_hmd_profile() {
    let dir = common::scratch("bad", "hmd-bad");
    let p = dir.join("broken.toml");
    std::fs::write(
        &p,
        "name = \"broken\"\nrefresh_hz = 90.0\n[[views]]\nposition = [0.0, 0.0]\n",
    )
    .unwrap();
    let stderr = fails(&[
        "render",
        "--scene",
        "factory:10",
        "--hmd",
        p.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(
        stderr.contains("broken.toml") && stderr.contains("malformed profile"),
        "{stderr}"
    );
}

#[test]
fn bad_cli_values() {
    let dir = common::scratch("bad", "cli");
    let out = dir.to_str().unwrap();
    let stderr = fails(&["render", "--scene", "factory:0", "--out", out]);
    assert!(stderr.contains("factory:0"), "{stderr}");
    let stderr = fails(&[
        "render",
        "--scene",
        "factory:10",
        "--msaa",
        "3",
        "--out",
        out,
    ]);
    assert!(stderr.contains("--msaa"), "{stderr}");
    for n in ["0", "4"] {
        let stderr = fails(&[
            "render",
            "--scene",
            "factory:10",
            "--frames-in-flight",
            n,
            "--out",
            out,
        ]);
        assert!(
            stderr.contains("--frames-in-flight") && stderr.contains("1 to 3"),
            "{stderr}"
        );
    }
    let out2 = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["render", "--pose", "1,2,nan,0,0,0", "--out", out])
        .output()
        .unwrap();
    assert_eq!(out2.status.code(), Some(2), "clap rejects a bad --pose");
}

/// One entry of `tests/bad_inputs/cases.toml`.
#[derive(serde::Deserialize)]
struct Case {
    file: String,
    kind: String,
    expect: Vec<String>,
}

#[derive(serde::Deserialize)]
struct Cases {
    case: Vec<Case>,
}

/// The malformed-input corpus: every file gives one error line that says
/// what the index expects, a non-zero exit and no panic.
#[test]
fn corpus() {
    let dir = root().join("tests/bad_inputs");
    let text = std::fs::read_to_string(dir.join("cases.toml")).unwrap();
    let cases: Cases = toml::from_str(&text).unwrap();
    assert!(cases.case.len() >= 30, "{} cases", cases.case.len());
    let out = common::scratch("bad", "corpus");
    let out = out.to_str().unwrap();
    let mut failures = Vec::new();
    for c in &cases.case {
        let path = dir.join(&c.file);
        let p = path.to_str().unwrap();
        let args: Vec<&str> = match c.kind.as_str() {
            "scene" => vec!["inspect", p],
            "hmd" => vec!["render", "--hmd", p, "--out", out],
            "plan" => vec!["bench", "--plan", p, "--out", out],
            "config" => vec!["render", "--config", p, "--out", out],
            other => panic!("{}: unknown kind {other}", c.file),
        };
        let stderr = fails(&args);
        for e in &c.expect {
            if !stderr.contains(e.as_str()) {
                failures.push(format!("{}: expected '{e}' in: {}", c.file, stderr.trim()));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
