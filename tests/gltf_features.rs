//! glTF features beyond the core vertex path, each checked on a small file
//! written here: node matrix vs TRS, sparse accessors, scene selection,
//! KHR_mesh_quantization, meshopt INDICES mode, KHR_texture_transform,
//! EXT_texture_webp and KTX2 images, emissive strength (rendered),
//! KHR_lights_punctual (the sun, rendered), cameras (`render --camera`),
//! framing without `--pose`, and `inspect`'s extension list.

mod common;

use glam::{DAffine3, DQuat, DVec3};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;
use vergence::scene::Scene;

/// Builds a glTF with one buffer (a data: URI) from appended views.
#[derive(Default)]
struct Doc {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    /// Appends `bytes` as a bufferView (4-byte aligned); returns its index.
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// Appends an accessor; returns its index.
    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// Float positions of a triangle in the z = 0 plane, as accessor.
    fn triangle(&mut self, size: f32) -> usize {
        let p: Vec<u8> = [0.0, 0.0, 0.0, size, 0.0, 0.0, 0.0, size, 0.0]
            .iter()
            .flat_map(|f: &f32| f.to_le_bytes())
            .collect();
        let v = self.view(&p, None);
        self.accessor(
            json!({"bufferView": v, "componentType": 5126, "count": 3, "type": "VEC3",
                             "min": [0, 0, 0], "max": [size, size, 0]}),
        )
    }

    /// The document: `rest` plus the buffer, views and accessors.
    fn finish(self, mut rest: Value) -> Value {
        use base64::Engine;
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bin)
        );
        rest["asset"] = json!({"version": "2.0"});
        rest["buffers"] = json!([{"uri": uri, "byteLength": self.bin.len()}]);
        rest["bufferViews"] = json!(self.views);
        rest["accessors"] = json!(self.accessors);
        rest
    }
}

fn write(test: &str, doc: &Value) -> PathBuf {
    let dir = common::scratch("gltf-features", test);
    let path = dir.join(format!("{test}.gltf"));
    std::fs::write(&path, serde_json::to_string_pretty(doc).unwrap()).unwrap();
    path
}

fn load(path: &Path) -> Scene {
    Scene::load(path.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: DAffine3, b: DAffine3) -> bool {
    a.abs_diff_eq(b, 1e-6)
}

#[test]
fn node_matrix_equals_trs() {
    let mut d = Doc::default();
    let pos = d.triangle(1.0);
    let (t, r, s) = (
        DVec3::new(1.0, 2.0, 3.0),
        DQuat::from_rotation_y(0.5) * DQuat::from_rotation_x(-0.3),
        DVec3::new(2.0, 0.5, 1.5),
    );
    let m = glam::DMat4::from_scale_rotation_translation(s, r, t);
    let doc = d.finish(json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "nodes": [
            {"mesh": 0, "translation": t.to_array(), "rotation": r.to_array(), "scale": s.to_array()},
            {"mesh": 0, "matrix": m.to_cols_array()},
            {"children": [0, 1], "translation": [10.0, 0.0, 0.0]}
        ],
        "scenes": [{"nodes": [2]}], "scene": 0
    }));
    let scene = load(&write("matrix", &doc));
    assert_eq!(scene.instances.len(), 2);
    let want = DAffine3::from_translation(DVec3::new(10.0, 0.0, 0.0))
        * DAffine3::from_scale_rotation_translation(s, r, t);
    for i in &scene.instances {
        assert!(close(i.transform, want), "{:?} vs {want:?}", i.transform);
    }
}

