//! The desktop window under Xvfb (lavapipe): `vergence view`'s presented
//! image matches a headless render of the same rig, resizing letterboxes
//! with the aspect kept, and without a display `view` fails with one line.
//! Tests that need an X server start their own Xvfb and skip, saying why,
//! only when Xvfb is not installed.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn vergence() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vergence"))
}

use common::on_path;
use common::xvfb::Xvfb;

fn load(path: &Path) -> image::RgbaImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgba8()
}

fn succeeds(cmd: &mut Command) -> String {
    let out = cmd.output().expect("vergence runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{cmd:?} failed: {stdout}\n{stderr}");
    stdout
}

/// FLIP mean of `test` against `reference` (same size).
fn flip_mean(reference: &image::RgbaImage, test: &image::RgbaImage) -> f64 {
    let f = vergence::bench::metrics::flip(reference, test, vergence::bench::metrics::DESKTOP_PPD)
        .expect("same sizes");
    f.mean as f64
}

const W: u32 = 256;
const H: u32 = 192;

fn headless_render(dir: &Path, extra: &[&str]) -> [image::RgbaImage; 2] {
    let out = dir.join("render");
    let size = [W.to_string(), H.to_string()];
    succeeds(
        vergence()
            .args(["render", "--scene", "factory:2000", "--hmd", "valve-index"])
            .args(["--width", &size[0], "--height", &size[1]])
            .args(extra)
            .arg("--out")
            .arg(&out),
    );
    [load(&out.join("left.png")), load(&out.join("right.png"))]
}

fn view(x: &Xvfb, shot: &Path, extra: &[&str]) -> Command {
    let size = [W.to_string(), H.to_string()];
    let mut cmd = vergence();
    cmd.env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .args(["view", "--scene", "factory:2000", "--hmd", "valve-index"])
        .args(["--width", &size[0], "--height", &size[1]])
        .args(extra)
        .arg("--screenshot")
        .arg(shot);
    // The overlay stays off unless a test asks for it.
    if !extra.contains(&"--overlay") {
        cmd.args(["--overlay", "off"]);
    }
    cmd
}

#[test]
fn view_presents_what_a_headless_render_of_the_same_rig_shows() {
    let Some(x) = Xvfb::start("view_presents") else {
        return;
    };
    let dir = common::scratch("window", "same-rig");
    let [left, right] = headless_render(&dir, &[]);

    // Both eyes side by side: the window is exactly twice an eye wide.
    let shot = dir.join("both.png");
    let stdout = succeeds(&mut view(&x, &shot, &["--frames", "5", "--eyes", "both"]));
    assert!(stdout.contains("viewed 5 frames"), "{stdout}");
    let img = load(&shot);
    assert_eq!(img.dimensions(), (2 * W, H), "window size");
    let half = |x0| image::imageops::crop_imm(&img, x0, 0, W, H).to_image();
    let (l, r) = (flip_mean(&left, &half(0)), flip_mean(&right, &half(W)));
    assert!(l <= 0.01 && r <= 0.01, "FLIP mean left {l}, right {r}");
    // The eyes differ, so the halves are not the same eye twice.
    assert!(flip_mean(&left, &right) > l.max(r), "left and right differ");

    // One eye: the right one fills the window.
    let shot = dir.join("right.png");
    succeeds(&mut view(&x, &shot, &["--frames", "5", "--eyes", "right"]));
    let img = load(&shot);
    assert_eq!(img.dimensions(), (W, H));
    let e = flip_mean(&right, &img);
    assert!(e <= 0.01, "FLIP mean right eye {e}");
}

