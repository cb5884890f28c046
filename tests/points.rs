//! Point clouds on lavapipe (64-bit buffer atomics: yes): the compute
//! rasterizer puts every point in its pixel (against a CPU rasterizer with
//! the renderer's own matrices); points and meshes composite by depth;
//! multiview equals two-pass; LAS and LAZ round trips; stats; bad files are
//! one error each. Zero validation messages (`render_config` checks).

mod common;

use common::{context, fails_with_one_error, load, render_config, scratch};
use glam::DVec3;
use std::sync::Arc;
use vergence::config::{RenderConfig, StereoMode};
use vergence::interact::scan::{scan, ScanSettings};
use vergence::scene::points::{read_las, write_las, PointCloud};
use vergence::view::profile::HmdProfile;
use vergence::view::Pose;

const W: u32 = 160;
const H: u32 = 144;

/// A cloud of `n` points scattered over a box in front of a head at the
/// origin looking down −z, with distinct colours.
fn scattered(n: usize, centre: DVec3) -> PointCloud {
    let mut rng = vergence::scene::factory::SplitMix64::new(9);
    let mut c = PointCloud {
        origin: centre,
        ..PointCloud::default()
    };
    for i in 0..n {
        let p = [
            (rng.unit() * 8.0 - 4.0) as f32,
            (rng.unit() * 6.0 - 3.0) as f32,
            (rng.unit() * 6.0 - 3.0) as f32,
        ];
        c.positions.push(p);
        c.colors
            .push([(i % 251) as u8, (i / 251 % 251) as u8, 200, 255]);
        c.classification.push(1);
    }
    c
}

/// A laser scan of `scene` from `stations` stations of `rays` rays each.
fn scan_of(scene: &vergence::scene::Scene, stations: u32, rays: u32) -> PointCloud {
    scan(
        scene,
        &ScanSettings {
            stations,
            rays_per_station: rays,
            ..ScanSettings::default()
        },
    )
}

/// `vergence render` of the point file `file` counts `total` points and
/// draws some.
fn renders_all(file: &std::path::Path, total: usize, out: &std::path::Path) {
    let stats = common::render_cli(
        &[
            "--scene",
            file.to_str().unwrap(),
            "--width",
            "96",
            "--height",
            "96",
        ],
        out,
    );
    assert_eq!(stats["points_total"], total as u64);
    assert!(stats["points_drawn"].as_u64().unwrap() > 0);
}

fn head() -> Pose {
    Pose::default()
}

fn points_scene(cloud: PointCloud) -> vergence::scene::Scene {
    vergence::scene::Scene::of_points(cloud)
}

fn config(stereo: StereoMode) -> RenderConfig {
    RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        ..RenderConfig::default()
    }
}

/// The CPU rasterizer: every point projected with the frame's f32
/// matrices, each pixel keeping the nearest (largest reverse-Z depth), as
/// (depth, sRGB colour) per pixel (None: empty).
fn cpu_keys(
    cloud: &PointCloud,
    rig: &vergence::view::StereoRig,
    eye: usize,
) -> Vec<Option<(f32, [u8; 3])>> {
    let u = vergence::render::uniforms::FrameUniforms::new(
        rig,
        RenderConfig::default().frame.near,
        [None, None],
        RenderConfig::default().frame.near,
    );
    let d = cloud.origin - rig.head.position;
    let offset = glam::Vec3::new(d.x as f32, d.y as f32, d.z as f32);
    let mut best: Vec<Option<(f32, [u8; 3])>> = vec![None; (W * H) as usize];
    for (p, c) in cloud.positions.iter().zip(&cloud.colors) {
        let rel = offset + glam::Vec3::from_array(*p);
        let clip = u.view_proj[eye] * rel.extend(1.0);
        if clip.w <= 0.0 {
            continue;
        }
        let n = clip.truncate() / clip.w;
        if n.x.abs() >= 1.0 || n.y.abs() >= 1.0 || n.z <= 0.0 || n.z > 1.0 {
            continue;
        }
        let x = (((n.x * 0.5 + 0.5) * W as f32) as u32).min(W - 1);
        let y = (((n.y * 0.5 + 0.5) * H as f32) as u32).min(H - 1);
        let slot = &mut best[(y * W + x) as usize];
        if slot.is_none_or(|(z, _)| n.z > z) {
            *slot = Some((n.z, [c[0], c[1], c[2]]));
        }
    }
    best
}

/// [`cpu_keys`]' colours alone.
fn cpu_raster(
    cloud: &PointCloud,
    rig: &vergence::view::StereoRig,
    eye: usize,
) -> Vec<Option<[u8; 3]>> {
    cpu_keys(cloud, rig, eye)
        .into_iter()
        .map(|k| k.map(|(_, c)| c))
        .collect()
}

