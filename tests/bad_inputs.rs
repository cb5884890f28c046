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
        v["extensionsUsed"] = serde_json::json!(["KHR_materials_pbrSpecularGlossiness"]);
        v["extensionsRequired"] = serde_json::json!(["KHR_materials_pbrSpecularGlossiness"]);
    });
    inspect_fails(
        &dir.join("Box.gltf"),
        &["KHR_materials_pbrSpecularGlossiness", "does not support"],
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
    /// `cli` cases: the arguments ({dir}, {out}, {fifo}, {fifo_ply},
    /// {fifo_las}, {zero_ply}, {big} replaced).
    #[serde(default)]
    args: Vec<String>,
    /// The exit code required (else any failure that is not a panic).
    exit: Option<i32>,
    /// Run under the address-space limit (the case needs no GPU).
    #[serde(default)]
    memory: bool,
}

#[derive(serde::Deserialize)]
struct Cases {
    case: Vec<Case>,
}

/// Wall-clock bound of every corpus case.
const CASE_SECONDS: f64 = 10.0;
/// Peak resident memory bound of every corpus case.
const CASE_RSS_MB: u64 = 1024;
/// Address-space limit of `memory = true` cases: a regression that
/// allocates without bound fails its own case instead of the machine.
const CASE_ADDRESS_SPACE_MB: u64 = 3072;

/// What a bounded run of vergence gave.
struct Outcome {
    code: Option<i32>,
    stderr: String,
    seconds: f64,
    peak_rss_mb: u64,
}

/// Runs `cmd` with its output in files (no pipe to fill), killed after
/// twice [`CASE_SECONDS`]; with `limit_as`, under `RLIMIT_AS`. Peak RSS
/// from `wait4`'s rusage.
#[cfg(unix)]
#[allow(
    clippy::zombie_processes,
    reason = "the child is reaped by wait4 below"
)]
fn run_bounded(cmd: &mut Command, scratch: &Path, name: &str, limit_as: bool) -> Outcome {
    use std::os::unix::process::CommandExt as _;
    use std::os::unix::process::ExitStatusExt as _;
    let err_path = scratch.join(format!("{name}.stderr"));
    let out_path = scratch.join(format!("{name}.stdout"));
    cmd.stdin(std::process::Stdio::null())
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap());
    if limit_as {
        // SAFETY: setrlimit is async-signal-safe; nothing else runs
        // between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let bytes = CASE_ADDRESS_SPACE_MB << 20;
                let lim = libc::rlimit {
                    rlim_cur: bytes,
                    rlim_max: bytes,
                };
                if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
    }
    let t0 = std::time::Instant::now();
    let child = cmd.spawn().expect("vergence starts");
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value to fill.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: waiting for our own child with valid out-pointers.
        let r = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
        if r == pid {
            break;
        }
        assert!(r == 0, "wait4 failed");
        if t0.elapsed().as_secs_f64() > 2.0 * CASE_SECONDS {
            // SAFETY: killing our own child.
            unsafe { libc::kill(pid, libc::SIGKILL) };
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let seconds = t0.elapsed().as_secs_f64();
    let exit = std::process::ExitStatus::from_raw(status);
    Outcome {
        code: exit.code(),
        stderr: std::fs::read_to_string(&err_path).unwrap_or_default(),
        seconds,
        peak_rss_mb: usage.ru_maxrss as u64 / 1024,
    }
}