#[test]
fn sparse_accessors_substitute_values() {
    let mut d = Doc::default();
    let pos = d.triangle(1.0);
    let idx = d.view(&[1u16, 2].map(u16::to_le_bytes).concat(), None);
    let vals = d.view(
        &[5.0f32, 5.0, 5.0, 0.0, 7.0, 0.0]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect::<Vec<u8>>(),
        None,
    );
    d.accessors[pos]["sparse"] = json!({"count": 2,
        "indices": {"bufferView": idx, "componentType": 5123},
        "values": {"bufferView": vals}});
    // A sparse accessor without a bufferView starts as zeros.
    let zeros = d.accessor(json!({"componentType": 5126, "count": 3, "type": "VEC3",
        "min": [0, 0, 0], "max": [5, 7, 5],
        "sparse": {"count": 2, "indices": {"bufferView": idx, "componentType": 5123},
                   "values": {"bufferView": vals}}}));
    let doc = d.finish(json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]},
                   {"primitives": [{"attributes": {"POSITION": zeros}}]}],
        "nodes": [{"mesh": 0}, {"mesh": 1}],
        "scenes": [{"nodes": [0, 1]}]
    }));
    let scene = load(&write("sparse", &doc));
    assert_eq!(
        scene.primitives[0].positions,
        vec![[0.0, 0.0, 0.0], [5.0, 5.0, 5.0], [0.0, 7.0, 0.0]]
    );
    assert_eq!(
        scene.primitives[1].positions,
        vec![[0.0, 0.0, 0.0], [5.0, 5.0, 5.0], [0.0, 7.0, 0.0]]
    );
}

#[test]
fn default_and_selected_scenes() {
    let mut d = Doc::default();
    let pos = d.triangle(1.0);
    let doc = d.finish(json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "nodes": [{"mesh": 0}, {"mesh": 0, "translation": [10.0, 0.0, 0.0]}],
        "scenes": [{"name": "first", "nodes": [0]}, {"name": "second", "nodes": [1]}],
        "scene": 1
    }));
    let path = write("scenes", &doc);
    let x = |s: &Scene| s.instances[0].transform.translation.x;
    let default = load(&path);
    assert_eq!(x(&default), 10.0);
    assert_eq!(default.scene_names, ["first", "second"]);
    let spec = |sel: &str| format!("{}#{sel}", path.display());
    assert_eq!(x(&Scene::load(&spec("0")).unwrap()), 0.0);
    assert_eq!(x(&Scene::load(&spec("first")).unwrap()), 0.0);
    let e = Scene::load(&spec("third")).unwrap_err().to_string();
    assert!(
        e.contains("no scene 'third'") && e.contains("1 'second'"),
        "{e}"
    );
}

/// A 2×2 PNG, as bytes.
fn png() -> Vec<u8> {
    let mut out = Vec::new();
    image::RgbaImage::from_fn(2, 2, |x, y| {
        image::Rgba([x as u8 * 255, y as u8 * 255, 0, 255])
    })
    .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
    .unwrap();
    out
}

