//! gltfpack output of the vendored assets (KHR_mesh_quantization by
//! default, plus EXT_meshopt_compression with `-cc`) and gltf-pipeline's
//! `-d` output (KHR_draco_mesh_compression, NAME.draco.glb or
//! NAME.draco.gltf; all made by scripts/make-gltfpack-assets.sh, see each
//! folder's ATTRIBUTION.md) must render like its uncompressed source: FLIP mean ≤ 0.01 in both eyes, from
//! the same pose, with the same triangle count. (gltfpack merges nodes and
//! meshes, so instance counts differ, and bakes transforms into vertices,
//! so the variant's world boxes are tighter: they must lie inside the
//! source's.)

mod common;

use common::{context, framing_pose, load, render_config};
use vergence::bench::metrics::{flip, DESKTOP_PPD};
use vergence::config::RenderConfig;
use vergence::view::profile::HmdProfile;

/// Largest accepted mean FLIP error between a compressed file and its source.
const MAX_MEAN: f32 = 0.01;
const SIZE: u32 = 160;

/// Renders `source` and each of `variants` (paths under assets/) from the
/// pose that frames the source, and compares each eye.
fn matches_source(source: &str, variants: &[&str]) {
    matches_source_within(source, variants, MAX_MEAN);
}

/// [`matches_source`] with its own bound on the mean FLIP error.
fn matches_source_within(source: &str, variants: &[&str], max_mean: f32) {
    let ctx = context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let reference = load(source);
    let pose = framing_pose(&reference, &profile);
    let config = RenderConfig::default();
    let want = render_config(&ctx, &reference, &profile, pose, &config, SIZE, SIZE);
    let mut failures = Vec::new();
    for v in variants {
        let scene = load(v);
        assert_eq!(
            scene.instanced_triangles(),
            reference.instanced_triangles(),
            "{v}: triangle count"
        );
        let (lo, hi) = scene.bounds();
        let (rlo, rhi) = reference.bounds();
        let eps = 0.01 * (rhi - rlo).length();
        assert!(
            lo.cmpge(rlo - eps).all()
                && hi.cmple(rhi + eps).all()
                && (hi - lo).length() > 0.5 * (rhi - rlo).length(),
            "{v}: bounds {lo:?}..{hi:?} vs the source's {rlo:?}..{rhi:?}"
        );
        let got = render_config(&ctx, &scene, &profile, pose, &config, SIZE, SIZE);
        for (eye, label) in ["left", "right"].iter().enumerate() {
            let r = flip(&want.images[eye], &got.images[eye], DESKTOP_PPD).unwrap();
            eprintln!("{v} {label}: FLIP mean {:.5}", r.mean);
            if r.mean > max_mean {
                let dir = common::root().join("target/gltf-compressed-diff");
                std::fs::create_dir_all(&dir).unwrap();
                let stem = v.replace('/', "_");
                got.images[eye]
                    .save(dir.join(format!("{stem}-{label}.png")))
                    .unwrap();
                want.images[eye]
                    .save(dir.join(format!("{stem}-{label}-source.png")))
                    .unwrap();
                failures.push(format!("{v} {label}: FLIP mean {:.4} > {max_mean}", r.mean));
            }
        }
        assert!(got.stats.instances_drawn > 0, "{v}: nothing drawn");
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn box_() {
    matches_source(
        "assets/Box/Box.gltf",
        &[
            "assets/Box/Box.q.glb",
            "assets/Box/Box.cc.glb",
            "assets/Box/Box.draco.glb",
        ],
    );
}

#[test]
fn box_textured() {
    matches_source(
        "assets/BoxTextured/BoxTextured.gltf",
        &[
            "assets/BoxTextured/BoxTextured.q.glb",
            "assets/BoxTextured/BoxTextured.cc.glb",
            "assets/BoxTextured/BoxTextured.draco.gltf",
        ],
    );
}

/// BoxTextured's texture as KTX2 (KHR_texture_basisu) from the Basis
/// Universal encoder, transcoded on load. UASTC is near-lossless and meets
/// the bar; ETC1S is a lossy codec even at quality 255 (its transcode is
/// exact: tests/gltf_features.rs compares it with the reference decoder's),
/// so it gets 0.015 (measured 0.0123).
#[test]
fn box_textured_basis_universal() {
    let source = "assets/BoxTextured/BoxTextured.gltf";
    matches_source(source, &["assets/BoxTextured/BoxTextured.uastc.gltf"]);
    matches_source_within(
        source,
        &["assets/BoxTextured/BoxTextured.etc1s.gltf"],
        0.015,
    );
}

#[test]
fn multi_uv() {
    matches_source(
        "assets/MultiUVTest/MultiUVTest.gltf",
        &[
            "assets/MultiUVTest/MultiUVTest.q.glb",
            "assets/MultiUVTest/MultiUVTest.cc.glb",
            "assets/MultiUVTest/MultiUVTest.draco.gltf",
        ],
    );
}

#[test]
fn orientation() {
    matches_source(
        "assets/OrientationTest/OrientationTest.gltf",
        &[
            "assets/OrientationTest/OrientationTest.q.glb",
            "assets/OrientationTest/OrientationTest.cc.glb",
            "assets/OrientationTest/OrientationTest.draco.glb",
        ],
    );
}

#[test]
fn normal_tangent_mirror() {
    matches_source(
        "assets/NormalTangentMirrorTest/NormalTangentMirrorTest.gltf",
        &[
            "assets/NormalTangentMirrorTest/NormalTangentMirrorTest.q.glb",
            "assets/NormalTangentMirrorTest/NormalTangentMirrorTest.cc.glb",
            "assets/NormalTangentMirrorTest/NormalTangentMirrorTest.draco.gltf",
        ],
    );
}

#[test]
fn alpha_blend_modes() {
    matches_source(
        "assets/AlphaBlendModeTest/AlphaBlendModeTest.gltf",
        &[
            "assets/AlphaBlendModeTest/AlphaBlendModeTest.q.glb",
            "assets/AlphaBlendModeTest/AlphaBlendModeTest.cc.glb",
            "assets/AlphaBlendModeTest/AlphaBlendModeTest.draco.gltf",
        ],
    );
}

#[test]
fn simple_instancing() {
    matches_source(
        "assets/SimpleInstancing/SimpleInstancing.gltf",
        &[
            "assets/SimpleInstancing/SimpleInstancing.q.glb",
            "assets/SimpleInstancing/SimpleInstancing.cc.glb",
        ],
    );
}

#[test]
fn garage() {
    matches_source(
        "assets/garage/garage.gltf",
        &[
            "assets/garage/garage.q.glb",
            "assets/garage/garage.cc.glb",
            "assets/garage/garage.draco.glb",
        ],
    );
}

#[test]
fn retroufo() {
    matches_source(
        "assets/retroufo/retroufo.glb",
        &[
            "assets/retroufo/retroufo.q.glb",
            "assets/retroufo/retroufo.cc.glb",
        ],
    );
}