#[cfg(not(unix))]
fn run_bounded(cmd: &mut Command, _scratch: &Path, _name: &str, _limit_as: bool) -> Outcome {
    let t0 = std::time::Instant::now();
    let out = cmd.output().expect("vergence runs");
    Outcome {
        code: out.status.code(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        seconds: t0.elapsed().as_secs_f64(),
        peak_rss_mb: 0,
    }
}

/// Checks one outcome: one `error:` line, the exit code, no panic, the
/// expectations, time and memory bounds. Returns the problems.
fn check(name: &str, c: &Case, o: &Outcome) -> Vec<String> {
    let mut bad = Vec::new();
    let err = o.stderr.trim();
    let errors = o.stderr.lines().filter(|l| l.starts_with("error:")).count();
    if errors != 1 {
        bad.push(format!("{name}: {errors} error lines: {err}"));
    }
    match (o.code, c.exit) {
        (Some(0), _) => bad.push(format!("{name}: succeeded: {err}")),
        (Some(101), _) => bad.push(format!("{name}: panicked: {err}")),
        (None, _) => bad.push(format!(
            "{name}: killed by a signal after {:.1} s: {err}",
            o.seconds
        )),
        (Some(code), Some(want)) if code != want => {
            bad.push(format!("{name}: exit {code}, expected {want}: {err}"))
        }
        _ => {}
    }
    if o.stderr.contains("panicked") {
        bad.push(format!("{name}: panicked: {err}"));
    }
    // The reason in words: a system error number tells a reader nothing.
    if o.stderr.contains("(os error") {
        bad.push(format!(
            "{name}: an error number instead of a reason: {err}"
        ));
    }
    for e in &c.expect {
        if !o.stderr.contains(e.as_str()) {
            bad.push(format!("{name}: expected '{e}' in: {err}"));
        }
    }
    if o.seconds > CASE_SECONDS {
        bad.push(format!(
            "{name}: took {:.1} s (bound {CASE_SECONDS} s)",
            o.seconds
        ));
    }
    if o.peak_rss_mb > CASE_RSS_MB {
        bad.push(format!(
            "{name}: peak RSS {} MB (bound {CASE_RSS_MB} MB)",
            o.peak_rss_mb
        ));
    }
    bad
}

/// The malformed-input corpus: every case gives one error line that says
/// what the index expects, the exit code it names (else a non-zero one
/// that is not a panic), within [`CASE_SECONDS`] and [`CASE_RSS_MB`]; the
/// cases that need no GPU run under an address-space limit.
#[test]
fn corpus() {
    let dir = root().join("tests/bad_inputs");
    let text = std::fs::read_to_string(dir.join("cases.toml")).unwrap();
    let cases: Cases = toml::from_str(&text).unwrap();
    assert!(cases.case.len() >= 100, "{} cases", cases.case.len());
    let scratch = common::scratch("bad", "corpus");
    let out = scratch.join("out");
    let fifo = scratch.join("pipe.gltf");
    // Point files are read by their extension: a FIFO for the PLY and the
    // LAS reader each, and a .ply that is a link to /dev/zero.
    let fifo_ply = scratch.join("pipe.ply");
    let fifo_las = scratch.join("pipe.las");
    let zero_ply = scratch.join("zero.ply");
    let big = scratch.join("big.toml");
    #[cfg(unix)]
    {
        for f in [&fifo, &fifo_ply, &fifo_las] {
            let c = std::ffi::CString::new(f.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        }
        std::os::unix::fs::symlink("/dev/zero", &zero_ply).unwrap();
    }
    // 17 MiB, sparse: over the 16 MiB text limit without using the disk.
    std::fs::File::create(&big)
        .unwrap()
        .set_len(17 << 20)
        .unwrap();
    let fill = |a: &str| {
        a.replace("{dir}", dir.to_str().unwrap())
            .replace("{out}", out.to_str().unwrap())
            .replace("{fifo}", fifo.to_str().unwrap())
            .replace("{fifo_ply}", fifo_ply.to_str().unwrap())
            .replace("{fifo_las}", fifo_las.to_str().unwrap())
            .replace("{zero_ply}", zero_ply.to_str().unwrap())
            .replace("{big}", big.to_str().unwrap())
    };
    let o = out.to_str().unwrap().to_string();
    let mut failures = Vec::new();
    for (i, c) in cases.case.iter().enumerate() {
        let path = dir.join(&c.file);
        let p = path.to_str().unwrap().to_string();
        let (args, limit_as): (Vec<String>, bool) = match c.kind.as_str() {
            "scene" => (vec!["inspect".into(), p], true),
            "hmd" => (
                vec![
                    "render".into(),
                    "--hmd".into(),
                    p,
                    "--out".into(),
                    o.clone(),
                ],
                false,
            ),
            "plan" => (
                vec![
                    "bench".into(),
                    "--plan".into(),
                    p,
                    "--out".into(),
                    o.clone(),
                ],
                false,
            ),
            "config" => (
                vec![
                    "render".into(),
                    "--config".into(),
                    p,
                    "--out".into(),
                    o.clone(),
                ],
                false,
            ),
            "rig" => (
                vec![
                    "render".into(),
                    "--rig".into(),
                    p,
                    "--out".into(),
                    o.clone(),
                ],
                false,
            ),
            "kiosk" => (
                [
                    "run", "--xr", "headless", "--frames", "1", "--mirror", "off", "--kiosk",
                ]
                .iter()
                .map(|a| a.to_string())
                .chain([p])
                .collect(),
                false,
            ),
            "cli" => (c.args.iter().map(|a| fill(a)).collect(), c.memory),
            other => panic!("{}: unknown kind {other}", c.file),
        };
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_vergence"));
        cmd.args(&args).current_dir(root());
        let outcome = run_bounded(&mut cmd, &scratch, &format!("case{i}"), limit_as);
        failures.extend(check(&c.file, c, &outcome));
        if out.join("left.png").exists() {
            failures.push(format!("{}: a failing case wrote output", c.file));
            let _ = std::fs::remove_dir_all(&out);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Class 9: a symbolic link planted where an output goes is replaced, never
/// written through; `run --stats-out` leaves a file named like its old
/// spool alone.
#[cfg(unix)]
#[test]
fn outputs_never_follow_planted_links() {
    let dir = common::scratch("bad", "links");
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    for name in ["left.png", "right.png", "stats.json", "stats.json.tmp"] {
        std::os::unix::fs::symlink(&victim, out.join(name)).unwrap();
    }
    let status = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "render",
            "--scene",
            "factory:20",
            "--width",
            "32",
            "--height",
            "32",
        ])
        .args(["--hmd", "monado-sim", "--out", out.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    for name in ["left.png", "right.png", "stats.json"] {
        let m = std::fs::symlink_metadata(out.join(name)).unwrap();
        assert!(m.is_file(), "{name} is a regular file now");
    }
    image::open(out.join("left.png")).expect("a real PNG");
    // The unrelated link is left as it was.
    assert!(std::fs::symlink_metadata(out.join("stats.json.tmp"))
        .unwrap()
        .is_symlink());

    let stats = dir.join("S.json");
    std::fs::write(dir.join("S.frames.tmp"), b"not vergence's").unwrap();
    std::os::unix::fs::symlink(&victim, &stats).unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["run", "--xr", "headless", "--scene", "factory:20"])
        .args([
            "--hmd-fallback",
            "monado-sim",
            "--width",
            "32",
            "--height",
            "32",
        ])
        .args(["--frames", "3", "--stats-out", stats.to_str().unwrap()])
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert_eq!(
        std::fs::read(dir.join("S.frames.tmp")).unwrap(),
        b"not vergence's"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(v["frames"].as_array().map(Vec::len), Some(3), "{v}");
    let left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left behind: {left:?}");
}

/// Class 7: `run --capture` writes the hidden areas into rig.json and
/// `render --rig ... --opt stencil-mask` renders with them; an older rig
/// file without them takes the --hmd profile's.
#[test]
fn rig_round_trip_with_stencil_mask() {
    let dir = common::scratch("bad", "rig-trip");
    let cap = dir.join("cap");
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{args:?}: {stderr}");
    };
    run(&[
        "run",
        "--xr",
        "headless",
        "--scene",
        "factory:50",
        "--hmd-fallback",
        "monado-sim",
        "--width",
        "64",
        "--height",
        "48",
        "--frames",
        "2",
        "--capture",
        cap.to_str().unwrap(),
    ]);
    let rig_path = cap.join("rig.json");
    let mut rig: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rig_path).unwrap()).unwrap();
    let area = rig["views"][0]["hidden_area"]
        .as_array()
        .expect("hidden_area");
    assert!(!area.is_empty() && area.len().is_multiple_of(3));
    for (name, opt) in [("plain", ""), ("masked", "stencil-mask")] {
        let out = dir.join(name);
        run(&[
            "render",
            "--scene",
            "factory:50",
            "--hmd",
            "monado-sim",
            "--rig",
            rig_path.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--opt",
            opt,
            "--out",
            out.to_str().unwrap(),
        ]);
    }
    let img = |p: &Path| image::open(p).unwrap().to_rgba8();
    let captured = img(&cap.join("left.png"));
    let plain = img(&dir.join("plain/left.png"));
    let masked = img(&dir.join("masked/left.png"));
    let mean_diff = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(x, y)| (*x as f64 - *y as f64).abs())
            .sum::<f64>()
            / a.as_raw().len() as f64
    };
    assert!(
        mean_diff(&captured, &plain) < 1.0,
        "render --rig reproduces the captured views"
    );
    let changed = common::pixels_differing(&masked, &plain);
    assert!(changed > 0, "the stencil mask hides part of the image");
    // An older rig file, without hidden areas: the profile's are used.
    for v in rig["views"].as_array_mut().unwrap() {
        v.as_object_mut().unwrap().remove("hidden_area");
    }
    let old = dir.join("old-rig.json");
    std::fs::write(&old, rig.to_string()).unwrap();
    run(&[
        "render",
        "--scene",
        "factory:50",
        "--hmd",
        "monado-sim",
        "--rig",
        old.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
        "--opt",
        "stencil-mask",
        "--out",
        dir.join("old").to_str().unwrap(),
    ]);
    assert_eq!(img(&dir.join("old/left.png")), masked);
}

