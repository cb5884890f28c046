//! The distortion preview on lavapipe, with validation: the four methods
//! agree, every panel pixel shows the eye-image point the lens model gives
//! for each colour channel, a straight line bends the way a barrel lens
//! bends it, and a profile without a lens is one error.

mod common;

use ash::vk;
use std::process::Command;
use vergence::bench::metrics::flip;
use vergence::config::{RenderConfig, StereoMode};
use vergence::render::distortion::{preview_panel, DistortionPreview, Method};
use vergence::view::distortion::{eye_uv, Lens};
use vergence::view::profile::HmdProfile;
use vergence::view::Fov;

const METHODS: [Method; 4] = [
    Method::Fragment,
    Method::Grid,
    Method::Mesh,
    Method::Compute,
];

fn lenses(p: &HmdProfile) -> ([&Lens; 2], [&Fov; 2]) {
    let l = |i: usize| p.views[i].lens.as_ref().expect("lens");
    ([l(0), l(1)], [&p.views[0].fov, &p.views[1].fov])
}

fn preview(
    ctx: &std::sync::Arc<vergence::gpu::Context>,
    p: &HmdProfile,
    eyes: &[image::RgbaImage; 2],
    method: Method,
) -> [image::RgbaImage; 2] {
    let before = ctx.validation_messages();
    let (l, f) = lenses(p);
    let extent = vk::Extent2D {
        width: eyes[0].width(),
        height: eyes[0].height(),
    };
    let mut d = DistortionPreview::new(ctx, l, f, extent, method).unwrap_or_else(|e| panic!("{e}"));
    let out = d.run(eyes, 2).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.gpu_ms.len(), 2);
    drop(d);
    common::assert_no_validation_since(ctx, before);
    out.images
}

/// Eye images whose red channel is 255·u and green 255·v (blue 128).
fn gradient(w: u32, h: u32) -> image::RgbaImage {
    image::RgbaImage::from_fn(w, h, |x, y| {
        let u = (x as f64 + 0.5) / w as f64;
        let v = (y as f64 + 0.5) / h as f64;
        image::Rgba([
            (u * 255.0).round() as u8,
            (v * 255.0).round() as u8,
            128,
            255,
        ])
    })
}

#[test]
fn the_four_methods_agree_on_a_rendered_scene() {
    let ctx = common::context();
    let scene = common::load("factory:3000");
    for name in ["vive", "rift-dk1"] {
        let p = HmdProfile::load(name).unwrap();
        let pose = common::framing_pose(&scene, &p);
        let config = RenderConfig {
            frame: vergence::config::FrameConfig {
                stereo: StereoMode::Multiview,
                msaa: 4,
                ..Default::default()
            },
            ..RenderConfig::default()
        };
        let [w, h] = p.views[0].resolution.map(|v| v / 4);
        let frame = common::render_config(&ctx, &scene, &p, pose, &config, w, h);
        let out: Vec<[image::RgbaImage; 2]> = METHODS
            .iter()
            .map(|&m| preview(&ctx, &p, &frame.images, m))
            .collect();
        // Eye images of a quarter of the profile's size: the panel is
        // drawn at no more than twice their size per axis.
        let eye = vk::Extent2D {
            width: w,
            height: h,
        };
        let panel = preview_panel(p.views[0].lens.unwrap().panel, eye);
        let (pw, ph) = (panel.width, panel.height);
        assert_eq!(out[0][0].dimensions(), (pw, ph));
        // Pixels per degree of the panel: its width over the eye's FOV.
        let fov = &p.views[0].fov;
        let ppd = (pw as f64 / (fov.right - fov.left).to_degrees())
            .max(vergence::bench::metrics::MIN_FLIP_PPD) as f32;
        let [fragment, grid, mesh, compute] = [&out[0], &out[1], &out[2], &out[3]];
        for eye in 0..2 {
            let images = [&fragment[eye], &grid[eye], &mesh[eye], &compute[eye]];
            for (a, b) in [(0, 1), (0, 2), (1, 2), (0, 3)] {
                let f = flip(images[a], images[b], ppd).unwrap();
                assert!(
                    f.mean <= 0.01,
                    "{name} eye {eye}: {:?} vs {:?}: FLIP mean {}",
                    METHODS[a],
                    METHODS[b],
                    f.mean
                );
            }
            // Not a black image: the scene is there.
            let lit = images[2].pixels().filter(|p| p.0[0] > 20).count();
            assert!(lit > (pw * ph / 10) as usize, "{name}: {lit} lit pixels");
        }
    }
}