#[test]
fn quantized_attributes_and_texture_transform() {
    let mut d = Doc::default();
    // Unnormalized u16 positions scaled by the node (gltfpack's layout).
    let p: Vec<u8> = [0u16, 0, 0, 0, 1000, 0, 0, 0, 0, 1000, 0, 0]
        .iter()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let pv = d.view(&p, Some(8));
    let pos = d.accessor(
        json!({"bufferView": pv, "componentType": 5123, "count": 3, "type": "VEC3",
                               "min": [0, 0, 0], "max": [1000, 1000, 0]}),
    );
    let n = d.view(&[0u8, 127, 0, 0, 0x81, 0, 0, 0, 0, 0, 127, 0], Some(4));
    let nrm = d.accessor(
        json!({"bufferView": n, "componentType": 5120, "normalized": true,
                               "count": 3, "type": "VEC3"}),
    );
    let uv: Vec<u8> = [0u16, 0, 65535, 0, 0, 65535]
        .iter()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let uvv = d.view(&uv, None);
    let uv0 = d.accessor(
        json!({"bufferView": uvv, "componentType": 5123, "normalized": true,
                               "count": 3, "type": "VEC2"}),
    );
    let img = d.view(&png(), None);
    let tt = json!({"offset": [0.25, 0.5], "rotation": std::f64::consts::FRAC_PI_2,
                    "scale": [2.0, 3.0], "texCoord": 1});
    let doc = d.finish(json!({
        "extensionsUsed": ["KHR_mesh_quantization", "KHR_texture_transform"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "images": [{"bufferView": img, "mimeType": "image/png"}],
        "textures": [{"source": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
            "extensions": {"KHR_texture_transform": tt}}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm,
            "TEXCOORD_1": uv0}, "material": 0}]}],
        "nodes": [{"mesh": 0, "scale": [0.001, 0.001, 0.001]}],
        "scenes": [{"nodes": [0]}]
    }));
    let scene = load(&write("quantized", &doc));
    let p = &scene.primitives[0];
    assert_eq!(p.positions[1], [1000.0, 0.0, 0.0]);
    let (lo, hi) = scene.bounds();
    assert!((hi - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-6 && lo == DVec3::ZERO);
    // Normalized i8: 127 → 1, -127 → -1 (glTF 2.0 §3.11).
    assert_eq!(p.normals[0], [0.0, 1.0, 0.0]);
    assert_eq!(p.normals[1], [-1.0, 0.0, 0.0]);
    // texCoord 1 from the transform; uv' = T·R·S·uv with R(90°) taking
    // (x, y) to (-y, x): (1, 0) → S (2, 0) → R (0, 2) → T (0.25, 2.5).
    let tex = scene.materials[0].base_color_tex.unwrap();
    assert_eq!(tex.tex_coord, 1);
    let uv = p.uv1.as_ref().unwrap();
    let near = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-5 && (a[1] - b[1]).abs() < 1e-5;
    assert!(near(uv[0], [0.25, 0.5]), "{:?}", uv[0]);
    assert!(near(uv[1], [0.25, 2.5]), "{:?}", uv[1]);
    assert!(near(uv[2], [-2.75, 0.5]), "{:?}", uv[2]);
}

#[test]
fn quantized_types_need_the_extension() {
    let mut d = Doc::default();
    let v = d.view(&[0u8, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0], Some(4));
    let pos = d.accessor(
        json!({"bufferView": v, "componentType": 5121, "count": 3, "type": "VEC3",
                               "min": [0, 0, 0], "max": [1, 1, 0]}),
    );
    let doc = d.finish(json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]
    }));
    let e = Scene::load(write("noquant", &doc).to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("only with KHR_mesh_quantization"), "{e}");
}

#[test]
fn meshopt_indices_mode_and_fallback_buffer() {
    let mut d = Doc::default();
    let pos = d.triangle(1.0);
    let fan: Vec<u32> = vec![0, 1, 2];
    let stream = meshopt::encode_index_sequence(&fan, 3).unwrap();
    let sv = d.view(&stream, None);
    let src = d.views[sv].clone();
    d.views[sv] = json!({"buffer": 1, "byteLength": 12, "extensions": {"EXT_meshopt_compression": {
        "buffer": 0, "byteOffset": src["byteOffset"], "byteLength": stream.len(),
        "byteStride": 4, "count": 3, "mode": "INDICES"}}});
    let ind =
        d.accessor(json!({"bufferView": sv, "componentType": 5125, "count": 3, "type": "SCALAR"}));
    let mut doc = d.finish(json!({
        "extensionsUsed": ["EXT_meshopt_compression"],
        "extensionsRequired": ["EXT_meshopt_compression"],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": ind, "mode": 6}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]
    }));
    // The fallback buffer has no data at all: it must not be read.
    doc["buffers"].as_array_mut().unwrap().push(
        json!({"byteLength": 12, "extensions": {"EXT_meshopt_compression": {"fallback": true}}}),
    );
    let scene = load(&write("meshopt-indices", &doc));
    assert_eq!(scene.primitives[0].indices, fan);
}

