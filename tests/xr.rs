//! OpenXR integration: `vergence run` against Monado (simulated HMD or the
//! remote driver) started by `scripts/with-monado`, as `cargo xtask xr`
//! does. These tests run inside the Debian 13 root (`cargo xtask test`
//! makes `scripts/in-root` cargo's runner); they fail, not skip, without
//! Monado.

mod common;
use vergence::xr::remote as monado_remote;

use monado_remote::{RemoteHead, RemotePose};
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use vergence::bench::metrics;

/// One Monado at a time: the remote driver's port is fixed and the
/// machine has two cores.
static MONADO: Mutex<()> = Mutex::new(());

const SIM_FOV_H: f64 = 0.7418;
const SIM_FOV_V: f64 = 0.7788;

fn lock() -> std::sync::MutexGuard<'static, ()> {
    MONADO.lock().unwrap_or_else(|e| e.into_inner())
}

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_vergence")
}

fn out_dir(name: &str) -> PathBuf {
    let d = common::root().join("target/xr-tests").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("test output dir");
    d
}

fn with_monado(remote: bool) -> Command {
    let script = common::root().join("scripts/with-monado");
    assert!(
        Command::new("sh")
            .args(["-c", "command -v monado-service"])
            .output()
            .is_ok_and(|o| o.status.success()),
        "monado-service is not installed here: run the suite with `cargo xtask test` (it runs tests inside target/xr-root)"
    );
    let mut c = Command::new(script);
    if remote {
        c.arg("--remote");
    }
    c.arg(bin());
    c
}

/// `vergence run --xr openxr ARGS --stats-out S_PATH` under Monado (ARGS
/// split at spaces), which must succeed; its output and stats.
fn run_openxr(s_path: &Path, args: &str) -> (Output, Value) {
    let o = with_monado(false)
        .args(["run", "--xr", "openxr"])
        .args(args.split_whitespace())
        .arg("--stats-out")
        .arg(s_path)
        .output()
        .expect("with-monado");
    assert!(o.status.success(), "{}", text(&o));
    let s = stats(s_path);
    (o, s)
}

/// The `aq` records of a run's frames.
fn aq_frames(s: &Value) -> Vec<&Value> {
    s["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|f| f.get("aq"))
        .collect()
}

fn stats(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("stats JSON")
}

fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn assert_no_validation(o: &Output, s: &Value) {
    let all = text(o);
    assert_eq!(s["validation_messages"], 0, "Vulkan validation: {all}");
    assert_eq!(s["xr_validation_messages"], 0, "OpenXR validation: {all}");
    for bad in ["VALID_ERROR", "VALID_WARNING", "VUID-"] {
        let hits: Vec<&str> = all
            .lines()
            .filter(|l| l.contains(bad) && !l.contains("VUID-CoreValidation-"))
            .collect();
        assert!(hits.is_empty(), "validation output {bad}: {hits:?}");
    }
    assert_eq!(
        s["api_layers"][0], "XR_APILAYER_LUNARG_core_validation",
        "the core validation layer must be on"
    );
}

/// A JSON array of strings.
fn strings(v: &Value) -> Vec<&str> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_str().unwrap_or_else(|| panic!("not a string: {x}")))
        .collect()
}

fn fov_close(v: &Value, want: [f64; 4], tol: f64) -> bool {
    let got =
        [&v["left"], &v["right"], &v["up"], &v["down"]].map(|x| x.as_f64().unwrap_or(f64::NAN));
    got.iter().zip(want).all(|(g, w)| (g - w).abs() <= tol)
}

#[test]
fn session_reaches_focused_submits_100_frames_with_the_runtimes_fovs() {
    let _g = lock();
    let dir = out_dir("session");
    let s_path = dir.join("stats.json");
    let o = with_monado(false)
        .args([
            "run",
            "--xr",
            "openxr",
            "--frames",
            "100",
            "--scene",
            "factory:2000",
        ])
        .args([
            "--hmd-fallback",
            "valve-index",
            "--opt",
            "superfrustum",
            "--stats-out",
        ])
        .arg(&s_path)
        .output()
        .expect("with-monado");
    assert!(o.status.success(), "{}", text(&o));
    let s = stats(&s_path);
    assert_eq!(s["mode"], "openxr");
    assert_eq!(s["system"], "Monado: Simulated HMD");
    assert_eq!(s["focused"], true);
    assert!(s["frames_submitted"].as_u64().unwrap() >= 100, "{s}");
    let states = strings(&s["states"]);
    for want in [
        "IDLE",
        "READY",
        "SYNCHRONIZED",
        "VISIBLE",
        "FOCUSED",
        "STOPPING",
        "EXITING",
    ] {
        assert!(states.contains(&want), "{want} missing from {states:?}");
    }
    assert_eq!(states.last(), Some(&"EXITING"));
    let exts = strings(&s["extensions_enabled"]);
    for want in [
        "XR_KHR_vulkan_enable2",
        "XR_KHR_visibility_mask",
        "XR_KHR_composition_layer_depth",
        "XR_EXT_debug_utils",
    ] {
        assert!(exts.contains(&want), "{want} not enabled: {exts:?}");
    }
    assert!(s["color_format"].as_str().unwrap().ends_with("_SRGB"));
    assert!(s["depth_format"].is_string(), "depth layer expected: {s}");
    assert_eq!(
        s["image_size"],
        serde_json::json!([320, 240]),
        "Monado's recommended size"
    );
    for m in s["visibility_mask"].as_array().unwrap() {
        assert!(
            m[0].as_u64().unwrap() >= 3 && m[1].as_u64().unwrap() >= 3,
            "hidden mesh {m}"
        );
    }
    let sim = [-SIM_FOV_H, SIM_FOV_H, SIM_FOV_V, -SIM_FOV_V];
    let mut rendered = 0;
    for f in s["frames"].as_array().unwrap() {
        assert!(f["predicted_display_period_ns"].as_i64().unwrap() > 0);
        if f["should_render"] == true {
            rendered += 1;
            for v in f["fov"].as_array().unwrap() {
                assert!(
                    fov_close(v, sim, 1e-4),
                    "frame {} rendered and culled with FOV {v}, not Monado's",
                    f["index"]
                );
            }
            assert!(f["gpu_ms"].as_f64().unwrap() > 0.0);
        }
    }
    assert!(rendered >= 100);
    let cull = &s["cull"];
    assert!(
        cull["accepted"].as_u64().unwrap() > 0 && cull["rejected"].as_u64().unwrap() > 0,
        "culling ran on the runtime's rig: {cull}"
    );
    assert_no_validation(&o, &s);
}