/// Class 3: one image sampled by 2000 textures is decoded and held once.
#[cfg(unix)]
#[test]
fn shared_image_is_held_once() {
    let dir = common::scratch("bad", "shared-image");
    image::RgbaImage::from_pixel(1024, 1024, image::Rgba([90, 120, 200, 255]))
        .save(dir.join("one.png"))
        .unwrap();
    let n = 2000;
    let bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .chain([0u16, 1, 2, 0].iter().flat_map(|i| i.to_le_bytes()))
        .collect();
    use base64::Engine as _;
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": format!("data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)), "byteLength": bin.len()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
        "images": [{"uri": "one.png"}],
        "textures": (0..n).map(|_| serde_json::json!({"source": 0})).collect::<Vec<_>>(),
        "materials": (0..n).map(|i| serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": i}}})).collect::<Vec<_>>(),
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0
    });
    let path = dir.join("shared.gltf");
    std::fs::write(&path, gltf.to_string()).unwrap();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vergence"));
    cmd.args(["inspect", path.to_str().unwrap()]);
    let o = run_bounded(&mut cmd, &dir, "inspect", true);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    // 2000 copies of 4 MiB would be 8 GiB; one is 4 MiB.
    assert!(o.peak_rss_mb < 512, "peak RSS {} MB", o.peak_rss_mb);
    assert!(o.seconds < CASE_SECONDS, "{} s", o.seconds);
}