#[test]
fn every_point_lands_in_its_pixel_and_the_stereo_modes_agree() {
    let ctx = context();
    let cloud = scattered(3000, DVec3::new(1e6, 20.0, -1e6 - 9.0));
    let profile = HmdProfile::load("valve-index").unwrap();
    // A head near survey coordinates, 9 m from the cloud's centre.
    let pose = Pose {
        position: DVec3::new(1e6, 20.0, -1e6),
        ..head()
    };
    let scene = points_scene(cloud.clone());
    let mv = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::Multiview),
        W,
        H,
    );
    let rig = profile.rig(pose);
    for eye in 0..2 {
        let want = cpu_raster(&cloud, &rig, eye);
        let (mut keyed, mut same) = (0, 0);
        for (i, w) in want.iter().enumerate() {
            let Some(c) = w else { continue };
            keyed += 1;
            let p = mv.images[eye].get_pixel(i as u32 % W, i as u32 / W);
            same += usize::from((0..3).all(|k| p[k] == c[k]));
        }
        assert!(keyed > 1000, "eye {eye}: {keyed} pixels with points");
        // Pixel-exact but for points on a pixel edge, where the GPU's and
        // the CPU's last float bits may disagree.
        assert!(
            same * 1000 >= keyed * 995,
            "eye {eye}: {same} of {keyed} point pixels as the CPU rasterizer has them"
        );
    }
    let points_total = 3000;
    assert_eq!(
        mv.stats.points_drawn.map(|d| d <= 2 * points_total),
        Some(true)
    );
    assert!(mv.stats.gpu_ms.contains_key("points-raster"));
    let tp = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::TwoPass),
        W,
        H,
    );
    for eye in 0..2 {
        assert_eq!(
            common::pixels_differing(&mv.images[eye], &tp.images[eye]),
            0,
            "eye {eye}: two-pass draws the multiview image"
        );
    }
    assert_eq!(mv.stats.points_drawn, tp.stats.points_drawn);
}

/// Eye-dome lighting's shade of each keyed pixel as the composite computes
/// it, from the CPU rasterizer's keys: exp(−300 S · mean over the 8
/// neighbours of max(0, log2 d_n − log2 d)), d the reverse-Z depth
/// (None: no point there).
fn cpu_edl(keys: &[Option<(f32, [u8; 3])>], strength: f64) -> Vec<Option<f64>> {
    (0..keys.len())
        .map(|i| {
            let (d, _) = keys[i]?;
            let (x, y) = ((i as u32 % W) as i64, (i as u32 / W) as i64);
            let mut sum = 0.0f64;
            for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
                let (qx, qy) = (x + dx, y + dy);
                if (dx, dy) == (0, 0) || qx < 0 || qy < 0 || qx >= W as i64 || qy >= H as i64 {
                    continue;
                }
                if let Some((dn, _)) = keys[(qy * W as i64 + qx) as usize] {
                    sum += (dn.log2() as f64 - d.log2() as f64).max(0.0);
                }
            }
            Some((-300.0 * strength * sum / 8.0).exp())
        })
        .collect()
}

/// `edl`: every point pixel takes the shade a CPU form of the composite
/// computes from the CPU rasterizer's depths (within 2 levels but for the
/// pixels near a point on a pixel edge); pixels with no nearer neighbour
/// keep their colour; behind nearer points they darken; multiview equals
/// two-pass; `edl` with the point-list fallback is one error.
#[test]
fn eye_dome_lighting_shades_points_behind_nearer_ones() {
    let ctx = context();
    let cloud = scattered(3000, DVec3::new(0.0, 0.0, -9.0));
    let profile = HmdProfile::load("valve-index").unwrap();
    let scene = points_scene(cloud.clone());
    let strength = 0.4;
    let lit_config = |stereo| {
        let mut rc = config(stereo);
        rc.points.edl = Some(strength);
        rc
    };
    let plain = render_config(
        &ctx,
        &scene,
        &profile,
        head(),
        &config(StereoMode::Multiview),
        W,
        H,
    );
    let lit = render_config(
        &ctx,
        &scene,
        &profile,
        head(),
        &lit_config(StereoMode::Multiview),
        W,
        H,
    );
    let rig = profile.rig(head());
    for eye in 0..2 {
        let keys = cpu_keys(&cloud, &rig, eye);
        let shades = cpu_edl(&keys, strength);
        let (mut keyed, mut close, mut dark, mut darker, mut flat, mut kept) = (0, 0, 0, 0, 0, 0);
        for (i, (k, shade)) in keys.iter().zip(&shades).enumerate() {
            let (Some((_, c)), Some(shade)) = (k, shade) else {
                continue;
            };
            keyed += 1;
            let (x, y) = (i as u32 % W, i as u32 / W);
            let got = lit.images[eye].get_pixel(x, y);
            let was = plain.images[eye].get_pixel(x, y);
            let want = c.map(|v| common::linear_to_srgb(common::srgb_to_linear(v) * shade));
            close += usize::from((0..3).all(|j| (got[j] as f64 - want[j]).abs() <= 2.0));
            if *shade < 0.8 {
                dark += 1;
                darker += usize::from(
                    (0..3).map(|j| got[j] as u32).sum::<u32>()
                        < (0..3).map(|j| was[j] as u32).sum::<u32>(),
                );
            }
            if *shade == 1.0 {
                flat += 1;
                kept += usize::from(got == was);
            }
        }
        assert!(keyed > 1000, "eye {eye}: {keyed} point pixels");
        assert!(
            close * 100 >= keyed * 97,
            "eye {eye}: {close} of {keyed} point pixels take the CPU form's shade"
        );
        assert!(
            dark * 10 >= keyed,
            "eye {eye}: only {dark} of {keyed} pixels lie behind nearer points"
        );
        assert!(
            darker * 100 >= dark * 97,
            "eye {eye}: {darker} of {dark} shaded pixels darkened"
        );
        assert!(
            flat > 100 && kept * 100 >= flat * 97,
            "eye {eye}: {kept} of {flat} unshaded pixels kept"
        );
    }
    let tp = render_config(
        &ctx,
        &scene,
        &profile,
        head(),
        &lit_config(StereoMode::TwoPass),
        W,
        H,
    );
    for eye in 0..2 {
        assert_eq!(
            common::pixels_differing(&lit.images[eye], &tp.images[eye]),
            0,
            "eye {eye}: two-pass lights the multiview image"
        );
    }
    let mut both = lit_config(StereoMode::Multiview);
    both.points.points_pipeline = true;
    let err = both.validate().unwrap_err().to_string();
    assert!(err.contains("points-pipeline"), "{err}");
}