#[test]
fn two_pass_uses_one_swapchain_per_view_at_one_sample() {
    let _g = lock();
    let dir = out_dir("two-pass");
    let s_path = dir.join("stats.json");
    let cap = dir.join("capture");
    let o = with_monado(false)
        .args([
            "run",
            "--xr",
            "openxr",
            "--frames",
            "12",
            "--scene",
            "factory:2000",
        ])
        .args([
            "--stereo", "two-pass", "--msaa", "1", "--width", "200", "--height", "160",
        ])
        .arg("--capture")
        .arg(&cap)
        .arg("--stats-out")
        .arg(&s_path)
        .output()
        .expect("with-monado");
    assert!(o.status.success(), "{}", text(&o));
    let s = stats(&s_path);
    assert_eq!(s["config"]["stereo"], "two-pass");
    assert_eq!(
        s["image_size"],
        serde_json::json!([200, 160]),
        "size override"
    );
    assert!(s["frames_submitted"].as_u64().unwrap() >= 12);
    for eye in ["left.png", "right.png"] {
        let img = image::open(cap.join(eye)).expect("captured eye").to_rgba8();
        assert_eq!(img.dimensions(), (200, 160));
        let distinct: std::collections::HashSet<[u8; 4]> = img.pixels().map(|p| p.0).collect();
        assert!(
            distinct.len() > 50,
            "{eye} looks empty ({} colours)",
            distinct.len()
        );
    }
    assert_no_validation(&o, &s);
}

#[test]
fn one_and_three_frames_in_flight_run_clean_under_the_runtime() {
    let _g = lock();
    for n in ["1", "3"] {
        let dir = out_dir(&format!("in-flight-{n}"));
        let s_path = dir.join("stats.json");
        let o = with_monado(false)
            .args(["run", "--xr", "openxr", "--frames", "20"])
            .args(["--scene", "factory:2000", "--opt", "superfrustum"])
            .args(["--frames-in-flight", n, "--width", "160", "--height", "128"])
            .arg("--stats-out")
            .arg(&s_path)
            .output()
            .expect("with-monado");
        assert!(o.status.success(), "{n}: {}", text(&o));
        let s = stats(&s_path);
        assert_eq!(s["config"]["frames_in_flight"], n.parse::<u64>().unwrap());
        let frames = s["frames"].as_array().unwrap();
        assert!(frames.len() >= 20, "{n}: every frame has a record");
        for (i, f) in frames.iter().enumerate() {
            assert_eq!(f["index"], i as u64, "{n}: records in frame order");
            if f["should_render"] == true {
                assert!(f["gpu_ms"].as_f64().unwrap() > 0.0, "{n}: frame {i}: {f}");
            }
        }
        assert_no_validation(&o, &s);
    }
}

#[test]
fn adaptive_quality_submits_each_frames_sub_image_clean_under_the_runtime() {
    let _g = lock();
    let dir = out_dir("aq");
    let s_path = dir.join("stats.json");
    // A budget every frame misses on lavapipe: the level falls to the
    // lowest and the sub-image shrinks, in swapchains made for 1.4x.
    let (o, s) = run_openxr(&s_path, "--frames 40 --scene factory:2000 --opt superfrustum,aq --budget-ms 1 --width 160 --height 120");
    assert_eq!(s["config"]["aq"], true);
    let aq = aq_frames(&s);
    assert!(aq.len() >= 30, "{} frames with aq", aq.len());
    let size = |a: &Value| {
        [
            a["size"][0].as_u64().unwrap(),
            a["size"][1].as_u64().unwrap(),
        ]
    };
    let first = size(aq[0]);
    let last = size(aq.last().unwrap());
    assert_eq!(
        aq.last().unwrap()["level"],
        0,
        "at the lowest level: {aq:?}"
    );
    assert_eq!(last, [104, 78], "0.65 x 160x120");
    assert!(first[0] > last[0], "{first:?} → {last:?}");
    assert!(aq.iter().all(|a| a["budget_ms"] == 1.0));
    assert_no_validation(&o, &s);
}

