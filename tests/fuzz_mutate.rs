//! Stable-toolchain mutation fuzzing of the same entry points as the
//! cargo-fuzz targets in fuzz/ (which need nightly and libFuzzer): CLI value
//! parsers, rig JSON and bench plans, HMD profiles with lenses, the LOD cache, the Draco decoder, the KTX2 / Basis
//! Universal transcoder and the whole glTF loader. Each target mutates its
//! seeds (the bad-input corpus, the vendored assets, built-in plans) with a
//! seeded RNG for a fixed time; any panic fails the test and the input is
//! written to target/fuzz-mutate/. Ignored by default (they run for minutes):
//! `VERGENCE_FUZZ_SECS=60 cargo test --test fuzz_mutate -- --ignored --nocapture`.

mod common;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};

/// xorshift64*: deterministic from its seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Integers and strings that often sit on boundaries.
const INTERESTING: &[&[u8]] = &[
    b"0",
    b"-1",
    b"1e308",
    b"1e-46",
    b"NaN",
    b"inf",
    b"18446744073709551615",
    b"4294967296",
    b"-0",
    b"0x10",
    b",",
    b"\"",
    b"[",
    b"]",
    b"{",
    b"}",
    b"\xff\xff\xff\xff",
    b"\0\0\0\0",
    b"\x7f",
    b"\x80",
];

/// One mutation of `input`, sometimes spliced with another seed.
fn mutate(rng: &mut Rng, input: &[u8], seeds: &[Vec<u8>]) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(v.len() + 1);
        match rng.below(7) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] = rng.next() as u8;
            }
            2 if !v.is_empty() => {
                let end = (at + 1 + rng.below(16)).min(v.len());
                v.drain(at.min(end)..end);
            }
            3 => {
                let t = INTERESTING[rng.below(INTERESTING.len())];
                v.splice(at..at, t.iter().copied());
            }
            4 if !v.is_empty() => {
                let i = rng.below(v.len());
                let n = (1 + rng.below(8)).min(v.len() - i);
                let chunk = v[i..i + n].to_vec();
                v.splice(at..at, chunk);
            }
            5 => {
                let other = &seeds[rng.below(seeds.len())];
                if !other.is_empty() {
                    let i = rng.below(other.len());
                    let n = (1 + rng.below(64)).min(other.len() - i);
                    v.splice(at..at, other[i..i + n].iter().copied());
                }
            }
            _ => v.truncate(at),
        }
    }
    v
}