#[test]
fn points_and_meshes_composite_by_depth() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let mut scene = load("factory:300");
    let (lo, hi) = scene.bounds();
    let pose = common::framing_pose(&scene, &profile);
    // One sample per pixel: a mesh edge's pixel is the mesh's or the
    // wall's, not a blend of both.
    let one = {
        let mut rc = config(StereoMode::Multiview);
        rc.frame.msaa = 1;
        rc
    };
    let plain = render_config(&ctx, &scene, &profile, pose, &one, W, H);
    // A dense wall of pure red points across the view: first between the
    // head and the factory, then far behind it.
    let forward = pose.orientation * DVec3::NEG_Z;
    let wall = |distance: f64| {
        let mut c = PointCloud {
            origin: pose.position + forward * distance,
            ..PointCloud::default()
        };
        let right = pose.orientation * DVec3::X;
        let up = pose.orientation * DVec3::Y;
        let half = distance * 2.0;
        for i in 0..400 {
            for j in 0..400 {
                let v =
                    right * (i as f64 / 200.0 - 1.0) * half + up * (j as f64 / 200.0 - 1.0) * half;
                c.positions.push([v.x as f32, v.y as f32, v.z as f32]);
                c.colors.push([255, 0, 0, 255]);
                c.classification.push(1);
            }
        }
        c
    };
    let near_d = 1.0;
    scene.points = Some(Arc::new(wall(near_d)));
    let front = render_config(&ctx, &scene, &profile, pose, &one, W, H);
    let far_d = 4.0 * (hi - lo).length();
    scene.points = Some(Arc::new(wall(far_d)));
    let behind = render_config(&ctx, &scene, &profile, pose, &one, W, H);
    let red = |p: &image::Rgba<u8>| p[0] == 255 && p[1] == 0 && p[2] == 0;
    let n = (W * H) as usize;
    let front_red = front.images[0].pixels().filter(|p| red(p)).count();
    assert!(
        front_red * 10 >= n * 9,
        "the near wall covers the view: {front_red} of {n}"
    );
    // Behind the factory: the factory's pixels are the plain render's; the
    // wall shows only where the plain render had sky.
    let mut mesh_kept = (0, 0);
    for (p, q) in behind.images[0].pixels().zip(plain.images[0].pixels()) {
        if red(p) {
            continue;
        }
        mesh_kept.0 += 1;
        mesh_kept.1 += usize::from(p == q);
    }
    assert!(
        mesh_kept.0 > n / 50,
        "the factory shows in front of the far wall: {} of {n}",
        mesh_kept.0
    );
    assert_eq!(
        mesh_kept.0, mesh_kept.1,
        "pixels the far wall does not take are the plain render's"
    );
    let behind_red = behind.images[0].pixels().filter(|p| red(p)).count();
    assert!(
        behind_red > 0 && behind_red < front_red,
        "{behind_red} vs {front_red}"
    );
}