#[test]
fn the_inset_and_its_aq_rungs_run_clean_under_the_runtime() {
    let _g = lock();
    let dir = out_dir("inset");
    // inset-wide-1x: the wide views at one sample, the insets at 4x.
    let s_path = dir.join("wide-1x.json");
    let (o, s) = run_openxr(&s_path, "--frames 20 --scene factory:2000 --opt superfrustum,inset,inset-wide-1x --width 160 --height 128");
    let path = s["inset_path"].as_str().unwrap_or_default();
    assert!(path.ends_with("wide views at 1 sample"), "{path}");
    assert_no_validation(&o, &s);
    // inset with aq under a budget every frame misses: the level falls
    // through the render scales and on down the inset's rungs (the wide
    // view at one sample, then smaller), each frame's sub-image submitted.
    let s_path = dir.join("aq.json");
    let (o, s) = run_openxr(&s_path, "--frames 60 --scene factory:2000 --opt superfrustum,inset,aq --budget-ms 1 --width 160 --height 120");
    let aq = aq_frames(&s);
    let last = aq.last().expect("frames with aq");
    assert_eq!(last["level"], 0, "at the lowest level: {aq:?}");
    assert_eq!(last["wide_one_sample"], true, "{last}");
    let factor = last["wide_factor"].as_f64().unwrap();
    assert!((factor - 1.15f64.powf(-4.5)).abs() < 1e-9, "{factor}");
    assert_eq!(last["size"], serde_json::json!([104, 78]), "0.65 x 160x120");
    assert_no_validation(&o, &s);
}

#[test]
fn lens_matched_shading_runs_clean_under_the_runtime() {
    let _g = lock();
    let dir = out_dir("lms");
    let s_path = dir.join("stats.json");
    let (o, s) = run_openxr(
        &s_path,
        "--frames 20 --scene factory:2000 --opt superfrustum,lms --width 160 --height 128",
    );
    // The runtime's views carry no lens: the default coefficient, and on
    // lavapipe the vertex-shader path.
    let lms = &s["lms"];
    assert!(
        lms["path"].as_str().unwrap().starts_with("vertex-shader"),
        "{lms}"
    );
    assert_eq!(lms["coefficients"]["left"], 409.0 / 1024.0);
    assert!(lms["size"][0].as_u64().unwrap() < 160, "{lms}");
    let rendered = s["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["should_render"] == true && f["gpu_ms"].as_f64().unwrap_or(0.0) > 0.0)
        .count();
    assert!(rendered >= 15, "{rendered} frames rendered");
    assert_no_validation(&o, &s);
}

fn yaw_quat(deg: f32) -> [f32; 4] {
    let h = deg.to_radians() * 0.5;
    [0.0, h.sin(), 0.0, h.cos()]
}

#[test]
fn remote_driver_pose_and_asymmetric_fov_reach_the_submitted_frame() {
    let _g = lock();
    let dir = out_dir("remote");
    let s_path = dir.join("stats.json");
    let cap = dir.join("capture");
    let fovs = [[-0.9f32, 0.6, 0.7, -0.8], [-0.6f32, 0.9, 0.75, -0.85]];
    let head = RemoteHead {
        center: RemotePose {
            orientation: yaw_quat(20.0),
            position: [0.2, 1.6, -0.3],
        },
        views: [
            (
                fovs[0],
                RemotePose {
                    orientation: [0.0, 0.0, 0.0, 1.0],
                    position: [-0.032, 0.0, 0.0],
                },
            ),
            (
                fovs[1],
                RemotePose {
                    orientation: [0.0, 0.0, 0.0, 1.0],
                    position: [0.032, 0.0, 0.0],
                },
            ),
        ],
    };
    let done = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicBool::new(false));
    let feeder = {
        let (done, sent) = (done.clone(), sent.clone());
        std::thread::spawn(move || -> Result<(), String> {
            let mut s = monado_remote::connect(Duration::from_secs(20))
                .map_err(|e| format!("cannot reach the remote driver: {e}"))?;
            while !done.load(Ordering::SeqCst) {
                match monado_remote::send(&mut s, &head) {
                    Ok(()) => sent.store(true, Ordering::SeqCst),
                    // Monado is stopped once vergence exits.
                    Err(_) if sent.load(Ordering::SeqCst) => break,
                    Err(e) => return Err(e.to_string()),
                }
                std::thread::sleep(Duration::from_millis(30));
            }
            Ok(())
        })
    };
    let o = with_monado(true)
        .args([
            "run",
            "--xr",
            "openxr",
            "--frames",
            "40",
            "--scene",
            "factory:2000",
        ])
        .args(["--width", "256", "--height", "224", "--capture"])
        .arg(&cap)
        .arg("--stats-out")
        .arg(&s_path)
        .output()
        .expect("with-monado");
    done.store(true, Ordering::SeqCst);
    let fed = feeder.join().expect("feeder thread");
    assert!(o.status.success(), "{}", text(&o));
    fed.expect("remote driver fed");
    assert!(sent.load(Ordering::SeqCst));
    let s = stats(&s_path);
    assert_no_validation(&o, &s);
    let rig: Value =
        serde_json::from_str(&std::fs::read_to_string(cap.join("rig.json")).unwrap()).unwrap();
    // Controllers inactive in the packet: head-only, no events, and the
    // last frame's head_world is the captured rig's head.
    let rendered: Vec<&Value> = s["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["should_render"] == true)
        .collect();
    for f in &rendered {
        assert_eq!(f["events"], serde_json::json!([]), "frame {}", f["index"]);
        assert!(f["head_world"]["orientation"].is_array(), "{}", f["index"]);
    }
    let last = rendered.last().expect("rendered frames");
    for key in ["position", "orientation"] {
        let (got, want) = (&last["head_world"][key], &rig["head"][key]);
        let n = want.as_array().expect("rig head").len();
        for i in 0..n {
            let (g, w) = (got[i].as_f64().unwrap(), want[i].as_f64().unwrap());
            assert!(
                (g - w).abs() < 1e-6,
                "head_world {key} {got} vs the captured rig's {want}"
            );
        }
    }
    for (eye, want) in fovs.iter().enumerate() {
        let want = want.map(|x| x as f64);
        assert!(
            fov_close(&rig["views"][eye]["fov"], want, 1e-5),
            "view {eye} FOV {} is not the one set through the runtime {want:?}",
            rig["views"][eye]["fov"]
        );
    }
    let p = |eye: usize| -> [f64; 3] {
        let v = &rig["views"][eye]["pose"]["position"];
        [0, 1, 2].map(|i| v[i].as_f64().unwrap())
    };
    let (a, b) = (p(0), p(1));
    let ipd = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!(
        (ipd - 0.064).abs() < 1e-4,
        "eye separation {ipd} from the remote eye poses"
    );

    // The same rig rendered headless must give the frame that was submitted.
    let again = dir.join("render");
    let r = Command::new(bin())
        .args(["render", "--scene", "factory:2000", "--hmd", "monado-sim"])
        .args(["--width", "256", "--height", "224", "--rig"])
        .arg(cap.join("rig.json"))
        .arg("--out")
        .arg(&again)
        .output()
        .expect("vergence render");
    assert!(r.status.success(), "{}", text(&r));
    for eye in ["left.png", "right.png"] {
        let submitted = image::open(cap.join(eye)).unwrap().to_rgba8();
        let rendered = image::open(again.join(eye)).unwrap().to_rgba8();
        let f = metrics::flip(&rendered, &submitted, metrics::DESKTOP_PPD).unwrap();
        // Same renderer, same views: only the swapchain copy differs, and a
        // copy is exact. 0.005 leaves room for nothing but noise.
        assert!(
            f.mean < 0.005,
            "{eye}: FLIP mean {} between the submitted frame and `render --rig`",
            f.mean
        );
    }
}

/// Starts `vergence run` under Monado with info logging and returns the
/// child plus a receiver that fires when the session is FOCUSED.
fn start_logged(
    rundir: &Path,
    extra: &[&str],
) -> (
    std::process::Child,
    std::sync::mpsc::Receiver<()>,
    Arc<Mutex<String>>,
) {
    let mut child = with_monado(false)
        .args([
            "run",
            "--xr",
            "openxr",
            "--scene",
            "factory:2000",
            "--seconds",
            "60",
        ])
        .args(extra)
        .env("VERGENCE_XR_RUNDIR", rundir)
        .env("RUST_LOG", "vergence=info")
        .env("NO_COLOR", "1")
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("with-monado");
    let (tx, rx) = std::sync::mpsc::channel();
    let log = Arc::new(Mutex::new(String::new()));
    let err = child.stderr.take().expect("piped");
    let sink = log.clone();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            if line.contains("session state Focused") {
                let _ = tx.send(());
            }
            if let Ok(mut l) = sink.lock() {
                l.push_str(&line);
                l.push('\n');
            }
        }
    });
    (child, rx, log)
}

