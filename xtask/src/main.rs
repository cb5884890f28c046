//! `cargo xtask`: the README's commands.
//!
//! - `setup`: installs what is missing (Debian/Ubuntu packages as root, or
//!   prints the exact command) and builds the Debian 13 root in
//!   `target/xr-root` (Mesa 25 lavapipe, Vulkan validation layers, Monado).
//! - `demo`: runs the built-in factory scene: in a headset when an OpenXR
//!   runtime is active, else under Monado's simulated HMD, else headless;
//!   the last frame and the statistics land in `demo-output/`. `demo
//!   --rehearse [SCRIPT]` plays a scripted visit through Monado's remote
//!   driver instead.
//! - `xr -- ARGS`: runs `vergence ARGS` against Monado's simulated HMD
//!   (started before, stopped after; the exit code passes through).
//! - `test`: the whole suite (fmt, clippy, the bad-input corpus against its
//!   generator, a build of the binary for Windows when that target can be
//!   had, tests inside the root, then `tests/host_driver.rs` once more on
//!   the host).
//! - `corpus`: only the corpus check (see [`corpus`]).
//! - `gpu-bench [PLAN]`: prepares `target/gpu-bench/` for a GPU machine
//!   without Rust or a Vulkan loader (see [`gpu_bench`]).

mod corpus;
mod gpu_bench;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Host packages: shader compiler, SPIR-V validator, Vulkan loader,
/// lavapipe, validation layers, debootstrap for the test root, an X
/// server without a screen plus input scripting for the window tests, and
/// the MinGW C++ compiler the Windows check needs for meshoptimizer.
const HOST_PACKAGES: &[&str] = &[
    "glslc",
    "spirv-tools",
    "libvulkan1",
    "mesa-vulkan-drivers",
    "vulkan-validationlayers",
    "debootstrap",
    "xvfb",
    "xdotool",
    "g++-mingw-w64-x86-64",
];
/// Packages inside the Debian 13 root: a current lavapipe (Mesa 22.3 in
/// Debian 12 misroutes some multiview draws), validation layers, and the
/// OpenXR runtime Monado with its loader and validation layer, for the
/// window tests Xvfb, xdotool and the X client libraries winit loads, and
/// Wine to run the Windows binary.
const ROOT_PACKAGES: &[&str] = &[
    "mesa-vulkan-drivers",
    "vulkan-validationlayers",
    "libvulkan1",
    "spirv-tools",
    "monado-service",
    "libopenxr1-monado",
    "libopenxr-loader1",
    "openxr-layer-corevalidation",
    "libopenxr-utils",
    "xvfb",
    "xdotool",
    "libx11-6",
    "libx11-xcb1",
    "libxcursor1",
    "libxrandr2",
    "libxi6",
    "libxkbcommon-x11-0",
    "wine",
    "wine64",
];
const ROOT_SUITE: &str = "trixie";
/// Monado on distributions that ship it (Debian 13+, Ubuntu 24.04+).
const MONADO_PACKAGES: &[&str] = &[
    "monado-service",
    "libopenxr1-monado",
    "libopenxr-loader1",
    "openxr-layer-corevalidation",
];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the repo")
        .to_path_buf()
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

fn run(cmd: &mut Command) -> Result<(), String> {
    eprintln!("xtask: running {cmd:?}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{cmd:?} failed with {status}"))
    }
}

fn missing_packages(list: &[&str]) -> Vec<String> {
    list.iter()
        .filter(|p| {
            !Command::new("dpkg-query")
                .args(["-W", "-f=${Status}", p])
                .output()
                .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).contains("install ok installed"))
        })
        .map(|p| p.to_string())
        .collect()
}

fn setup_host() -> Result<(), String> {
    if Command::new("dpkg-query")
        .arg("--version")
        .output()
        .is_err()
    {
        return Err(format!(
            "this is not a Debian/Ubuntu system: install the equivalents of {} by hand",
            HOST_PACKAGES.join(" ")
        ));
    }
    apt_install(HOST_PACKAGES, "missing packages")
}

