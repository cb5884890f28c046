//! The file layer under attack: caches, scans and logs never write through
//! a planted link, over one of the command's inputs, or into a device or
//! FIFO; reading a cache that is a device, a FIFO or a huge file neither
//! hangs nor fills memory; echoed text cannot drive the terminal.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn vergence() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vergence"))
}

fn fails(args: &[&str]) -> String {
    common::fails_with_one_error(vergence().args(args))
}

fn succeeds(args: &[&str]) -> String {
    let out = vergence().args(args).output().expect("vergence runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{args:?} failed: {stderr}");
    String::from_utf8_lossy(&out.stdout).into_owned() + &stderr
}

/// A small scan of the factory written to `dir/name`.
fn small_scan(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    let o = out.to_str().unwrap();
    succeeds(&[
        "scan",
        "--scene",
        "factory:10",
        "--stations",
        "1",
        "--rays",
        "3000",
        "--out",
        o,
    ]);
    out
}

#[test]
fn scan_never_overwrites_its_own_scene() {
    let dir = common::scratch("files", "scan-self");
    let las = small_scan(&dir, "s.las");
    let before = std::fs::read(&las).unwrap();
    let p = las.to_str().unwrap();
    let e = fails(&[
        "scan",
        "--scene",
        p,
        "--stations",
        "1",
        "--rays",
        "100",
        "--out",
        p,
    ]);
    assert!(e.contains("never writes over an input"), "{e}");
    assert_eq!(std::fs::read(&las).unwrap(), before);
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("partial") || n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

#[test]
fn a_scan_that_hits_nothing_writes_nothing() {
    let dir = common::scratch("files", "scan-empty");
    let out = dir.join("empty.las");
    // A box seen from a station inside it still hits; the empty glTF
    // scene (no meshes) cannot.
    let gltf = dir.join("empty.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0}"#,
    )
    .unwrap();
    let e = fails(&[
        "scan",
        "--scene",
        gltf.to_str().unwrap(),
        "--stations",
        "1",
        "--rays",
        "100",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        e.contains("nothing written") || e.contains("no meshes") || e.contains("empty"),
        "{e}"
    );
    assert!(!out.exists());
}

#[cfg(unix)]
#[test]
fn the_octree_cache_is_never_written_through_a_link_or_over_an_input() {
    let dir = common::scratch("files", "octree");
    let las = small_scan(&dir, "s.las");
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "keep me").unwrap();
    let cache = dir.join("s.las.octree");
    std::os::unix::fs::symlink(&victim, &cache).unwrap();
    let out = succeeds(&["inspect", las.to_str().unwrap(), "--write-octree"]);
    assert!(out.contains("wrote the octree cache"), "{out}");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep me");
    assert!(!std::fs::symlink_metadata(&cache)
        .unwrap()
        .file_type()
        .is_symlink());
    // A manifest whose point file has the name of the manifest's own
    // cache: writing the cache would replace the scan.
    std::fs::copy(&las, dir.join("m.toml.octree")).unwrap();
    let manifest = dir.join("m.toml");
    std::fs::write(
        &manifest,
        "name = \"m\"\n[[points]]\nfile = \"m.toml.octree\"\n",
    )
    .unwrap();
    let before = std::fs::read(dir.join("m.toml.octree")).unwrap();
    let e = fails(&["inspect", manifest.to_str().unwrap(), "--write-octree"]);
    assert!(e.contains("never writes over an input"), "{e}");
    assert_eq!(std::fs::read(dir.join("m.toml.octree")).unwrap(), before);
}

#[cfg(unix)]
#[test]
fn a_cache_that_is_a_device_fifo_or_huge_file_is_not_read() {
    let dir = common::scratch("files", "octree-read");
    let las = small_scan(&dir, "s.las");
    let cache = dir.join("s.las.octree");
    let p = las.to_str().unwrap();
    std::os::unix::fs::symlink("/dev/zero", &cache).unwrap();
    let started = std::time::Instant::now();
    let out = succeeds(&["inspect", p]);
    assert!(out.contains("character device"), "{out}");
    std::fs::remove_file(&cache).unwrap();
    let c = std::ffi::CString::new(cache.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let out = succeeds(&["inspect", p]);
    assert!(out.contains("FIFO"), "{out}");
    std::fs::remove_file(&cache).unwrap();
    // 3 GB, sparse: over what a cache of these points can be.
    std::fs::File::create(&cache)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    let out = succeeds(&["inspect", p]);
    assert!(out.contains("over the"), "{out}");
    assert!(started.elapsed().as_secs() < 60, "{:?}", started.elapsed());
}

#[test]
fn the_lod_cache_never_replaces_a_buffer_of_its_name() {
    let dir = common::scratch("files", "lodcache");
    let root = common::root().join("assets/Box");
    std::fs::copy(root.join("Box0.bin"), dir.join("Box.gltf.lodcache")).unwrap();
    let text = std::fs::read_to_string(root.join("Box.gltf"))
        .unwrap()
        .replace("Box0.bin", "Box.gltf.lodcache");
    let gltf = dir.join("Box.gltf");
    std::fs::write(&gltf, text).unwrap();
    let before = std::fs::read(dir.join("Box.gltf.lodcache")).unwrap();
    let scene = vergence::scene::Scene::load(gltf.to_str().unwrap()).unwrap();
    let (_, used) = vergence::scene::lod_cache::load_or_build(&scene, &gltf);
    match used {
        vergence::scene::lod_cache::CacheUse::NotWritten(why) => {
            assert!(why.contains("never writes over an input"), "{why}")
        }
        other => panic!("the buffer was replaced: {other:?}"),
    }
    assert_eq!(
        std::fs::read(dir.join("Box.gltf.lodcache")).unwrap(),
        before
    );
}

#[test]
fn errors_escape_control_characters() {
    let dir = common::scratch("files", "escape");
    let name = dir.join("\u{1b}[2J\u{1b}[31mred.gltf");
    let e = fails(&["inspect", name.to_str().unwrap()]);
    assert!(
        !e.contains('\u{1b}'),
        "a raw escape reached the terminal: {e:?}"
    );
    assert!(e.contains("\\u{1b}[31mred.gltf"), "{e}");
    // Names inside a file (a mesh, a material) are escaped in what
    // inspect prints too.
    let gltf = std::fs::read_to_string(common::root().join("assets/Box/Box.gltf")).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&gltf).unwrap();
    json["meshes"][0]["name"] = "\u{1b}]0;owned\u{7}mesh".into();
    json["materials"][0]["name"] = "line\nbreak\u{202e}rtl".into();
    std::fs::copy(
        common::root().join("assets/Box/Box0.bin"),
        dir.join("Box0.bin"),
    )
    .unwrap();
    let file = dir.join("named.gltf");
    std::fs::write(&file, json.to_string()).unwrap();
    let out = succeeds(&["inspect", file.to_str().unwrap()]);
    assert!(
        !out.contains('\u{1b}') && !out.contains('\u{7}') && !out.contains('\u{202e}'),
        "a raw control character reached the terminal: {out:?}"
    );
    assert!(out.contains("\\u{1b}]0;owned\\u{7}mesh"), "{out}");
    assert!(out.contains("line break\\u{202e}rtl"), "{out}");
}

/// `vergence inspect FILE | head`: a reader that stops early ends the
/// output quietly (exit 0, no panic), as with any Unix tool.
#[test]
fn inspect_into_a_closed_pipe_ends_quietly() {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["inspect", "assets/retroufo/retroufo.glb"])
        .current_dir(common::root())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The reader goes away before the scene is loaded and anything written.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// A file larger than any LOD cache of its scene is refused before it is
/// read (a 3 GB sparse file would otherwise be read whole), and a real
/// cache fits the bound.
#[test]
fn a_lod_cache_larger_than_its_scene_allows_is_not_read() {
    use vergence::scene::lod_cache::{content_hash, encode, max_bytes, read_for};
    let scene = common::load("factory:200");
    let bytes = encode(content_hash(&scene), &vergence::scene::lod::build(&scene));
    assert!(bytes.len() as u64 <= max_bytes(&scene));
    let dir = common::scratch("files", "lodcache-size");
    let file = dir.join("big.gltf.lodcache");
    std::fs::File::create(&file)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    let started = std::time::Instant::now();
    let err = read_for(&file, &scene).unwrap_err();
    assert!(err.to_string().contains("over the"), "{err}");
    assert!(started.elapsed().as_secs() < 5, "{:?}", started.elapsed());
    std::fs::write(&file, &bytes).unwrap();
    assert_eq!(read_for(&file, &scene).unwrap(), bytes);
}