/// Waits (30 s at most) for the session to reach FOCUSED.
fn await_focused(focused: &std::sync::mpsc::Receiver<()>, log: &Arc<Mutex<String>>) {
    focused
        .recv_timeout(Duration::from_secs(30))
        .unwrap_or_else(|_| panic!("never FOCUSED: {}", log.lock().unwrap()));
}

/// The pid of the monado-service `scripts/with-monado` started in `rundir`.
fn monado_pid(rundir: &Path) -> i32 {
    std::fs::read_to_string(rundir.join("monado.pid"))
        .expect("monado pid")
        .trim()
        .parse()
        .expect("pid")
}

fn signal(pid: i32, sig: i32) {
    // SAFETY: sending a signal to a process this test started.
    assert_eq!(unsafe { libc::kill(pid, sig) }, 0, "kill({pid}, {sig})");
}

/// The pid of `parent`'s child process whose name is `name` (from /proc).
fn child_named(parent: u32, name: &str) -> Option<i32> {
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: i32 = e.file_name().to_str()?.parse().ok()?;
        let stat = std::fs::read_to_string(e.path().join("stat")).ok()?;
        let (comm, rest) = stat.split_once(" (")?.1.rsplit_once(") ")?;
        let ppid: u32 = rest.split_whitespace().nth(1)?.parse().ok()?;
        (ppid == parent && comm == name).then_some(pid)
    })
}