#[test]
fn las_and_laz_round_trip_the_same_points() {
    let scene = load("factory:200");
    let cloud = scan_of(&scene, 2, 20_000);
    assert!(cloud.len() > 10_000);
    let dir = scratch("points", "roundtrip");
    let (las, laz) = (dir.join("scan.las"), dir.join("scan.laz"));
    write_las(&las, &cloud, 0.0005).unwrap();
    write_las(&laz, &cloud, 0.0005).unwrap();
    assert!(std::fs::metadata(&laz).unwrap().len() < std::fs::metadata(&las).unwrap().len());
    let a = read_las(&las).unwrap();
    let b = read_las(&laz).unwrap();
    assert_eq!(a.len(), cloud.len());
    // LAZ is lossless over LAS's integer records: the same cloud.
    assert_eq!(a.origin, b.origin);
    let differ = |x: &[[f32; 3]], y: &[[f32; 3]]| x.iter().zip(y).filter(|(p, q)| p != q).count();
    assert_eq!(differ(&a.positions, &b.positions), 0, "positions");
    assert!(a.colors == b.colors, "colours");
    assert!(a.classification == b.classification, "classification");
    // Within the file's quantum (0.5 mm, rounding: 0.25 mm) of the scan.
    for i in (0..cloud.len()).step_by(37) {
        let e = (a.world(i) - cloud.world(i)).abs().max_element();
        assert!(e <= 0.00026, "point {i} moved {e} m");
        assert_eq!(a.colors[i][..3], cloud.colors[i][..3]);
    }
    // Written again and read back: bit for bit.
    let again = dir.join("again.las");
    write_las(&again, &a, 0.0005).unwrap();
    let c = read_las(&again).unwrap();
    assert_eq!(a.origin, c.origin);
    assert_eq!(
        differ(&a.positions, &c.positions),
        0,
        "positions written again"
    );
    assert!(a.colors == c.colors, "colours written again");
}

/// E57 as vergence writes it (`write_e57`, `scan --out X.e57`): the
/// scan's world positions read back within a micrometre (doubles), colours
/// and intensity bytes exactly; written again and read back, bit for bit; a
/// point that is not finite is one error naming it.
#[test]
fn e57_round_trips_a_scan() {
    use vergence::scene::e57::{read_e57, write_e57};
    let scene = load("factory:200");
    let cloud = scan_of(&scene, 2, 20_000);
    assert!(cloud.len() > 10_000);
    let dir = scratch("points", "e57-roundtrip");
    let path = dir.join("scan.e57");
    write_e57(&path, &cloud).unwrap();
    let a = read_e57(&path).unwrap();
    assert_eq!(a.len(), cloud.len());
    for i in 0..cloud.len() {
        let e = (a.world(i) - cloud.world(i)).abs().max_element();
        assert!(e < 1e-6, "point {i} moved {e} m");
    }
    assert!(a.colors == cloud.colors, "colours and intensity bytes");
    let again = dir.join("again.e57");
    write_e57(&again, &a).unwrap();
    let b = read_e57(&again).unwrap();
    assert_eq!(a.origin, b.origin);
    assert!(a.positions == b.positions, "positions written again");
    assert!(a.colors == b.colors, "colours written again");

    let mut broken = scattered(3, DVec3::new(100.0, 0.0, 0.0));
    broken.positions[1][2] = f32::NAN;
    let nan = dir.join("nan.e57");
    write_e57(&nan, &broken).unwrap();
    let err = read_e57(&nan).unwrap_err().to_string();
    assert!(
        err.contains("nan.e57") && err.contains("point 1 at"),
        "{err}"
    );
    assert!(err.contains("not finite"), "{err}");

    // The command line writes E57 by the extension.
    let out = dir.join("cli.e57");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["scan", "--scene", "factory:100", "--stations", "1"])
        .args(["--rays", "5000", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    assert!(read_e57(&out).unwrap().len() > 1000);
}

#[test]
fn scan_writes_a_cloud_that_render_draws_and_counts() {
    let dir = scratch("points", "cli");
    let out = dir.join("scan.laz");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "scan",
            "--scene",
            "factory:300",
            "--stations",
            "2",
            "--rays",
            "30000",
            "--out",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let total = read_las(&out).unwrap().len() as u64;
    let stats = common::render_cli(
        &[
            "--scene",
            out.to_str().unwrap(),
            "--width",
            "160",
            "--height",
            "144",
        ],
        &dir.join("render"),
    );
    assert_eq!(stats["points_total"], total);
    let drawn = stats["points_drawn"].as_u64().unwrap();
    assert!(drawn > 0 && drawn <= 2 * total, "{drawn} of 2 × {total}");
    assert_eq!(stats["validation_messages"], 0);
    assert_eq!(stats["points_octree"]["cache"]["not_used"], "no cache file");

    // The octree cache: `inspect --write-octree` writes it, a render reads
    // it and draws the same image; a stale cache is rebuilt, not an error.
    let inspect = |extra: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
            .arg("inspect")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success());
        String::from_utf8(o.stdout).unwrap()
    };
    assert!(inspect(&["--write-octree"]).contains("octree cache written to"));
    let cache = dir.join("scan.laz.octree");
    assert!(cache.is_file());
    assert!(inspect(&[]).contains("read from"));
    let args = [
        "--scene",
        out.to_str().unwrap(),
        "--width",
        "160",
        "--height",
        "144",
    ];
    let cached = common::render_cli(&args, &dir.join("render-cached"));
    assert_eq!(
        cached["points_octree"]["nodes"],
        stats["points_octree"]["nodes"]
    );
    assert!(
        cached["points_octree"]["cache"]["read"].is_string(),
        "{cached}"
    );
    assert_eq!(cached["points_drawn"], stats["points_drawn"]);
    let pngs = |d: &str| -> Vec<Vec<u8>> {
        let mut names: Vec<_> = std::fs::read_dir(dir.join(d))
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|e| e == "png"))
            .collect();
        names.sort();
        assert!(!names.is_empty());
        names.iter().map(|p| std::fs::read(p).unwrap()).collect()
    };
    assert_eq!(pngs("render"), pngs("render-cached"));
    // Cut short: a warning, the octree built again.
    let bytes = std::fs::read(&cache).unwrap();
    std::fs::write(&cache, &bytes[..bytes.len() / 2]).unwrap();
    let stale = common::render_cli(&args, &dir.join("render-stale"));
    assert!(
        stale["points_octree"]["cache"]["not_used"]
            .as_str()
            .is_some_and(|w| w.contains("bytes for")),
        "{stale}"
    );
}