/// With `--overlay on` (the default) the panel covers the window's top
/// left and the rest is the rendered eye; the eye images never get it.
#[test]
fn view_draws_the_overlay_over_the_eyes_only_where_the_panel_is() {
    let Some(x) = Xvfb::start("view_overlay") else {
        return;
    };
    let dir = common::scratch("window", "overlay");
    let [left, right] = headless_render(&dir, &[]);
    let shot = dir.join("overlay.png");
    succeeds(&mut view(
        &x,
        &shot,
        &["--frames", "5", "--eyes", "both", "--overlay", "on"],
    ));
    let img = load(&shot);
    let crop =
        |i: &image::RgbaImage, x0, y0, w, h| image::imageops::crop_imm(i, x0, y0, w, h).to_image();
    // Beyond the panel (at most 376 px wide from x = 8) the window is the
    // right eye.
    let beyond = 400 - W;
    let r = flip_mean(
        &crop(&right, beyond, 0, W - beyond, H),
        &crop(&img, 400, 0, W - beyond, H),
    );
    assert!(r <= 0.01, "right of the panel: FLIP {r}");
    // The panel's first lines differ from the left eye.
    let p = flip_mean(&crop(&left, 12, 12, 200, 40), &crop(&img, 12, 12, 200, 40));
    assert!(p > 0.1, "the overlay is drawn: FLIP {p}");
}

#[test]
fn view_in_two_pass_mode_matches_too() {
    let Some(x) = Xvfb::start("view_two_pass") else {
        return;
    };
    let dir = common::scratch("window", "two-pass");
    let opts = [
        "--stereo",
        "two-pass",
        "--msaa",
        "1",
        "--frames-in-flight",
        "3",
    ];
    let [left, _] = headless_render(&dir, &opts);
    let shot = dir.join("left.png");
    let mut cmd = view(&x, &shot, &["--frames", "7", "--eyes", "left"]);
    succeeds(cmd.args(opts));
    let e = flip_mean(&left, &load(&shot));
    assert!(e <= 0.01, "FLIP mean {e}");
}

#[test]
fn resizing_the_window_keeps_the_aspect() {
    let Some(x) = Xvfb::start("resize") else {
        return;
    };
    if !on_path("xdotool") {
        println!("skipping resize: xdotool is not installed (apt-get install xdotool)");
        return;
    }
    let dir = common::scratch("window", "resize");
    let shot = dir.join("resized.png");
    let mut child = view(&x, &shot, &["--eyes", "both"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("vergence starts");
    let xdotool = |args: &[&str]| x.xdotool(args);
    let start = Instant::now();
    let id = loop {
        let out = xdotool(&["search", "--name", "vergence view"]);
        let id = String::from_utf8_lossy(&out.stdout)
            .lines()
            .next()
            .map(str::to_string);
        if let Some(id) = id {
            break id;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no window appeared"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    // A window taller than the content's 8:3: bars above and below.
    assert!(xdotool(&["windowsize", &id, "600", "400"]).status.success());
    std::thread::sleep(Duration::from_secs(2));
    // Escape (typed through XTEST into the focused window: no window
    // manager runs) ends the session in order; sent until the process
    // ends, killed (and failed) if it never does.
    let start = Instant::now();
    while child.try_wait().expect("vergence state").is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("view did not end on Escape");
        }
        xdotool(&["windowfocus", &id]);
        xdotool(&["mousemove", "--window", &id, "100", "100"]);
        xdotool(&["key", "Escape"]);
        std::thread::sleep(Duration::from_millis(700));
    }
    let out = child.wait_with_output().expect("vergence ends");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "view exit: {stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("600x400 window"), "{stdout}");
    // Content 512x192 in 600x400: 600x225 at y = 87, black above and below.
    let img = load(&shot);
    assert_eq!(img.dimensions(), (600, 400));
    let band = |y0: u32, y1: u32| {
        let mut sum = 0u64;
        for y in y0..y1 {
            for x in 0..600 {
                let p = img.get_pixel(x, y).0;
                sum += p[0] as u64 + p[1] as u64 + p[2] as u64;
            }
        }
        sum as f64 / ((y1 - y0) * 600 * 3) as f64
    };
    assert_eq!(band(0, 86), 0.0, "black bar above");
    assert_eq!(band(313, 400), 0.0, "black bar below");
    assert!(band(90, 310) > 10.0, "the scene is in between");
}

#[test]
fn view_without_a_display_fails_with_one_line() {
    let stderr = common::fails_with_one_error(
        vergence()
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .args(["view", "--scene", "factory:10", "--frames", "1"]),
    );
    assert!(
        stderr.contains("DISPLAY") && stderr.contains("no display"),
        "{stderr}"
    );
}