fn wait_exit(child: &mut std::process::Child, limit: Duration) -> Option<std::process::ExitStatus> {
    let t = Instant::now();
    while t.elapsed() < limit {
        if let Ok(Some(s)) = child.try_wait() {
            return Some(s);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    None
}

#[test]
fn killing_monado_mid_session_ends_vergence_within_5_s_with_a_clear_error() {
    let _g = lock();
    let rundir = out_dir("kill").join("run");
    let (mut child, focused, log) = start_logged(&rundir, &[]);
    await_focused(&focused, &log);
    std::thread::sleep(Duration::from_millis(500));
    let killed = Instant::now();
    signal(monado_pid(&rundir), libc::SIGKILL);
    let status = wait_exit(&mut child, Duration::from_secs(5));
    let took = killed.elapsed();
    let Some(status) = status else {
        let _ = child.kill();
        panic!(
            "vergence still running 5 s after monado-service was killed: {}",
            log.lock().unwrap()
        );
    };
    assert!(!status.success(), "a lost runtime must be a failure");
    std::thread::sleep(Duration::from_millis(100));
    let log = log.lock().unwrap().clone();
    let errors: Vec<&str> = log.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "one clear error line: {log}");
    assert!(
        errors[0].contains("runtime"),
        "the error names the runtime: {}",
        errors[0]
    );
    eprintln!(
        "vergence exited {took:?} after monado-service was killed: {}",
        errors[0]
    );
}

#[test]
fn sigterm_ends_the_session_in_order() {
    let _g = lock();
    let dir = out_dir("sigterm");
    let s_path = dir.join("stats.json");
    let rundir = dir.join("run");
    let s_arg = s_path.to_string_lossy().to_string();
    let (mut child, focused, log) = start_logged(&rundir, &["--stats-out", &s_arg]);
    await_focused(&focused, &log);
    std::thread::sleep(Duration::from_millis(300));
    let pid = child_named(child.id(), "vergence").expect("vergence is a child of with-monado");
    signal(pid, libc::SIGTERM);
    let status = wait_exit(&mut child, Duration::from_secs(10)).expect("exited after SIGTERM");
    assert!(status.success(), "orderly exit: {}", log.lock().unwrap());
    let s = stats(&s_path);
    let states = strings(&s["states"]);
    assert_eq!(
        &states[states.len() - 3..],
        &["STOPPING", "IDLE", "EXITING"],
        "{states:?}"
    );
    assert_eq!(s["exit"], "session exited after vergence asked to exit");
}

#[test]
fn without_a_runtime_auto_falls_back_and_openxr_fails_naming_the_manifest() {
    let dir = out_dir("fallback");
    let s_path = dir.join("stats.json");
    let missing = "/nonexistent/openxr/active_runtime.json";
    let o = Command::new(bin())
        .args([
            "run",
            "--xr",
            "auto",
            "--frames",
            "3",
            "--scene",
            "factory:200",
        ])
        .args(["--hmd-fallback", "monado-sim", "--stats-out"])
        .arg(&s_path)
        .env("XR_RUNTIME_JSON", missing)
        .output()
        .expect("vergence");
    assert!(o.status.success(), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    let notes: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("no OpenXR headset"))
        .collect();
    assert_eq!(notes.len(), 1, "one line about the fallback: {err}");
    assert!(
        notes[0].contains(missing) && notes[0].contains("headless on the monado-sim profile"),
        "{}",
        notes[0]
    );
    let s = stats(&s_path);
    assert_eq!(s["mode"], "headless");
    assert_eq!(s["frames_submitted"], 3);
    assert!(s["fallback_reason"].as_str().unwrap().contains(missing));

    let o = Command::new(bin())
        .args([
            "run",
            "--xr",
            "openxr",
            "--frames",
            "3",
            "--scene",
            "factory:200",
        ])
        .env("XR_RUNTIME_JSON", missing)
        .output()
        .expect("vergence");
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    assert!(
        errors[0].contains("OpenXR unavailable") && errors[0].contains(missing),
        "{}",
        errors[0]
    );
}

#[test]
fn reconnect_survives_monado_restarting() {
    let _g = lock();
    let dir = out_dir("reconnect");
    let s_path = dir.join("stats.json");
    let rundir = dir.join("run");
    let s_arg = s_path.to_string_lossy().to_string();
    let (mut child, focused, log) = start_logged(&rundir, &["--reconnect", "--stats-out", &s_arg]);
    await_focused(&focused, &log);
    std::thread::sleep(Duration::from_millis(300));
    signal(monado_pid(&rundir), libc::SIGKILL);
    std::thread::sleep(Duration::from_millis(1500));
    assert!(
        child.try_wait().expect("wait").is_none(),
        "with --reconnect vergence keeps running: {}",
        log.lock().unwrap()
    );
    // A new monado-service in the same runtime directory.
    let _ = std::fs::remove_file(rundir.join("monado_comp_ipc"));
    let mut second = Command::new("monado-service")
        .env("XDG_RUNTIME_DIR", &rundir)
        .env("XRT_COMPOSITOR_NULL", "1")
        .env("XRT_NO_STDIN", "1")
        .env("SIMULATED_ENABLE", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("monado-service");
    let again = focused.recv_timeout(Duration::from_secs(30));
    let vergence = child_named(child.id(), "vergence");
    if let Some(pid) = vergence {
        signal(pid, libc::SIGTERM);
    }
    let status = wait_exit(&mut child, Duration::from_secs(10));
    let _ = second.kill();
    let _ = second.wait();
    let log = log.lock().unwrap().clone();
    again.unwrap_or_else(|_| panic!("no second FOCUSED session after monado came back: {log}"));
    let status = status.expect("exited after SIGTERM");
    assert!(status.success(), "orderly exit after reconnecting: {log}");
    assert!(log.contains("reconnecting in 1 s"), "{log}");
    let s = stats(&s_path);
    assert!(
        s["reconnects"].as_u64().unwrap() >= 1,
        "{}",
        s["reconnects"]
    );
    let focused_count = strings(&s["states"])
        .iter()
        .filter(|st| **st == "FOCUSED")
        .count();
    assert!(focused_count >= 2, "{:?}", s["states"]);
}

/// The test layer offering XR_VARJO_quad_views
/// (`examples/quad_views_layer.rs`, built by `cargo test --workspace`) and
/// a manifest for it in `dir`.
fn quad_views_layer(dir: &Path, extension: bool) -> PathBuf {
    let exe = std::env::current_exe().expect("test binary");
    let lib = exe
        .parent()
        .and_then(Path::parent)
        .expect("target/debug")
        .join("examples/libquad_views_layer.so");
    assert!(
        lib.is_file(),
        "{} is missing: cargo build --example quad_views_layer (cargo xtask test builds it)",
        lib.display()
    );
    let layers = dir.join(if extension { "layers" } else { "layers-core" });
    std::fs::create_dir_all(&layers).unwrap();
    let manifest = serde_json::json!({
        "file_format_version": "1.0.0",
        "api_layer": {
            "name": "XR_APILAYER_VERGENCE_quad_views",
            "library_path": lib,
            "api_version": "1.1",
            "implementation_version": "1",
            "description": "vergence test layer: XR_VARJO_quad_views over a stereo runtime",
        }
    });
    let mut manifest = manifest;
    if extension {
        manifest["api_layer"]["instance_extensions"] =
            serde_json::json!([{"name": "XR_VARJO_quad_views", "extension_version": "2"}]);
    }
    std::fs::write(layers.join("quad_views.json"), manifest.to_string()).unwrap();
    layers
}

/// A mean absolute difference per channel between the wide view `wide`
/// and the inset `inset` (at `scale` × its density) placed at `at` in the
/// wide view, inset pixels averaged over the wide view's pixels.
fn inset_against_wide(
    wide: &image::RgbaImage,
    inset: &image::RgbaImage,
    at: (i64, i64),
    ratio: u32,
) -> f64 {
    let (mut sum, mut n) = (0.0, 0u64);
    for y in 0..inset.height() / ratio {
        for x in 0..inset.width() / ratio {
            let (wx, wy) = (at.0 + x as i64, at.1 + y as i64);
            if wx < 0 || wy < 0 || wx >= wide.width() as i64 || wy >= wide.height() as i64 {
                continue;
            }
            let w = wide.get_pixel(wx as u32, wy as u32);
            for c in 0..3 {
                let mut acc = 0.0;
                for dy in 0..ratio {
                    for dx in 0..ratio {
                        acc += inset.get_pixel(x * ratio + dx, y * ratio + dy)[c] as f64;
                    }
                }
                sum += (acc / (ratio * ratio) as f64 - w[c] as f64).abs();
                n += 1;
            }
        }
    }
    sum / n.max(1) as f64
}

/// `vergence run --xr openxr ARGS` (split at spaces) at 160×128 under
/// Monado with the quad-views test layer of `layers` below the core
/// validation layer, which must succeed cleanly: its stats and the
/// layer's log of projection layers (JSON lines).
fn run_with_layer(dir: &Path, layers: &Path, name: &str, args: &str) -> (Value, Vec<Value>) {
    run_with_layer_env(dir, layers, name, args, &[])
}

/// [`run_with_layer`] with `env` set for the layer too, and the size left
/// to the runtime when `args` has no `--width`.
fn run_with_layer_env(
    dir: &Path,
    layers: &Path,
    name: &str,
    args: &str,
    env: &[(&str, &str)],
) -> (Value, Vec<Value>) {
    let log = dir.join(format!("{name}-layer.jsonl"));
    let s_path = dir.join(format!("{name}.json"));
    let o = with_monado(false)
        .env(
            "XR_API_LAYER_PATH",
            format!(
                "{}:/usr/share/openxr/1/api_layers/explicit.d",
                layers.display()
            ),
        )
        .env(
            "XR_ENABLE_API_LAYERS",
            "XR_APILAYER_LUNARG_core_validation:XR_APILAYER_VERGENCE_quad_views",
        )
        .env("VERGENCE_QUAD_LAYER_LOG", &log)
        .envs(env.iter().copied())
        .args(["run", "--xr", "openxr", "--scene", "factory:2000"])
        .args(if env.is_empty() {
            &["--width", "160", "--height", "128"][..]
        } else {
            &[][..]
        })
        .args(args.split_whitespace())
        .arg("--stats-out")
        .arg(&s_path)
        .output()
        .expect("with-monado");
    assert!(o.status.success(), "{}", text(&o));
    let s = stats(&s_path);
    assert_no_validation(&o, &s);
    let lines = std::fs::read_to_string(&log)
        .unwrap_or_else(|e| panic!("{}: {e}", log.display()))
        .lines()
        .map(|l| serde_json::from_str(l).expect("layer log line"))
        .collect();
    (s, lines)
}

/// Checks a quad session's projection layers: four views each, `chains`
/// swapchains, the wide views at 80×64 (half the eye) from the top left,
/// the focus views smaller than the eye with a FOV holding the runtime's
/// (0.4 × the eye's tangents) and no more than a pixel beyond it.
fn assert_quad_layers(name: &str, lines: &[Value], chains: u64) {
    assert_eq!(lines[0]["begin"], "foveated-inset", "{:?}", lines[0]);
    let frames: Vec<&Value> = lines.iter().filter(|l| l.get("views").is_some()).collect();
    assert!(frames.len() >= 15, "{} projection layers", frames.len());
    for f in &frames {
        assert_eq!(f["views"], 4, "{f}");
        assert_eq!(f["swapchains"], chains, "{name}: {f}");
        let rect = |i: usize| -> Vec<i64> {
            f["rect"][i]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_i64().unwrap())
                .collect()
        };
        assert_eq!(&rect(0)[..4], &[0, 0, 80, 64], "{f}");
        assert_eq!(&rect(1)[..4], &[0, 0, 80, 64], "{f}");
        let fov = |i: usize| -> Vec<f64> {
            f["fov"][i]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap().tan())
                .collect()
        };
        for eye in 0..2 {
            let (w, h) = (rect(2 + eye)[2], rect(2 + eye)[3]);
            assert!(w > 20 && w < 160 && h > 16 && h < 128, "{f}");
            let (e, got) = (fov(eye), fov(2 + eye));
            let pixel = [(e[1] - e[0]) / 160.0, (e[2] - e[3]) / 128.0];
            for side in 0..4 {
                let want = e[side] * 0.4;
                // Left and down are negative: outward is further down.
                let outward = if side == 0 || side == 3 {
                    want - got[side]
                } else {
                    got[side] - want
                };
                assert!(
                    outward > -1e-5 && outward < 1.01 * pixel[side / 2],
                    "{name} view {}: side {side} {} against the runtime's {want}",
                    2 + eye,
                    got[side]
                );
            }
        }
    }
}