/// Bytes of a valid LAS 1.4 file of a few points, for the bad-file cases.
fn valid_las(dir: &std::path::Path) -> Vec<u8> {
    let path = dir.join("valid.las");
    write_las(&path, &scattered(50, DVec3::new(10.0, 0.0, 0.0)), 0.001).unwrap();
    std::fs::read(path).unwrap()
}

#[test]
fn bad_point_files_are_one_error_each() {
    let dir = scratch("points", "bad");
    let good = valid_las(&dir);
    let put = |bytes: &[u8], at: usize, value: &[u8]| {
        let mut b = bytes.to_vec();
        b[at..at + value.len()].copy_from_slice(value);
        b
    };
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("truncated", good[..good.len() - 40].to_vec(), "points"),
        // LAS 1.4: the legacy count (u32 at 107) and the count (u64 at 247).
        (
            "count-lies",
            put(
                &put(&good, 107, &5000u32.to_le_bytes()),
                247,
                &5000u64.to_le_bytes(),
            ),
            "5000",
        ),
        ("unknown-format", put(&good, 104, &[42]), ""),
        (
            "nan-scale",
            put(&good, 131, &f64::NAN.to_le_bytes()),
            "scale",
        ),
        (
            "huge-extent",
            put(&good, 179, &1e12f64.to_le_bytes()),
            "1000000000",
        ),
        ("not-las", b"PLY nonsense".to_vec(), ""),
    ];
    for (name, bytes, says) in cases {
        let path = dir.join(format!("{name}.las"));
        std::fs::write(&path, &bytes).unwrap();
        let err = fails_with_one_error(
            std::process::Command::new(env!("CARGO_BIN_EXE_vergence")).args([
                "render",
                "--scene",
                path.to_str().unwrap(),
                "--out",
                dir.join("out").to_str().unwrap(),
            ]),
        );
        assert!(
            err.contains(&format!("{name}.las")) && err.contains(says),
            "{name}: {err}"
        );
    }
}

/// With a budget over every point the octree's nodes draw the cloud's own
/// image (the atomic max does not depend on the order); with a budget, no
/// more than it is chosen and drawn, and the image keeps the nearest
/// detail first.
#[test]
fn the_octree_draws_the_whole_cloud_or_keeps_the_budget() {
    let ctx = context();
    let scene = load("factory:300");
    let cloud = scan_of(&scene, 2, 60_000).with_octree();
    assert!(cloud.octree.as_ref().unwrap().nodes.len() > 1);
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = common::framing_pose(&scene, &profile);
    let mut whole = cloud.clone();
    whole.octree = None;
    let plain = render_config(
        &ctx,
        &points_scene(whole),
        &profile,
        pose,
        &config(StereoMode::Multiview),
        W,
        H,
    );
    let lod_scene = points_scene(cloud.clone());
    let unlimited = {
        let mut rc = config(StereoMode::Multiview);
        rc.points.points_budget = vergence::scene::points::MAX_POINTS;
        rc
    };
    let all = render_config(&ctx, &lod_scene, &profile, pose, &unlimited, W, H);
    for eye in 0..2 {
        assert_eq!(
            common::pixels_differing(&plain.images[eye], &all.images[eye]),
            0,
            "eye {eye}"
        );
    }
    assert_eq!(all.stats.points_drawn, plain.stats.points_drawn);
    let budget = cloud.len() as u64 / 5;
    let limited = {
        let mut rc = config(StereoMode::Multiview);
        rc.points.points_budget = budget;
        rc
    };
    let some = render_config(&ctx, &lod_scene, &profile, pose, &limited, W, H);
    let chosen = some.stats.points_selected.unwrap();
    assert!(
        chosen <= budget && chosen > budget / 4,
        "{chosen} of {budget}"
    );
    assert!(some.stats.points_drawn.unwrap() <= 2 * chosen);
    assert!(
        common::pixels_differing(&some.images[0], &all.images[0]) > 0,
        "a fifth of the points draws less"
    );
}