#[test]
fn webp_and_ktx2_images_load() {
    let mut d = Doc::default();
    let pos = d.triangle(1.0);
    let mut webp = Vec::new();
    image::RgbaImage::from_pixel(3, 2, image::Rgba([20, 120, 220, 255]))
        .write_to(
            &mut std::io::Cursor::new(&mut webp),
            image::ImageFormat::WebP,
        )
        .unwrap();
    let wv = d.view(&webp, None);
    let px: Vec<u8> = (0..4 * 4 * 4).map(|i| (i * 3) as u8).collect();
    let kv = d.view(
        &vergence::scene::image_decode::encode_ktx2_rgba8(4, 4, &px),
        None,
    );
    let uvb: Vec<u8> = [0.0f32; 6].iter().flat_map(|f| f.to_le_bytes()).collect();
    let uvv = d.view(&uvb, None);
    let uv =
        d.accessor(json!({"bufferView": uvv, "componentType": 5126, "count": 3, "type": "VEC2"}));
    let doc = d.finish(json!({
        "extensionsUsed": ["EXT_texture_webp", "KHR_texture_basisu"],
        "extensionsRequired": ["EXT_texture_webp", "KHR_texture_basisu"],
        "images": [{"bufferView": wv, "mimeType": "image/webp"},
                   {"bufferView": kv, "mimeType": "image/ktx2"}],
        "textures": [{"extensions": {"EXT_texture_webp": {"source": 0}}},
                     {"extensions": {"KHR_texture_basisu": {"source": 1}}}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                "metallicRoughnessTexture": {"index": 1}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "material": 0}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]
    }));
    let scene = load(&write("images", &doc));
    let webp = &scene.textures[0];
    assert_eq!((webp.width, webp.height), (3, 2));
    assert_eq!(&webp.rgba8[..4], &[20, 120, 220, 255]);
    let ktx = &scene.textures[1];
    assert_eq!((ktx.width, ktx.height), (4, 4));
    assert_eq!(*ktx.rgba8, px);
}

/// A camera-facing 2 m quad at z = 0 with material `mat`, a camera
/// "front" 3 m in front of it, and `extra` merged into the document.
fn quad_scene(mat: Value, extra: Value) -> Value {
    let mut d = Doc::default();
    let p: Vec<u8> = [
        -1.0f32, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
    ]
    .iter()
    .flat_map(|f| f.to_le_bytes())
    .collect();
    let pv = d.view(&p, None);
    let pos = d.accessor(
        json!({"bufferView": pv, "componentType": 5126, "count": 4, "type": "VEC3",
                               "min": [-1, -1, 0], "max": [1, 1, 0]}),
    );
    let iv = d.view(&[0u16, 1, 2, 0, 2, 3].map(u16::to_le_bytes).concat(), None);
    let ind =
        d.accessor(json!({"bufferView": iv, "componentType": 5123, "count": 6, "type": "SCALAR"}));
    let mut doc = d.finish(json!({
        "materials": [mat],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": ind, "material": 0}]}],
        "cameras": [{"name": "front", "type": "perspective",
                     "perspective": {"yfov": 0.8, "znear": 0.05}}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 0.0, 3.0]}],
        "scenes": [{"nodes": [0, 1]}]
    }));
    for (k, v) in extra.as_object().unwrap() {
        if k == "nodes" {
            for n in v.as_array().unwrap() {
                doc["nodes"].as_array_mut().unwrap().push(n.clone());
                let i = doc["nodes"].as_array().unwrap().len() - 1;
                doc["scenes"][0]["nodes"]
                    .as_array_mut()
                    .unwrap()
                    .push(json!(i));
            }
        } else {
            doc[k] = v.clone();
        }
    }
    doc
}

/// Renders `path` from its camera "front" through the CLI at 64×64 and
/// returns the left eye's centre pixel.
fn render_centre(path: &Path, out: &Path, args: &[&str]) -> [u8; 4] {
    let status = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["render", "--scene", path.to_str().unwrap(), "--out"])
        .arg(out)
        .args(["--width", "64", "--height", "64", "--msaa", "1"])
        .args(args)
        .status()
        .unwrap();
    assert!(status.success(), "render {}", path.display());
    let img = image::open(out.join("left.png")).unwrap().to_rgba8();
    img.get_pixel(32, 32).0
}