/// Where the runtime takes quad views (here the test layer over Monado,
/// below the core validation layer), `inset` submits its four views as
/// they are: the session begins with PRIMARY_QUAD_VARJO, every projection
/// layer has four views, the wide views at F × the eye size and the focus
/// views at the inset rectangle's size with a FOV holding the runtime's;
/// the captured inset is the wide view's content at twice the density;
/// multiview and two-pass; with aq and with four views in one scope; and
/// with `inset-composite` the session stays stereo; no validation message.
#[test]
fn the_inset_goes_out_as_quad_views_where_the_runtime_takes_them() {
    let _g = lock();
    let dir = out_dir("quad-views");
    let layers = quad_views_layer(&dir, true);
    for (name, stereo, chains) in [("multiview", "multiview", 2), ("two-pass", "two-pass", 4)] {
        let capture = dir.join(format!("{name}-capture"));
        let args = format!(
            "--frames 20 --stereo {stereo} --opt superfrustum,inset --capture {}",
            capture.display()
        );
        let (s, lines) = run_with_layer(&dir, &layers, name, &args);
        assert_eq!(s["view_configuration"], "PRIMARY_QUAD_VARJO", "{name}");
        assert_eq!(s["api_version"], "1.1.0", "{name}");
        assert!(
            strings(&s["extensions_enabled"]).contains(&"XR_VARJO_quad_views"),
            "{}",
            s["extensions_enabled"]
        );
        let path = s["inset_path"].as_str().unwrap_or_default();
        assert!(path.ends_with("submitted as four views"), "{path}");
        assert_quad_layers(name, &lines, chains);
        let views = s["views"].as_array().unwrap();
        assert_eq!(views.len(), 4);
        let tan = |v: &Value, k: &str| v["fov"][k].as_f64().unwrap().tan();
        let ratio = tan(&views[2], "left") / tan(&views[0], "left");
        assert!((ratio - 0.4).abs() < 1e-4, "focus view 2: {}", views[2]);
        // The capture holds the four views as submitted.
        let img = |n: &str| image::open(capture.join(n)).unwrap().to_rgba8();
        let (wide, inset) = (img("left.png"), img("inset-left.png"));
        assert_eq!(wide.dimensions(), (80, 64));
        let last = lines.last().unwrap();
        let r = &last["rect"][2];
        assert_eq!(
            inset.dimensions(),
            (r[2].as_u64().unwrap() as u32, r[3].as_u64().unwrap() as u32)
        );
        // The inset, halved, is the wide view's content where the focus
        // FOV lies in the eye (and not a few pixels off it).
        let tan = |v: &Value, i: usize| v[i].as_f64().unwrap().tan();
        let (eye, foc) = (&last["fov"][0], &last["fov"][2]);
        let x0 = ((tan(foc, 0) - tan(eye, 0)) / (tan(eye, 1) - tan(eye, 0)) * 80.0).round() as i64;
        let y0 = ((tan(eye, 2) - tan(foc, 2)) / (tan(eye, 2) - tan(eye, 3)) * 64.0).round() as i64;
        let here = inset_against_wide(&wide, &inset, (x0, y0), 2);
        let off = inset_against_wide(&wide, &inset, (x0 + 6, y0 + 5), 2);
        assert!(
            here < 12.0 && here * 1.5 < off,
            "{name}: {here} here, {off} off"
        );
    }
    // With aq down its inset rungs, and with the four views in one scope:
    // the sub-images follow the scale and the wide view's factor.
    let wide_w = |l: &Value| l["rect"][0][2].as_i64().unwrap();
    let views = |lines: &[Value]| -> Vec<Value> {
        lines
            .iter()
            .filter(|l| l.get("views").is_some())
            .cloned()
            .collect()
    };
    let (s, lines) = run_with_layer(
        &dir,
        &layers,
        "aq",
        "--frames 40 --opt superfrustum,inset,aq --budget-ms 1",
    );
    assert_eq!(s["view_configuration"], "PRIMARY_QUAD_VARJO");
    let aq = aq_frames(&s);
    assert_eq!(aq.last().expect("aq frames")["level"], 0, "{aq:?}");
    let lines = views(&lines);
    let (first, end) = (lines.first().unwrap(), lines.last().unwrap());
    assert!(lines.iter().all(|l| l["views"] == 4));
    // 0.65 × 160 = 104 wide eyes, the wide view at 0.5 × 0.533 of that.
    assert!(wide_w(first) > wide_w(end), "{first} then {end}");
    assert!(wide_w(end) <= 28 && wide_w(end) >= 26, "{end}");
    let (s, lines) = run_with_layer(
        &dir,
        &layers,
        "four-view",
        "--frames 20 --opt superfrustum,inset,inset-views=4",
    );
    assert_eq!(s["view_configuration"], "PRIMARY_QUAD_VARJO");
    assert_quad_layers("four-view", &lines, 2);
    // inset-composite: a stereo session, composited here.
    let (s, lines) = run_with_layer(
        &dir,
        &layers,
        "composite",
        "--frames 20 --opt superfrustum,inset,inset-composite",
    );
    assert_eq!(s["view_configuration"], "PRIMARY_STEREO");
    assert_eq!(s["api_version"], "1.0.0");
    let path = s["inset_path"].as_str().unwrap_or_default();
    assert!(!path.contains("four views"), "{path}");
    let lines = views(&lines);
    assert!(
        !lines.is_empty() && lines.iter().all(|l| l["views"] == 2 && wide_w(l) == 160),
        "{:?}",
        lines.last()
    );
}