/// A cloud spread over several point buffers (as past maxStorageBufferRange:
/// 268 M points on the H200; here forced small) draws the same image.
#[test]
fn a_cloud_over_several_buffers_draws_the_same_image() {
    let dir = scratch("points", "buffers");
    let scan_out = dir.join("scan.las");
    let scene = load("factory:200");
    let cloud = scan_of(&scene, 1, 30_000);
    write_las(&scan_out, &cloud, 0.001).unwrap();
    let render = |per: Option<&str>, out: &str| {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"));
        cmd.args([
            "render",
            "--scene",
            scan_out.to_str().unwrap(),
            "--width",
            "160",
            "--height",
            "144",
            "--out",
        ])
        .arg(dir.join(out));
        if let Some(p) = per {
            cmd.env("VERGENCE_POINTS_PER_BUFFER", p);
        }
        assert!(cmd.status().unwrap().success());
        image::open(dir.join(out).join("left.png"))
            .unwrap()
            .to_rgba8()
    };
    let one = render(None, "one");
    // Five buffers: four full, the last partly.
    let per = (cloud.len().div_ceil(5) + 1).to_string();
    let five = render(Some(&per), "five");
    assert_eq!(common::pixels_differing(&one, &five), 0);
    let edge = std::fs::read_to_string(dir.join("five/stats.json")).unwrap();
    assert!(edge.contains("\"validation_messages\": 0"));
}

/// Inside the cloud, along the bench's walk path, the octree with an
/// unlimited budget draws what every point draws.
#[test]
fn inside_the_cloud_the_octree_draws_every_visible_point() {
    let ctx = context();
    let scene = load("factory:300");
    let cloud = scan_of(&scene, 2, 60_000).with_octree();
    let (lo, hi) = cloud.bounds();
    let profile = HmdProfile::load("valve-index").unwrap();
    let mut whole = cloud.clone();
    whole.octree = None;
    let (whole, lod) = (points_scene(whole), points_scene(cloud));
    let unlimited = {
        let mut rc = config(StereoMode::Multiview);
        rc.points.points_budget = vergence::scene::points::MAX_POINTS;
        rc
    };
    for f in [0u64, 200, 400] {
        let pose = vergence::bench::cull::head_path(f, 1, lo, hi);
        let a = render_config(
            &ctx,
            &whole,
            &profile,
            pose,
            &config(StereoMode::Multiview),
            W,
            H,
        );
        let b = render_config(&ctx, &lod, &profile, pose, &unlimited, W, H);
        assert!(
            a.stats.points_drawn.unwrap() > 0,
            "frame {f}: nothing in view"
        );
        assert_eq!(a.stats.points_drawn, b.stats.points_drawn, "frame {f}");
        for eye in 0..2 {
            assert_eq!(
                common::pixels_differing(&a.images[eye], &b.images[eye]),
                0,
                "frame {f} eye {eye}"
            );
        }
    }
}

/// PLY clouds, ASCII and binary, read as the same points, colours and
/// classes; z up turns to y up; the cloud renders.
#[test]
fn ply_ascii_and_binary_read_the_same_points() {
    let dir = scratch("points", "ply");
    let pts: Vec<([f64; 3], [u8; 3], u8)> = (0..200)
        .map(|i| {
            let f = i as f64;
            (
                [1000.0 + f * 0.01, 2000.0 - f * 0.02, 5.0 + (f * 0.1).sin()],
                [i as u8, 255 - i as u8, 7],
                (i % 5) as u8,
            )
        })
        .collect();
    let mut ascii = String::from("ply\nformat ascii 1.0\ncomment vergence test\n");
    ascii += &format!("element vertex {}\n", pts.len());
    ascii += "property double x\nproperty double y\nproperty double z\n";
    ascii += "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar classification\n";
    ascii += "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    for (p, c, k) in &pts {
        ascii += &format!(
            "{} {} {} {} {} {} {}\n",
            p[0], p[1], p[2], c[0], c[1], c[2], k
        );
    }
    ascii += "3 0 1 2\n";
    let mut binary = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar classification\nend_header\n",
        pts.len()
    )
    .into_bytes();
    for (p, c, k) in &pts {
        for v in p {
            binary.extend(v.to_le_bytes());
        }
        binary.extend([c[0], c[1], c[2], *k]);
    }
    let (a_path, b_path) = (dir.join("a.ply"), dir.join("b.ply"));
    std::fs::write(&a_path, ascii).unwrap();
    std::fs::write(&b_path, binary).unwrap();
    let a = vergence::scene::point_files::read_file(&a_path).unwrap();
    let b = vergence::scene::point_files::read_file(&b_path).unwrap();
    assert_eq!(a.len(), pts.len());
    assert_eq!(
        (a.origin, &a.colors, &a.classification),
        (b.origin, &b.colors, &b.classification)
    );
    for (i, (p, c, k)) in pts.iter().enumerate() {
        let w = a.world(i);
        // z up in the file: (x, y, z) → (x, z, −y).
        let want = DVec3::new(p[0], p[2], -p[1]);
        assert!(
            (w - want).abs().max_element() < 1e-4,
            "point {i}: {w:?} vs {want:?}"
        );
        assert_eq!(a.colors[i][..3], c[..]);
        assert_eq!(a.classification[i], *k);
        assert!((b.world(i) - w).abs().max_element() < 1e-9);
    }
    renders_all(&a_path, pts.len(), &dir.join("render"));
}