#[test]
fn every_panel_pixel_shows_the_eye_point_the_lens_model_gives() {
    let ctx = common::context();
    for name in ["vive", "rift-dk1"] {
        let p = HmdProfile::load(name).unwrap();
        let [w, h] = p.views[0].resolution.map(|v| v / 2);
        let eyes = [gradient(w, h), gradient(w, h)];
        for method in METHODS {
            let out = preview(&ctx, &p, &eyes, method);
            for (eye, img) in out.iter().enumerate() {
                let (lens, fov) = (p.views[eye].lens.unwrap(), p.views[eye].fov);
                let [pw, ph] = lens.panel;
                let (mut checked, mut worst) = (0, 0.0f64);
                for y in (0..ph).step_by(7) {
                    for x in (0..pw).step_by(7) {
                        let uv = [(x as f64 + 0.5) / pw as f64, (y as f64 + 0.5) / ph as f64];
                        let q = lens.lens_of_panel(uv);
                        if q[0].hypot(q[1]) > 0.95 * lens.r_max {
                            continue;
                        }
                        let at = |c: usize| eye_uv(&fov, lens.tangent_of_panel(uv, c).unwrap());
                        let (red, green) = (at(0), at(1));
                        let inside = |e: [f64; 2]| e.iter().all(|v| (0.03..=0.97).contains(v));
                        if !inside(red) || !inside(green) {
                            continue;
                        }
                        let px = img.get_pixel(x, y).0;
                        let dr = (px[0] as f64 - red[0] * 255.0).abs();
                        let dg = (px[1] as f64 - green[1] * 255.0).abs();
                        worst = worst.max(dr).max(dg);
                        checked += 1;
                    }
                }
                assert!(
                    checked > 1000,
                    "{name} {method:?}: {checked} pixels checked"
                );
                assert!(
                    worst <= 3.0,
                    "{name} {method:?} eye {eye}: off by {worst} of 255"
                );
            }
        }
    }
}

#[test]
fn a_straight_line_bows_outward_on_the_panel() {
    // A vertical line in the eye image, right of the lens axis: the panel
    // point at mid-height reaching it lies farther out than the points near
    // the top and bottom (there r is larger, D(r) larger, so a smaller
    // panel offset reaches the same eye column), i.e. barrel-shaped.
    let ctx = common::context();
    let p = HmdProfile::load("vive").unwrap();
    let [w, h] = p.views[0].resolution.map(|v| v / 2);
    let line_u = 0.7;
    let img = image::RgbaImage::from_fn(w, h, |x, _| {
        let u = (x as f64 + 0.5) / w as f64;
        let on = (u - line_u).abs() < 1.5 / w as f64;
        image::Rgba(if on {
            [255, 255, 255, 255]
        } else {
            [0, 0, 0, 255]
        })
    });
    for method in METHODS {
        let out = preview(&ctx, &p, &[img.clone(), img.clone()], method);
        let lens = p.views[0].lens.unwrap();
        let [pw, ph] = lens.panel;
        let cx = lens.centre[0] * pw as f64;
        let column = |y: u32| -> f64 {
            let (mut sum, mut weight) = (0.0, 0.0);
            for x in 0..pw {
                let g = out[0].get_pixel(x, y).0[1] as f64;
                sum += g * x as f64;
                weight += g;
            }
            assert!(weight > 0.0, "{method:?}: no line in row {y}");
            sum / weight
        };
        let cy = (lens.centre[1] * ph as f64) as u32;
        let (mid, top, bottom) = (column(cy), column(cy - ph / 4), column(cy + ph / 4));
        assert!(
            mid - cx > top - cx + 5.0 && mid - cx > bottom - cx + 5.0,
            "{method:?}: columns top {top:.1} mid {mid:.1} bottom {bottom:.1} (centre {cx:.1})"
        );
    }
}