#[test]
fn cameras_become_viewpoints() {
    let doc = quad_scene(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 1.0, 0.0, 1.0]}}),
        json!({}),
    );
    let path = write("camera", &doc);
    let scene = load(&path);
    assert_eq!(scene.cameras.len(), 1);
    let c = &scene.cameras[0];
    assert_eq!((c.index, c.name.as_str()), (0, "front"));
    assert!((c.pose.position - DVec3::new(0.0, 0.0, 3.0)).length() < 1e-12);
    assert_eq!(c.yfov, Some(0.8f32 as f64));
    let out = path.with_extension("out");
    // From the camera the green quad fills the centre.
    let px = render_centre(&path, &out, &["--camera", "front"]);
    assert!(px[1] > 2 * px[0].max(px[2]).max(8), "centre {px:?}");
    assert_eq!(render_centre(&path, &out, &["--camera", "0"]), px);
    // Facing away (yaw 180°), the centre is sky, not the quad.
    let away = render_centre(&path, &out, &["--pose", "0,0,3,180,0,0"]);
    assert!(away[2] > away[1], "away {away:?}");
    let stderr = common::fails_with_one_error(
        Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "render",
                "--scene",
                path.to_str().unwrap(),
                "--camera",
                "back",
                "--out",
            ])
            .arg(&out),
    );
    assert!(
        stderr.contains("'back'") && stderr.contains("0 'front'"),
        "{stderr}"
    );
}

#[test]
fn render_without_pose_frames_the_scene() {
    let out = common::scratch("gltf-features", "framing");
    let status = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["render", "--scene"])
        .arg(common::root().join("assets/Box/Box.gltf"))
        .arg("--out")
        .arg(&out)
        .args(["--width", "96", "--height", "96"])
        .status()
        .unwrap();
    assert!(status.success());
    let img = image::open(out.join("left.png")).unwrap().to_rgba8();
    // The Box is red (base colour 0.8, 0, 0): framed, it covers a good part
    // of the view.
    let red = img
        .pixels()
        .filter(|p| p.0[0] as u32 > 2 * (p.0[1] as u32).max(p.0[2] as u32) + 10)
        .count();
    assert!(red * 10 > (96 * 96), "{red} red pixels");
}

#[test]
fn emissive_strength_brightens() {
    let mat = |strength: Option<f64>| {
        let mut m = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0],
                           "metallicFactor": 0.0, "roughnessFactor": 1.0},
                           "emissiveFactor": [0.2, 0.0, 0.0]});
        if let Some(s) = strength {
            m["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": s}});
        }
        m
    };
    let plain = write("emissive-plain", &quad_scene(mat(None), json!({})));
    let strong = write("emissive-strong", &quad_scene(mat(Some(4.0)), json!({})));
    assert_eq!(load(&strong).materials[0].emissive, [0.8, 0.0, 0.0]);
    let a = render_centre(&plain, &plain.with_extension("out"), &["--camera", "front"]);
    let b = render_centre(
        &strong,
        &strong.with_extension("out"),
        &["--camera", "front"],
    );
    // sRGB-encoded output: 0.2 linear is about 124, 0.8 about 231.
    assert!(a[0] > 90 && a[0] < 160, "{a:?}");
    assert!(b[0] > 200, "{b:?}");
    assert!(b[1] < 40 && b[2] < 40, "{b:?}");
}