/// A big-endian PLY whose first element is not the vertices (faces with
/// index lists, read past record by record) and whose intensity runs past
/// 255: every point, its grey (intensity scaled to the file's largest)
/// and the faces after it are read.
#[test]
fn ply_big_endian_with_elements_around_the_vertices() {
    let dir = scratch("points", "ply-be");
    let n = 50u32;
    let mut file = format!(
        "ply\nformat binary_big_endian 1.0\nelement face 2\nproperty list uchar int vertex_indices\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nproperty ushort intensity\nelement edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
    )
    .into_bytes();
    for face in [[0i32, 1, 2], [2, 3, 4]] {
        file.push(3);
        for v in face {
            file.extend(v.to_be_bytes());
        }
    }
    for i in 0..n {
        for v in [i as f32, -2.0 * i as f32, 0.5] {
            file.extend(v.to_be_bytes());
        }
        file.extend(((i * 20) as u16).to_be_bytes());
    }
    file.extend(0i32.to_be_bytes());
    file.extend(1i32.to_be_bytes());
    let path = dir.join("be.ply");
    std::fs::write(&path, &file).unwrap();
    let c = vergence::scene::point_files::read_file(&path).unwrap();
    assert_eq!(c.len(), n as usize);
    let top = ((n - 1) * 20) as f64;
    for i in 0..n as usize {
        let want = DVec3::new(i as f64, 0.5, 2.0 * i as f64);
        assert!(
            (c.world(i) - want).abs().max_element() < 1e-5,
            "point {i}: {:?}",
            c.world(i)
        );
        let grey = ((i * 20) as f64 * (255.0 / top)) as u8;
        assert_eq!(c.colors[i], [grey, grey, grey, grey], "point {i}");
    }
    // Cut inside the edge element after the vertices: still an error.
    std::fs::write(&path, &file[..file.len() - 2]).unwrap();
    let e = vergence::scene::point_files::read_file(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("'edge' data"), "{e}");
}

/// `point-size=PX`: a near point covers PX × PX pixels around its own, a
/// far one shrinks to a pixel; every pixel a one-pixel point keys is still
/// a point's.
#[test]
fn point_size_grows_near_points_and_keeps_far_ones_single() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = head();
    let forward = DVec3::NEG_Z;
    // Three red points 1 m ahead (full size) and three blue ones 40 m ahead
    // (one pixel: 5 × 2 m / 40 m < 1).
    let mut c = PointCloud {
        origin: pose.position,
        ..PointCloud::default()
    };
    for (i, (d, rgb)) in [(1.0, [255, 0, 0]), (40.0, [0, 0, 255])].iter().enumerate() {
        for k in 0..3 {
            let p = forward * *d
                + DVec3::X * (k as f64 - 1.0) * 0.1 * d
                + DVec3::Y * 0.05 * i as f64 * d;
            c.positions.push([p.x as f32, p.y as f32, p.z as f32]);
            c.colors.push([rgb[0], rgb[1], rgb[2], 255]);
            c.classification.push(1);
        }
    }
    let scene = points_scene(c);
    let sized = |px: f64| {
        let mut rc = config(StereoMode::Multiview);
        rc.points.point_size = px;
        rc.frame.msaa = 1;
        rc
    };
    let one = render_config(&ctx, &scene, &profile, pose, &sized(1.0), W, H);
    let five = render_config(&ctx, &scene, &profile, pose, &sized(5.0), W, H);
    let count = |img: &image::RgbaImage, rgb: [u8; 3]| {
        img.pixels()
            .filter(|p| p[0] == rgb[0] && p[1] == rgb[1] && p[2] == rgb[2])
            .count()
    };
    for eye in 0..2 {
        assert_eq!(
            count(&one.images[eye], [255, 0, 0]),
            3,
            "eye {eye}: one pixel each"
        );
        assert_eq!(
            count(&five.images[eye], [255, 0, 0]),
            3 * 25,
            "eye {eye}: 5 × 5 each"
        );
        assert_eq!(count(&one.images[eye], [0, 0, 255]), 3);
        assert_eq!(
            count(&five.images[eye], [0, 0, 255]),
            3,
            "eye {eye}: far points stay single pixels"
        );
        for (p, q) in one.images[eye].pixels().zip(five.images[eye].pixels()) {
            if p[0] == 255 && p[1] == 0 {
                assert_eq!(p, q);
            }
        }
    }
}