/// Class 12: a scene that fails to load after the first was measured keeps
/// the first group: the report is written and the error names the scene.
#[test]
fn bench_keeps_what_finished() {
    let dir = common::scratch("bad", "keep");
    std::fs::write(dir.join("broken.gltf"), "{\"asset\": {\"version\": ").unwrap();
    let plan = dir.join("plan.toml");
    std::fs::write(
        &plan,
        format!(
            "name = \"p\"\nscenes = [\"factory:10\", {:?}]\nhmds = [\"monado-sim\"]\nscales = [0.25]\nframes = 2\nwarmup = 1\n[[configs]]\nname = \"a\"\nopt = \"two-pass\"\n",
            dir.join("broken.gltf").to_str().unwrap()
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let stderr = fails(&[
        "bench",
        "--plan",
        plan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        stderr.contains("broken.gltf")
            && stderr.contains("invalid glTF JSON")
            && stderr.contains("wrote the 2 finished configurations"),
        "{stderr}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(v["groups"].as_array().map(Vec::len), Some(1));
    assert_eq!(v["complete"], false);
    assert!(v["error"].as_str().unwrap().contains("broken.gltf"));
    assert!(out.join("report.md").exists());
}

/// Class 11 and 13: FLIP on images under 100 px works; an error whose
/// message already holds its cause does not repeat it; compare never
/// touches its inputs.
#[test]
fn small_images_compare_and_errors_say_things_once() {
    let dir = common::scratch("bad", "small");
    let a = dir.join("a.png");
    let b = dir.join("b.png");
    image::RgbaImage::from_pixel(8, 8, image::Rgba([10, 20, 30, 255]))
        .save(&a)
        .unwrap();
    image::RgbaImage::from_pixel(8, 8, image::Rgba([12, 20, 30, 255]))
        .save(&b)
        .unwrap();
    let before = std::fs::read(&a).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["flip_p99"].as_f64().unwrap() >= 0.0);
    assert!(dir.join("b.flip.png").exists());
    // Heat map over the reference: refused, the reference untouched.
    let stderr = fails(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--heatmap",
        a.to_str().unwrap(),
    ]);
    assert!(stderr.contains("never writes over an input"), "{stderr}");
    assert_eq!(std::fs::read(&a).unwrap(), before);
    let stderr = fails(&["inspect", dir.join("nothing.gltf").to_str().unwrap()]);
    // One plain reason, without the system's error number.
    let lower = stderr.to_lowercase();
    assert_eq!(lower.matches("no such file").count(), 1, "{stderr}");
    assert!(!stderr.contains("os error"), "{stderr}");
}