/// OpenXR 1.1's core PRIMARY_STEREO_WITH_FOVEATED_INSET (the layer's
/// manifest without XR_VARJO_quad_views: the configuration is offered to
/// a 1.1 instance only): with `inset` vergence asks for 1.1 and submits
/// the four views the same way; without the layer it composites.
#[test]
fn openxr_1_1s_foveated_inset_configuration_takes_the_four_views_too() {
    let _g = lock();
    let dir = out_dir("foveated-inset");
    let layers = quad_views_layer(&dir, false);
    let (s, lines) = run_with_layer(
        &dir,
        &layers,
        "core",
        "--frames 20 --opt superfrustum,inset",
    );
    assert_eq!(s["api_version"], "1.1.0");
    assert_eq!(
        s["view_configuration"],
        "PRIMARY_STEREO_WITH_FOVEATED_INSET"
    );
    assert!(!strings(&s["extensions_enabled"]).contains(&"XR_VARJO_quad_views"));
    assert_quad_layers("core", &lines, 2);
    let s_path = dir.join("plain.json");
    let (o, s) = run_openxr(
        &s_path,
        "--frames 10 --scene factory:2000 --opt superfrustum,inset --width 160 --height 128",
    );
    assert_no_validation(&o, &s);
    assert_eq!(s["view_configuration"], "PRIMARY_STEREO");
}