/// Runs `target` on mutations of `seeds` (and the seeds themselves) for the
/// configured time; prints executions and rate; fails on any panic.
fn fuzz(name: &str, seed: u64, seeds: Vec<Vec<u8>>, target: impl Fn(&[u8])) {
    assert!(!seeds.is_empty(), "{name}: no seeds");
    let secs: u64 = std::env::var("VERGENCE_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let mut rng = Rng(seed);
    let started = Instant::now();
    let mut runs = 0u64;
    let mut crashes = Vec::new();
    let mut pool = seeds.clone();
    // An abort (a failed allocation) cannot be caught: with
    // VERGENCE_FUZZ_LAST=FILE each input is written there first.
    let last = std::env::var_os("VERGENCE_FUZZ_LAST");
    let quiet = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    while started.elapsed() < Duration::from_secs(secs) {
        let input = if (runs as usize) < seeds.len() {
            seeds[runs as usize].clone()
        } else {
            let base = &pool[rng.below(pool.len())];
            mutate(&mut rng, base, &seeds)
        };
        if let Some(last) = &last {
            std::fs::write(last, &input).unwrap();
        }
        if catch_unwind(AssertUnwindSafe(|| target(&input))).is_err() {
            crashes.push(input.clone());
        } else if pool.len() < 4096 && rng.below(16) == 0 {
            pool.push(input);
        }
        runs += 1;
    }
    std::panic::set_hook(quiet);
    let elapsed = started.elapsed().as_secs_f64();
    eprintln!(
        "{name}: {runs} executions in {elapsed:.0} s ({:.0}/s), {} seeds, {} crashes",
        runs as f64 / elapsed,
        seeds.len(),
        crashes.len()
    );
    if !crashes.is_empty() {
        let dir = common::root().join("target/fuzz-mutate");
        std::fs::create_dir_all(&dir).unwrap();
        for (i, c) in crashes.iter().take(20).enumerate() {
            std::fs::write(dir.join(format!("{name}-{i}")), c).unwrap();
        }
        panic!(
            "{name}: {} inputs panicked (saved in {})",
            crashes.len(),
            dir.display()
        );
    }
}

/// Every file under `dir` (relative to the repository) with one of `exts`.
fn files(dir: &str, exts: &[&str]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut stack = vec![common::root().join(dir)];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        let mut paths: Vec<_> = entries.flatten().map(|e| e.path()).collect();
        paths.sort();
        for p in paths {
            if p.is_dir() {
                stack.push(p);
            } else if exts.iter().any(|e| p.extension().is_some_and(|x| x == *e))
                && std::fs::metadata(&p).is_ok_and(|m| m.len() < 4 << 20)
            {
                out.push(std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

#[test]
#[ignore]
fn cli_values() {
    let mut seeds: Vec<Vec<u8>> = [
        "1",
        "0.5",
        "1e6",
        "1e20",
        "-3",
        "nan",
        "0,1.6,2,-25",
        "1,2,3,4,5,6",
        "90",
        "0.01",
        "two-pass",
        "mffr=0.5",
        "stencil-mask,mffr=1e-46",
        "cull=per-eye",
        "msaa=4",
        "cad:1000",
        "cad:100_000",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect();
    let cases =
        std::fs::read_to_string(common::root().join("tests/bad_inputs/cases.toml")).unwrap();
    let cases: toml::Value = toml::from_str(&cases).unwrap();
    for c in cases["case"].as_array().unwrap() {
        for a in c
            .get("args")
            .and_then(|a| a.as_array())
            .into_iter()
            .flatten()
        {
            seeds.push(a.as_str().unwrap_or_default().as_bytes().to_vec());
        }
    }
    fuzz("cli_values", 1, seeds, vergence::fuzz_checks::cli_values);
}

#[test]
#[ignore]
fn point_files() {
    let mut seeds = files("tests/bad_inputs/points", &["las", "laz", "ply", "e57"]);
    let dir = common::scratch("fuzz", "points");
    let scene = vergence::scene::Scene::load("factory:30").unwrap();
    let cloud = vergence::interact::scan::scan(
        &scene,
        &vergence::interact::scan::ScanSettings {
            stations: 1,
            rays_per_station: 300,
            ..Default::default()
        },
    );
    for ext in ["las", "laz"] {
        let path = dir.join(format!("seed.{ext}"));
        vergence::scene::points::write_las(&path, &cloud, 0.001).unwrap();
        seeds.push(std::fs::read(path).unwrap());
    }
    fuzz("point_files", 7, seeds, vergence::fuzz_checks::point_file);
}

#[test]
#[ignore]
fn lod_cache() {
    let scene = vergence::fuzz_checks::lod_cache_scene();
    let chains = vergence::scene::lod::build(&scene);
    let hash = vergence::scene::lod_cache::content_hash(&scene);
    let seeds = vec![vergence::scene::lod_cache::encode(hash, &chains)];
    fuzz("lod_cache", 3, seeds, vergence::fuzz_checks::lod_cache);
}

#[test]
#[ignore]
fn octree_cache() {
    let positions = vergence::fuzz_checks::octree_cache_cloud();
    let (tree, order) = vergence::scene::octree::build(&positions);
    let hash = vergence::scene::octree_cache::content_hash(glam::DVec3::ZERO, &positions);
    let seeds = vec![vergence::scene::octree_cache::encode(hash, &tree, &order)];
    fuzz(
        "octree_cache",
        3,
        seeds,
        vergence::fuzz_checks::octree_cache,
    );
}

#[test]
#[ignore]
fn rig_json_and_plans() {
    let mut seeds = files("tests/bad_inputs/rigs", &["json"]);
    seeds.extend(files("tests/bad_inputs/plans", &["toml"]));
    seeds.extend(files("manifests/bench", &["toml"]));
    let rig = vergence::view::RigFile::of(
        &vergence::view::profile::HmdProfile::load("monado-sim")
            .unwrap()
            .rig(vergence::view::Pose::from_euler_deg(
                glam::DVec3::ZERO,
                0.0,
                0.0,
                0.0,
            )),
    );
    seeds.push(serde_json::to_vec_pretty(&rig).unwrap());
    fuzz(
        "rig_json_and_plans",
        2,
        seeds,
        vergence::fuzz_checks::rig_plan,
    );
}

/// Exercises a profile's lenses: forward and inverse maps over the panel,
/// the baked mesh and the density figures; every number must stay finite
/// and every round trip land back.
fn exercise_lenses(p: &vergence::view::profile::HmdProfile) {
    use vergence::view::distortion::{density, mesh};
    for v in &p.views {
        let Some(lens) = &v.lens else { continue };
        for j in 0..=8 {
            for i in 0..=8 {
                let uv = [i as f64 / 8.0, j as f64 / 8.0];
                for c in 0..3 {
                    if let Some(t) = lens.tangent_of_panel(uv, c) {
                        assert!(t.iter().all(|x| x.is_finite()), "{t:?}");
                        if let Some(back) = lens.panel_of_tangent(t, c) {
                            assert!(back.iter().all(|x| x.is_finite()), "{back:?}");
                        }
                    }
                }
            }
        }
        let m = mesh::build(lens, &v.fov, 4);
        assert_eq!(m.indices.len(), 4 * 4 * 6);
        let small = vergence::view::distortion::Lens {
            panel: [lens.panel[0].min(64), lens.panel[1].min(64)],
            ..*lens
        };
        let _ = density::density(&small, &v.fov, [64, 64], 4);
    }
}

#[test]
#[ignore]
fn hmd_profiles_with_lenses() {
    let mut seeds = files("manifests/hmd", &["toml"]);
    seeds.extend(files("tests/bad_inputs/hmd", &["toml"]));
    fuzz("hmd_profiles_with_lenses", 4, seeds, |data| {
        let Ok(text) = std::str::from_utf8(data) else {
            return;
        };
        if let Ok(p) = vergence::view::profile::HmdProfile::parse("fuzz", text) {
            exercise_lenses(&p);
        }
    });
}

#[test]
#[ignore]
fn kiosk_files() {
    let mut seeds = files("manifests/kiosk", &["toml"]);
    seeds.extend(files("tests/bad_inputs/kiosk", &["toml"]));
    fuzz("kiosk_files", 5, seeds, vergence::fuzz_checks::kiosk);
}

#[test]
#[ignore]
fn rehearsal_scripts() {
    let mut seeds = files("manifests/rehearse", &["toml"]);
    seeds.extend(files("tests/bad_inputs/rehearse", &["toml"]));
    fuzz(
        "rehearsal_scripts",
        6,
        seeds,
        vergence::fuzz_checks::rehearse,
    );
}

#[test]
#[ignore]
fn viewpoint_files() {
    let seeds = files("tests/bad_inputs/viewpoints", &["toml"]);
    fuzz(
        "viewpoint_files",
        5,
        seeds,
        vergence::fuzz_checks::viewpoints,
    );
}

#[test]
#[ignore]
fn image_decoding() {
    // The vendored textures under 200 kB (PNG, JPEG, WebP) and the corpus's
    // crafted images.
    let mut seeds = files("assets", &["png", "jpg", "jpeg", "webp"]);
    seeds.extend(files("tests/bad_inputs", &["png", "jpg", "jpeg", "webp"]));
    seeds.retain(|s| s.len() < 200_000);
    fuzz("image_decoding", 11, seeds, |data| {
        use vergence::scene::image_decode::{decode_rgba8, MAX_TEXTURE_SIDE};
        if let Ok(img) = decode_rgba8(data) {
            assert!(img.width() <= MAX_TEXTURE_SIDE && img.height() <= MAX_TEXTURE_SIDE);
        }
    });
}

#[test]
#[ignore]
fn draco_and_basis_decoders() {
    let seeds = draco_and_basis_seeds();
    fuzz("draco_and_basis_decoders", 3, seeds, draco_and_basis);
}

/// Replays the inputs the draco/basis target saved (under
/// `target/fuzz-mutate/`), each outside the harness so its panic shows.
#[test]
#[ignore]
fn replay_draco_and_basis() {
    let dir = common::root().join("target/fuzz-mutate");
    for e in std::fs::read_dir(&dir).unwrap().flatten() {
        if e.file_name()
            .to_string_lossy()
            .starts_with("draco_and_basis_decoders-")
        {
            eprintln!("replaying {}", e.path().display());
            draco_and_basis(&std::fs::read(e.path()).unwrap());
        }
    }
}

/// The Draco stream of `Box.draco.glb` and the vendored KTX2 textures.
fn draco_and_basis_seeds() -> Vec<Vec<u8>> {
    let mut seeds = Vec::new();
    let glb = std::fs::read(common::root().join("assets/Box/Box.draco.glb")).unwrap();
    // Box.draco.glb's Draco stream: bufferView 0, 118 bytes at the start
    // of the binary chunk (after the 20-byte header + JSON + 8-byte chunk
    // header).
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let start = 20 + json_len + 8;
    seeds.push(glb[start..start + 118].to_vec());
    for f in ["CesiumLogoFlat.etc1s.ktx2", "CesiumLogoFlat.uastc.ktx2"] {
        seeds.push(std::fs::read(common::root().join("assets/BoxTextured").join(f)).unwrap());
    }
    seeds
}

/// One input through the KTX2/Basis transcoder and the Draco decoder.
fn draco_and_basis(data: &[u8]) {
    use vergence::scene::draco::{decode, DracoExt, Expected};
    let ext = DracoExt {
        view: 0,
        attributes: vec![("NORMAL".into(), 0), ("POSITION".into(), 1)],
    };
    let _ = vergence::scene::image_decode::decode_ktx2_rgba8(data);
    let expected = Expected {
        vertices: 24,
        indices: Some(36),
        max_bytes: 64 << 20,
    };
    if let Ok(d) = decode(data, &ext, expected) {
        assert!(d.indices.iter().all(|&i| i < 24));
        let p = d.floats::<3>("POSITION", false).unwrap();
        assert!(p.is_ok_and(|p| p.len() == 24));
    }
}

#[test]
#[ignore]
fn gltf_loader() {
    let mut seeds = files("tests/bad_inputs/glb", &["glb"]);
    seeds.extend(files("tests/bad_inputs/gltf", &["gltf"]));
    for f in [
        "assets/Box/Box.draco.glb",
        "assets/Box/Box.cc.glb",
        "assets/Box/Box.q.glb",
        "assets/OrientationTest/OrientationTest.draco.glb",
        "assets/BoxTextured/BoxTextured.draco.gltf",
    ] {
        seeds.push(std::fs::read(common::root().join(f)).unwrap());
    }
    // Resources resolve inside an empty folder: nothing outside is read.
    let dir = common::scratch("fuzz", "gltf");
    let path = dir.join("fuzz.glb");
    fuzz("gltf_loader", 4, seeds, |data| {
        if let Ok(scene) = vergence::scene::gltf_load::load_bytes(&path, data) {
            let (lo, hi) = scene.bounds();
            assert!(scene.instances.is_empty() || (lo.is_finite() && hi.is_finite()));
        }
    });
}