/// Installs those of `packages` that are missing, as root through apt;
/// otherwise fails with `what` and the exact command to run.
fn apt_install(packages: &[&str], what: &str) -> Result<(), String> {
    let missing = missing_packages(packages);
    if missing.is_empty() {
        return Ok(());
    }
    let cmd = format!(
        "apt-get update && apt-get install -y --no-install-recommends {}",
        missing.join(" ")
    );
    if !is_root() {
        return Err(format!("{what}; run as root:\n    sudo sh -c '{cmd}'"));
    }
    run(Command::new("sh")
        .args(["-c", &cmd])
        .env("DEBIAN_FRONTEND", "noninteractive"))
}

fn root_dir() -> PathBuf {
    std::env::var_os("VERGENCE_XR_ROOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("target/xr-root"))
}

fn root_ready(root: &Path) -> bool {
    root.join("usr/bin/monado-service").exists()
        && root.join("usr/bin/spirv-val").exists()
        && root.join(".vergence-ready").exists()
}

/// The packages of [`ROOT_PACKAGES`] that the ready root's record
/// (`.vergence-ready`, one package a line) does not list: added to the list
/// after the root was made.
fn root_missing(root: &Path) -> Vec<&'static str> {
    let have = std::fs::read_to_string(root.join(".vergence-ready")).unwrap_or_default();
    let have: Vec<&str> = have.lines().map(str::trim).collect();
    ROOT_PACKAGES
        .iter()
        .copied()
        .filter(|p| !have.contains(p))
        .collect()
}

fn setup_root() -> Result<(), String> {
    let root = root_dir();
    if root_ready(&root) {
        let missing = root_missing(&root);
        if missing.is_empty() {
            return Ok(());
        }
        if !is_root() {
            return Err(format!(
                "the test root {} lacks {}; as root run: cargo xtask setup",
                root.display(),
                missing.join(" ")
            ));
        }
        let install = format!(
            "apt-get update -qq && apt-get install -y -qq --no-install-recommends {}",
            missing.join(" ")
        );
        run(Command::new("chroot")
            .arg(&root)
            .args(["sh", "-c", &install])
            .env("DEBIAN_FRONTEND", "noninteractive"))?;
        return std::fs::write(root.join(".vergence-ready"), ROOT_PACKAGES.join("\n"))
            .map_err(|e| e.to_string());
    }
    if !is_root() {
        return Err(format!(
            "the test root {} is missing; as root run: cargo xtask setup (it runs debootstrap --variant=minbase {ROOT_SUITE})",
            root.display()
        ));
    }
    if root.exists() {
        let _ = std::fs::remove_dir_all(&root);
    }
    std::fs::create_dir_all(&root).map_err(|e| format!("{}: {e}", root.display()))?;
    run(Command::new("debootstrap")
        .args(["--variant=minbase", ROOT_SUITE])
        .arg(&root)
        .arg("http://deb.debian.org/debian"))?;
    let install = format!(
        "apt-get update -qq && apt-get install -y -qq --no-install-recommends {}",
        ROOT_PACKAGES.join(" ")
    );
    run(Command::new("chroot")
        .arg(&root)
        .args(["sh", "-c", &install])
        .env("DEBIAN_FRONTEND", "noninteractive"))?;
    std::fs::write(root.join(".vergence-ready"), ROOT_PACKAGES.join("\n"))
        .map_err(|e| e.to_string())?;
    Ok(())
}