/// Context views recommended at half the focus views' density (as
/// Varjo's are; the test layer's VERGENCE_QUAD_LAYER_CONTEXT_SCALE=0.5):
/// the first frame goes out at the context views' 160×120, then the eyes
/// grow to 320×240 so that each inset has at least the focus view's
/// recommended 128×96 pixels (0.4 of Monado's 320×240), and every later
/// frame submits insets of that size.
#[test]
fn the_insets_get_the_focus_views_density_when_the_context_views_have_less() {
    let _g = lock();
    let dir = out_dir("quad-density");
    let layers = quad_views_layer(&dir, true);
    let (s, lines) = run_with_layer_env(
        &dir,
        &layers,
        "density",
        "--frames 12 --opt superfrustum,inset",
        &[("VERGENCE_QUAD_LAYER_CONTEXT_SCALE", "0.5")],
    );
    assert_eq!(s["view_configuration"], "PRIMARY_QUAD_VARJO");
    assert_eq!(s["views"][0]["recommended"], serde_json::json!([160, 120]));
    assert_eq!(s["views"][2]["recommended"], serde_json::json!([128, 96]));
    assert_eq!(s["image_size"], serde_json::json!([320, 240]));
    let frames: Vec<&Value> = lines.iter().filter(|l| l.get("views").is_some()).collect();
    let size = |f: &Value, i: usize| {
        (
            f["rect"][i][2].as_i64().unwrap(),
            f["rect"][i][3].as_i64().unwrap(),
        )
    };
    // The first frame at the context views' size: the wide view is 80×60.
    assert_eq!(size(frames[0], 0), (80, 60), "{}", frames[0]);
    let last = frames.last().unwrap();
    assert_eq!(size(last, 0), (160, 120), "{last}");
    for eye in 2..4 {
        let (w, h) = size(last, eye);
        assert!((128..=131).contains(&w) && (96..=99).contains(&h), "{last}");
    }
}