#[test]
fn directional_light_is_the_sun() {
    let white = json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                       "metallicFactor": 0.0, "roughnessFactor": 1.0}});
    let light = |rot: [f64; 4]| {
        json!({
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": {"KHR_lights_punctual": {"lights": [
                {"type": "directional", "color": [0.0, 0.0, 1.0], "intensity": 3.0},
                {"type": "point"}]}},
            "nodes": [{"rotation": rot, "extensions": {"KHR_lights_punctual": {"light": 0}}},
                      {"extensions": {"KHR_lights_punctual": {"light": 1}}}]
        })
    };
    // Identity: the light shines along -Z, onto the quad's face.
    let front = write(
        "sun-front",
        &quad_scene(white.clone(), light([0.0, 0.0, 0.0, 1.0])),
    );
    let scene = load(&front);
    let sun = scene.sun.unwrap();
    assert!((sun.direction - DVec3::Z).length() < 1e-9);
    assert_eq!(sun.color, [0.0, 0.0, 3.0]);
    // Rotated 180° about Y: the light comes from behind the quad.
    let behind = write(
        "sun-behind",
        &quad_scene(white, light([0.0, 1.0, 0.0, 0.0])),
    );
    assert!((load(&behind).sun.unwrap().direction + DVec3::Z).length() < 1e-9);
    let lit = render_centre(&front, &front.with_extension("out"), &["--camera", "front"]);
    let unlit = render_centre(
        &behind,
        &behind.with_extension("out"),
        &["--camera", "front"],
    );
    // A blue sun on a white quad: blue well above red and green, and far
    // brighter than with the sun behind it (ambient only).
    assert!(lit[2] as u32 > lit[0] as u32 + 60, "{lit:?}");
    assert!(lit[2] as u32 > unlit[2] as u32 + 60, "{lit:?} vs {unlit:?}");
}