fn setup() -> Result<(), String> {
    setup_host()?;
    setup_root()
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

fn runner_env(cmd: &mut Command) -> &mut Command {
    cmd.env(
        "CARGO_TARGET_X86_64_UNKNOWN_LINUX_GNU_RUNNER",
        repo().join("scripts/in-root"),
    )
    .env("VERGENCE_XR_ROOT", root_dir())
}

/// The Windows target `test` checks the binary for.
const WINDOWS_TARGET: &str = "x86_64-pc-windows-gnu";

/// Output of `cmd` when it ran and succeeded.
fn output_of(cmd: &mut Command) -> Option<String> {
    cmd.output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
}

/// Whether the standard library for `target` is installed: rustup's list
/// where rustup exists, else the compiler's sysroot.
fn target_installed(target: &str) -> bool {
    if let Some(list) = output_of(Command::new("rustup").args(["target", "list", "--installed"])) {
        return list.lines().any(|l| l.trim() == target);
    }
    output_of(Command::new("rustc").args(["--print", "sysroot"])).is_some_and(|root| {
        Path::new(root.trim())
            .join("lib/rustlib")
            .join(target)
            .join("lib")
            .is_dir()
    })
}

/// Runs `cmd`, killing it after `limit`; the error says why it failed.
fn run_with_limit(cmd: &mut Command, limit: std::time::Duration) -> Result<(), String> {
    eprintln!("xtask: running {cmd:?}");
    let mut child = cmd
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    let started = std::time::Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => {
                let mut stderr = String::new();
                if let Some(mut e) = child.stderr.take() {
                    let _ = std::io::Read::read_to_string(&mut e, &mut stderr);
                }
                let last = stderr.lines().rev().find(|l| !l.trim().is_empty());
                return if status.success() {
                    Ok(())
                } else {
                    Err(format!("{status}: {}", last.unwrap_or("no message")))
                };
            }
            Ok(None) if started.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("no answer within {} s", limit.as_secs()));
            }
            Ok(None) => std::thread::sleep(std::time::Duration::from_millis(200)),
            Err(e) => return Err(e.to_string()),
        }
    }
}

/// Cross-builds the binary for Windows when that target's standard
/// library is installed or rustup can add it, and returns the executable
/// (`tests/windows.rs` runs it under Wine); otherwise one line saying why
/// it was skipped.
fn build_windows(r: &Path) -> Result<Option<PathBuf>, String> {
    if !target_installed(WINDOWS_TARGET) {
        if output_of(Command::new("rustup").arg("--version")).is_none() {
            eprintln!("xtask: Windows build skipped: the {WINDOWS_TARGET} standard library is not installed and there is no rustup to add it");
            return Ok(None);
        }
        let limit = std::time::Duration::from_secs(300);
        if let Err(why) = run_with_limit(
            Command::new("rustup").args(["target", "add", WINDOWS_TARGET]),
            limit,
        ) {
            eprintln!(
                "xtask: Windows build skipped: rustup target add {WINDOWS_TARGET} failed ({why})"
            );
            return Ok(None);
        }
    }
    run(cargo()
        .current_dir(r)
        .args(["build", "--target", WINDOWS_TARGET, "--bin", "vergence"]))?;
    let exe = r.join(format!("target/{WINDOWS_TARGET}/debug/vergence.exe"));
    copy_mingw_runtime(exe.parent().expect("in a folder"))?;
    Ok(Some(exe))
}

/// The MinGW runtime libraries the executable links (its C++ parts'
/// standard library, libgcc, winpthreads), copied beside it: Wine, like
/// Windows, looks for them there.
fn copy_mingw_runtime(dir: &Path) -> Result<(), String> {
    for dll in [
        "libstdc++-6.dll",
        "libgcc_s_seh-1.dll",
        "libwinpthread-1.dll",
    ] {
        let found = output_of(
            Command::new("x86_64-w64-mingw32-g++").arg(format!("-print-file-name={dll}")),
        )
        .map(|p| PathBuf::from(p.trim()))
        .filter(|p| p.is_file())
        .or_else(|| {
            let p = PathBuf::from("/usr/x86_64-w64-mingw32/lib").join(dll);
            p.is_file().then_some(p)
        });
        if let Some(src) = found {
            std::fs::copy(&src, dir.join(dll))
                .map_err(|e| format!("copying {}: {e}", src.display()))?;
        }
    }
    Ok(())
}

fn test(args: &[String]) -> Result<(), String> {
    setup()?;
    let r = repo();
    run(cargo()
        .current_dir(&r)
        .args(["fmt", "--all", "--", "--check"]))?;
    run(cargo().current_dir(&r).args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ]))?;
    corpus::check(&r)?;
    let windows = build_windows(&r)?;
    let mut cmd = cargo();
    if let Some(exe) = &windows {
        cmd.env("VERGENCE_WINDOWS_EXE", exe);
    }
    cmd.current_dir(&r)
        .args(["test", "--workspace"])
        .args(args)
        .env("VERGENCE_VALIDATION", "required")
        .env("VERGENCE_XR_VALIDATION", "required")
        .env("VERGENCE_REQUIRE_SPIRV_VAL", "1");
    run(runner_env(&mut cmd))?;
    // The host's own Vulkan driver: outside the root (skips itself where
    // the host's lavapipe is not older than Mesa 23).
    run(cargo()
        .current_dir(&r)
        .args(["test", "--test", "host_driver"])
        .env_remove("CARGO_TARGET_X86_64_UNKNOWN_LINUX_GNU_RUNNER"))
}