/// The point-list fallback (what a device without 64-bit atomics runs;
/// forced here with `points-pipeline`) draws the compute rasterizer's
/// image within FLIP 0.01, with meshes, at 1× and 4× MSAA, in both stereo
/// modes; stats say which path ran.
#[test]
fn the_point_list_fallback_matches_the_compute_path() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let mut scene = load("factory:300");
    let cloud = scan_of(&scene, 2, 40_000).with_octree();
    // The scan moved 20 cm up, so points and meshes interleave by depth.
    let mut lifted = cloud.clone();
    lifted.origin += DVec3::Y * 0.2;
    scene.points = Some(Arc::new(lifted));
    let pose = common::framing_pose(&scene, &profile);
    for (stereo, msaa) in [
        (StereoMode::Multiview, 1),
        (StereoMode::Multiview, 4),
        (StereoMode::TwoPass, 4),
    ] {
        let base = {
            let mut rc = config(stereo);
            rc.frame.msaa = msaa;
            rc
        };
        let compute = render_config(&ctx, &scene, &profile, pose, &base, W, H);
        let list = {
            let mut rc = base.clone();
            rc.points.points_pipeline = true;
            rc
        };
        let fallback = render_config(&ctx, &scene, &profile, pose, &list, W, H);
        for eye in 0..2 {
            let f =
                vergence::bench::metrics::flip(&compute.images[eye], &fallback.images[eye], 30.0)
                    .unwrap();
            assert!(
                f.mean <= 0.01,
                "{stereo:?} {msaa}x eye {eye}: FLIP {}",
                f.mean
            );
        }
        eprintln!(
            "{stereo:?} {msaa}x: {} pixels differ",
            common::pixels_differing(&compute.images[0], &fallback.images[0])
        );
        assert_eq!(
            fallback.stats.points_selected,
            compute.stats.points_selected
        );
    }
}

/// E57: a file written with the `e57` crate (two scans, Cartesian
/// coordinates and 8-bit colour) reads back as the same points, z up
/// turned to y up, and renders.
#[test]
fn e57_scans_read_back_and_render() {
    use e57::{Record, RecordDataType, RecordName, RecordValue};
    let dir = scratch("points", "e57");
    let path = dir.join("scan.e57");
    let pts: Vec<[f64; 3]> = (0..300)
        .map(|i| {
            let f = i as f64;
            [500.0 + f * 0.03, 600.0 - f * 0.01, 3.0 + (f * 0.2).cos()]
        })
        .collect();
    {
        let mut w = e57::E57Writer::from_file(&path, "vergence-test-file").unwrap();
        let proto = vec![
            Record {
                name: RecordName::CartesianX,
                data_type: RecordDataType::Double {
                    min: None,
                    max: None,
                },
            },
            Record {
                name: RecordName::CartesianY,
                data_type: RecordDataType::Double {
                    min: None,
                    max: None,
                },
            },
            Record {
                name: RecordName::CartesianZ,
                data_type: RecordDataType::Double {
                    min: None,
                    max: None,
                },
            },
            Record {
                name: RecordName::ColorRed,
                data_type: RecordDataType::Integer { min: 0, max: 255 },
            },
            Record {
                name: RecordName::ColorGreen,
                data_type: RecordDataType::Integer { min: 0, max: 255 },
            },
            Record {
                name: RecordName::ColorBlue,
                data_type: RecordDataType::Integer { min: 0, max: 255 },
            },
        ];
        for (s, half) in pts.chunks(150).enumerate() {
            let mut pc = w
                .add_pointcloud(&format!("scan-{s}"), proto.clone())
                .unwrap();
            for (i, p) in half.iter().enumerate() {
                pc.add_point(vec![
                    RecordValue::Double(p[0]),
                    RecordValue::Double(p[1]),
                    RecordValue::Double(p[2]),
                    RecordValue::Integer((i % 256) as i64),
                    RecordValue::Integer(255),
                    RecordValue::Integer(s as i64 * 100),
                ])
                .unwrap();
            }
            pc.finalize().unwrap();
        }
        w.finalize().unwrap();
    }
    let c = vergence::scene::point_files::read_file(&path).unwrap();
    assert_eq!(c.len(), pts.len());
    for (i, p) in pts.iter().enumerate() {
        let want = DVec3::new(p[0], p[2], -p[1]);
        assert!((c.world(i) - want).abs().max_element() < 1e-4, "point {i}");
        assert_eq!(
            c.colors[i][..3],
            [(i % 150 % 256) as u8, 255, (i / 150) as u8 * 100]
        );
    }
    renders_all(&path, pts.len(), &dir.join("render"));
    // A cut file is one error.
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.join("cut.e57");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = fails_with_one_error(
        std::process::Command::new(env!("CARGO_BIN_EXE_vergence")).args([
            "render",
            "--scene",
            cut.to_str().unwrap(),
            "--out",
            dir.join("out").to_str().unwrap(),
        ]),
    );
    assert!(err.contains("cut.e57"), "{err}");
}