#[test]
fn inspect_lists_extensions_and_support() {
    let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .arg("inspect")
        .arg(common::root().join("assets/Box/Box.cc.glb"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("extensions used 2"), "{text}");
    assert!(text.contains("extensions required 2"), "{text}");
    for line in ["EXT_meshopt_compression", "KHR_mesh_quantization"] {
        assert!(
            text.lines()
                .any(|l| l.contains(line) && l.contains("Supported")),
            "{line}: {text}"
        );
    }
}

#[test]
fn draco_from_gltf_pipeline_loads_with_its_geometry() {
    // gltf-pipeline's Box: 12 triangles over 24 vertices, positions
    // quantized to 11 bits and dequantized by the decoder (the source's
    // unit cube, within a quantization step).
    let scene = load(&common::root().join("assets/Box/Box.draco.glb"));
    let source = load(&common::root().join("assets/Box/Box.gltf"));
    assert_eq!(scene.instanced_triangles(), 12);
    let p = &scene.primitives[0];
    assert_eq!(p.positions.len(), 24);
    assert_eq!(p.indices.len(), 36);
    let (lo, hi) = scene.bounds();
    let (slo, shi) = source.bounds();
    assert!((lo - slo).abs().max_element() < 2e-3, "{lo:?} vs {slo:?}");
    assert!((hi - shi).abs().max_element() < 2e-3, "{hi:?} vs {shi:?}");
    for n in &p.normals {
        let len = glam::Vec3::from_array(*n).length();
        assert!((len - 1.0).abs() < 0.01, "normal {n:?}");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .arg("inspect")
        .arg(common::root().join("assets/Box/Box.draco.glb"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.lines()
            .any(|l| l.contains("KHR_draco_mesh_compression") && l.contains("Supported")),
        "{text}"
    );
}

/// The basisu encoder's KTX2 files transcode to exactly what the reference
/// C++ transcoder decodes them to (`basisu -unpack`: ETC1S as ETC1, UASTC
/// as ASTC 4×4, both lossless from the payload), and land within a few
/// levels of the PNG they were encoded from.
#[test]
fn basis_universal_transcodes_like_the_reference() {
    use vergence::scene::image_decode::{decode_ktx2_rgba8, decode_rgba8};
    let dir = common::root().join("assets/BoxTextured");
    let png = decode_rgba8(&std::fs::read(dir.join("CesiumLogoFlat.png")).unwrap()).unwrap();
    for (codec, channels) in [("etc1s", 3), ("uastc", 4)] {
        let ktx2 = std::fs::read(dir.join(format!("CesiumLogoFlat.{codec}.ktx2"))).unwrap();
        let got = decode_ktx2_rgba8(&ktx2).unwrap_or_else(|e| panic!("{codec}: {e}"));
        let reference = std::fs::read(dir.join(format!("CesiumLogoFlat.{codec}.reference.png")));
        let want = decode_rgba8(&reference.unwrap()).unwrap();
        assert_eq!(got.dimensions(), want.dimensions(), "{codec}");
        let differ = got
            .pixels()
            .zip(want.pixels())
            .filter(|(a, b)| a.0[..channels] != b.0[..channels])
            .count();
        assert_eq!(
            differ, 0,
            "{codec}: {differ} pixels differ from the reference decode"
        );
        let err: f64 = got
            .pixels()
            .zip(png.pixels())
            .map(|(a, b)| {
                (0..3)
                    .map(|k| (a.0[k] as f64 - b.0[k] as f64).abs())
                    .sum::<f64>()
            })
            .sum::<f64>()
            / (3.0 * got.pixels().len() as f64);
        assert!(
            err < 8.0,
            "{codec}: mean error {err:.2} levels against the PNG"
        );
        eprintln!("{codec}: identical to the reference decode; mean error {err:.2} levels against the PNG");
    }
}

/// `run` starts at `--camera` (headless: the first frame's head is at the
/// camera, looking along it) and offers every camera of the file as a
/// viewpoint (listed in the stats, the start first).
#[test]
fn run_starts_at_a_camera_and_offers_the_cameras() {
    let doc = quad_scene(
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 1.0, 0.0, 1.0]}}),
        json!({"nodes": [{"camera": 1, "name": "side-node",
                          "translation": [4.0, 1.0, 0.0],
                          "rotation": [0.0, std::f64::consts::FRAC_1_SQRT_2, 0.0, std::f64::consts::FRAC_1_SQRT_2]}]}),
    );
    let mut doc = doc;
    doc["cameras"].as_array_mut().unwrap().push(
        json!({"name": "side", "type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05}}),
    );
    let path = write("run-camera", &doc);
    let run = |extra: &[&str]| -> Value {
        let stats = path.with_extension(format!("{}.json", extra.len()));
        let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "run", "--xr", "headless", "--frames", "3", "--width", "32", "--height", "32",
            ])
            .arg("--scene")
            .arg(&path)
            .arg("--stats-out")
            .arg(&stats)
            .args(extra)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap()
    };
    let s = run(&["--camera", "side"]);
    assert_eq!(
        s["viewpoints"],
        json!(["camera 1 'side'", "camera 0 'front'"]),
        "{}",
        s["viewpoints"]
    );
    let head = &s["frames"][0]["head_world"];
    let p: Vec<f64> = serde_json::from_value(head["position"].clone()).unwrap();
    assert!(
        (p[0] - 4.0).abs() < 1e-6 && (p[1] - 1.0).abs() < 1e-6 && p[2].abs() < 1e-6,
        "head {p:?}"
    );
    // Rotated +90° about Y, the side camera looks down -X (towards the
    // quad's edge at the origin): the head's -Z axis points along -X.
    let q: Vec<f64> = serde_json::from_value(head["orientation"].clone()).unwrap();
    let rot = glam::DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
    let fwd = rot * DVec3::NEG_Z;
    assert!((fwd - DVec3::NEG_X).length() < 1e-6, "forward {fwd:?}");
    // By index, and without --camera: the framing spawn first, then both.
    assert_eq!(
        run(&["--camera", "0"])["viewpoints"][0],
        json!("camera 0 'front'")
    );
    assert_eq!(
        run(&[])["viewpoints"],
        json!(["spawn", "camera 0 'front'", "camera 1 'side'"])
    );
    let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "run", "--xr", "headless", "--frames", "1", "--camera", "nope", "--scene",
        ])
        .arg(&path)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("--camera")
            && err.contains("0 'front'")
            && err.contains("1 'side'"),
        "{err}"
    );
}

#[test]
fn a_camera_with_a_degenerate_transform_is_named_not_dropped_unseen() {
    let dir = common::scratch("gltf", "degenerate-camera");
    let path = dir.join("cam.gltf");
    std::fs::write(
        &path,
        r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
            "nodes":[{"camera":0,"scale":[0,0,0]}],
            "cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.1}}]}"#,
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["inspect", path.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("node 0 places camera 0 with a degenerate transform"),
        "{stderr}"
    );
}