/// How Monado runs here.
enum Monado {
    /// Installed on the host.
    Native,
    /// Inside the Debian 13 root (`scripts/in-root`).
    Root,
}

fn has_command(name: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {name}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Makes Monado available: the host's own packages where the distribution
/// ships them, else the Debian 13 root.
fn setup_monado() -> Result<Monado, String> {
    if has_command("monado-service") {
        return Ok(Monado::Native);
    }
    let shipped = Command::new("apt-cache")
        .args(["show", "monado-service"])
        .output()
        .is_ok_and(|o| o.status.success() && !o.stdout.is_empty());
    if shipped {
        apt_install(MONADO_PACKAGES, "Monado is not installed")?;
        return Ok(Monado::Native);
    }
    setup_root()?;
    Ok(Monado::Root)
}

fn build_release() -> Result<PathBuf, String> {
    let r = repo();
    run(cargo()
        .current_dir(&r)
        .args(["build", "--release", "--bin", "vergence"]))?;
    Ok(r.join("target/release/vergence"))
}

/// `scripts/with-monado [--remote] BIN`, inside the root when needed.
fn monado_command(how: &Monado, bin: &Path) -> Command {
    monado_command_with(how, &[], bin)
}

/// `bin` under Monado as [`monado_command`], with `with-monado`'s own
/// options (`--remote`) first.
fn monado_command_with(how: &Monado, options: &[&str], bin: &Path) -> Command {
    let r = repo();
    let mut cmd = match how {
        Monado::Native => Command::new(r.join("scripts/with-monado")),
        Monado::Root => {
            let mut c = Command::new(r.join("scripts/in-root"));
            c.arg(r.join("scripts/with-monado"));
            c.env("VERGENCE_XR_ROOT", root_dir());
            c
        }
    };
    cmd.current_dir(&r).args(options).arg(bin);
    cmd
}

fn xr(args: &[String]) -> Result<u8, String> {
    setup_host()?;
    let how = setup_monado()?;
    let bin = build_release()?;
    let mut cmd = monado_command(&how, &bin);
    cmd.args(args);
    eprintln!("xtask: running {cmd:?}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    Ok(status.code().map_or(1, |c| c.clamp(0, 255) as u8))
}

/// Whether the OpenXR loader would find an active runtime on this host.
fn host_runtime() -> Option<String> {
    if let Some(p) = std::env::var_os("XR_RUNTIME_JSON") {
        return Some(PathBuf::from(p).display().to_string());
    }
    let home = std::env::var("XDG_CONFIG_HOME")
        .ok()
        .or_else(|| std::env::var("HOME").ok().map(|h| format!("{h}/.config")));
    let dirs = std::env::var("XDG_CONFIG_DIRS").unwrap_or_else(|_| "/etc/xdg".into());
    home.into_iter()
        .chain(dirs.split(':').map(str::to_string))
        .chain(["/etc".to_string()])
        .map(|d| format!("{d}/openxr/1/active_runtime.json"))
        .find(|p| Path::new(p).exists())
}

fn demo(args: &[String]) -> Result<(), String> {
    setup_host()?;
    let r = repo();
    let out = r.join("demo-output");
    let _ = std::fs::create_dir_all(&out);
    let stats = out.join("run-stats.json");
    let capture = out.join("last-frame");
    let loader = Path::new("/usr/lib/x86_64-linux-gnu/libopenxr_loader.so.1").exists()
        || Path::new("/usr/lib/libopenxr_loader.so.1").exists();
    if let (Some(runtime), true) = (host_runtime(), loader) {
        let bin = build_release()?;
        eprintln!(
            "xtask: demo: an OpenXR runtime is active ({runtime}); running the factory scene in the headset until you press Ctrl-C"
        );
        let mut cmd = Command::new(bin);
        cmd.current_dir(&r)
            .args(["run", "--xr", "openxr", "--scene", "factory", "--stats-out"])
            .arg(&stats)
            .args(args);
        return run(&mut cmd);
    }
    // 60 frames of the factory with superfrustum culling; the last frame
    // and the statistics go to demo-output/.
    let run_args = |xr: &str| -> Vec<std::ffi::OsString> {
        let mut v: Vec<std::ffi::OsString> = [
            "run",
            "--xr",
            xr,
            "--scene",
            "factory",
            "--opt",
            "superfrustum",
            "--frames",
            "60",
            "--capture",
        ]
        .iter()
        .map(Into::into)
        .collect();
        v.push(capture.clone().into());
        v.push("--stats-out".into());
        v.push(stats.clone().into());
        v.extend(args.iter().map(Into::into));
        v
    };
    if args.first().map(String::as_str) == Some("--rehearse") {
        return demo_rehearsal(&r, &args[1..]);
    }
    match setup_monado() {
        Ok(how) => {
            let bin = build_release()?;
            eprintln!(
                "xtask: demo: no headset runtime on this machine; running under Monado's simulated HMD ({})",
                match how {
                    Monado::Native => "host packages",
                    Monado::Root => "Debian 13 root in target/xr-root",
                }
            );
            let mut cmd = monado_command(&how, &bin);
            run(cmd.args(run_args("openxr")))?;
        }
        Err(why) => {
            let bin = build_release()?;
            eprintln!("xtask: demo: Monado cannot be set up here ({why}); running headless");
            let mut cmd = Command::new(bin);
            run(cmd.current_dir(&r).args(run_args("headless")))?;
        }
    }
    eprintln!(
        "xtask: demo: the last frame is in {} (left.png, right.png, rig.json), per-frame statistics in {}",
        capture.display(),
        stats.display()
    );
    Ok(())
}

/// `cargo xtask demo --rehearse [SCRIPT]`: a scripted visit of the factory
/// (the shipped `manifests/rehearse/visit.toml` by default) played through
/// Monado's remote driver; the frame it ends on and the per-frame records
/// (its events) go to demo-output/.
fn demo_rehearsal(r: &Path, args: &[String]) -> Result<(), String> {
    let how = setup_monado().map_err(|why| format!("a rehearsal needs Monado: {why}"))?;
    let bin = build_release()?;
    let out = r.join("demo-output");
    let script = args
        .first()
        .map_or_else(|| r.join("manifests/rehearse/visit.toml"), PathBuf::from);
    let (stats, capture) = (out.join("visit-stats.json"), out.join("visit-end"));
    eprintln!(
        "xtask: demo: rehearsing {} under Monado's remote driver",
        script.display()
    );
    let mut cmd = monado_command_with(&how, &["--remote"], &bin);
    let mut all: Vec<std::ffi::OsString> = Vec::new();
    all.extend(
        [
            "run",
            "--xr",
            "openxr",
            "--scene",
            "factory:2000",
            "--spawn",
            "1,0,-1,-90",
            "--move-speed",
            "1.5",
            "--snap-turn",
            "45",
            "--mirror",
            "off",
        ]
        .iter()
        .map(Into::into),
    );
    for (flag, path) in [
        ("--rehearse", &script),
        ("--stats-out", &stats),
        ("--capture", &capture),
    ] {
        all.push(flag.into());
        all.push(path.clone().into());
    }
    run(cmd.args(all))?;
    eprintln!(
        "xtask: demo: the visit's events are in {} (frames[].events), the frame it ended on in {}",
        stats.display(),
        capture.display()
    );
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (cmd, rest) = match args.split_first() {
        Some((c, r)) => (c.as_str(), r.to_vec()),
        None => ("help", Vec::new()),
    };
    let rest: Vec<String> = rest.into_iter().filter(|a| a != "--").collect();
    let result = match cmd {
        "setup" => setup(),
        "corpus" => corpus::check(&repo()),
        "test" => test(&rest),
        "demo" => demo(&rest),
        "gpu-bench" => gpu_bench::gpu_bench(&rest),
        "xr" => match xr(&rest) {
            Ok(code) => return ExitCode::from(code),
            Err(e) => Err(e),
        },
        _ => {
            eprintln!("usage: cargo xtask <setup|demo|test|xr|gpu-bench|corpus> [-- ARGS]");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}