#[test]
fn render_writes_the_panel_images_and_their_gpu_time() {
    let out = common::scratch("distortion", "cli");
    let stats = common::render_cli(
        &[
            "--scene",
            "factory:200",
            "--hmd",
            "rift-dk1",
            "--width",
            "128",
            "--height",
            "160",
            "--preview",
            "distorted",
            "--distortion",
            "grid",
            "--frames",
            "3",
        ],
        &out,
    );
    assert_eq!(stats["preview"]["mode"], "distorted");
    assert_eq!(stats["preview"]["method"], "grid");
    // The 640×800 panel is more than twice the 128×160 eye image per
    // axis: the preview draws it at twice the eye image.
    assert_eq!(stats["preview"]["panel"], serde_json::json!([256, 320]));
    let left = image::open(out.join("left_distorted.png")).unwrap();
    assert_eq!((left.width(), left.height()), (256, 320));
    assert!(stats["preview"]["gpu_ms"]["median"].as_f64().unwrap() > 0.0);
}

/// A profile may declare the largest panel its parser allows; a small
/// render's preview then follows the rendered size (its cost was the
/// panel's: 2 GB of panel images for a 16×16 render), and at a render as
/// large as the panel the panel keeps its own size.
#[test]
fn the_preview_follows_the_rendered_size_not_the_declared_panel() {
    let e = |width, height| vk::Extent2D { width, height };
    assert_eq!(preview_panel([16384, 16384], e(16, 16)), e(32, 32));
    assert_eq!(preview_panel([640, 800], e(1068, 1336)), e(640, 800));
    assert_eq!(preview_panel([1440, 1600], e(2016, 2240)), e(1440, 1600));
    assert_eq!(preview_panel([16384, 8], e(16, 16)), e(32, 1));
    let dir = common::scratch("distortion", "huge-panel");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("manifests/hmd/rift-dk1.toml"),
    )
    .unwrap()
    .replace("panel = [640, 800]", "panel = [16384, 16384]");
    let profile = dir.join("huge-panel.toml");
    std::fs::write(&profile, text).unwrap();
    let out = dir.join("out");
    let t0 = std::time::Instant::now();
    let stats = common::render_cli(
        &[
            "--scene",
            "factory:50",
            "--hmd",
            profile.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "16",
            "--preview",
            "distorted",
        ],
        &out,
    );
    assert_eq!(stats["preview"]["panel"], serde_json::json!([32, 32]));
    let left = image::open(out.join("left_distorted.png")).unwrap();
    assert_eq!((left.width(), left.height()), (32, 32));
    assert!(t0.elapsed().as_secs() < 60, "{:?}", t0.elapsed());
}

#[test]
fn a_profile_without_a_lens_is_one_error_naming_it() {
    let out = common::scratch("distortion", "nolens");
    let stderr = common::fails_with_one_error(
        Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "render",
                "--scene",
                "factory:10",
                "--hmd",
                "valve-index",
                "--width",
                "32",
                "--height",
                "32",
                "--preview",
                "distorted",
                "--out",
            ])
            .arg(&out),
    );
    assert!(
        stderr.contains("valve-index") && stderr.contains("lens"),
        "{stderr}"
    );
}

#[test]
fn rdm_auto_renders_with_the_radius_the_lens_density_gives() {
    let out = common::scratch("distortion", "rdm-auto");
    let stats = common::render_cli(
        &[
            "--scene",
            "factory:200",
            "--hmd",
            "vive",
            "--width",
            "96",
            "--height",
            "106",
            "--opt",
            "rdm=auto",
        ],
        &out,
    );
    let r = stats["config"]["rdm"].as_f64().unwrap();
    assert!((0.6..0.9).contains(&r), "{r}");
    assert_eq!(stats["config"]["rdm_auto"], false);
}

#[test]
fn foveation_auto_resolves_the_ring_the_lens_density_gives() {
    // lavapipe has no shading-rate attachment: the frame renders without
    // foveation, and the warning names the level that was asked for.
    let out = common::scratch("distortion", "foveation-auto");
    let o = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "render",
            "--scene",
            "factory:200",
            "--hmd",
            "rift-dk1",
            "--width",
            "96",
            "--height",
            "120",
            "--opt",
            "foveation=auto",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let r: u32 = stderr
        .split("foveation Lens(")
        .nth(1)
        .and_then(|t| t.split(')').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no resolved level in: {stderr}"));
    assert!((300..1500).contains(&r), "{r}");
}
