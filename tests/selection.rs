//! Pointing names what it hits: the glTF node's name and path from the
//! scene root, the mesh, the material and the node's `extras`.

mod common;

use glam::DVec3;
use vergence::interact::describe;
use vergence::interact::raycast::{Ray, SceneQuery};
use vergence::scene::Scene;

/// The Box sample under two named parents, its node carrying extras.
fn named_box() -> std::path::PathBuf {
    let dir = common::scratch("selection", "named");
    let src = common::root().join("assets/Box");
    std::fs::copy(src.join("Box0.bin"), dir.join("Box0.bin")).unwrap();
    let mut g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(src.join("Box.gltf")).unwrap()).unwrap();
    let nodes = g["nodes"].as_array_mut().unwrap();
    // Node 0 (the Box's rotation) gets a name; node 2, the hall, becomes
    // the root above it.
    nodes[0]["name"] = "line 3".into();
    nodes[1]["name"] = "robot arm".into();
    nodes[1]["extras"] = serde_json::json!({"part": "R-17", "mass_kg": 42.5});
    nodes.push(serde_json::json!({"name": "hall", "children": [0]}));
    g["scenes"][0]["nodes"] = serde_json::json!([2]);
    g["meshes"][0]["name"] = "arm casing".into();
    let p = dir.join("named.gltf");
    std::fs::write(&p, serde_json::to_string(&g).unwrap()).unwrap();
    p
}

#[test]
fn a_hit_is_named_by_node_path_mesh_material_and_extras() {
    let scene = Scene::load(named_box().to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.instance_node.len(), scene.instances.len());
    let q = SceneQuery::new(&scene);
    let from = DVec3::new(0.0, 0.0, 3.0);
    let hit = q
        .cast(&Ray {
            origin: from,
            direction: DVec3::NEG_Z,
            max_t: 10.0,
        })
        .expect("the ray hits the box");
    let picked = describe(&scene, &hit, from);
    assert_eq!(picked.node.as_deref(), Some("robot arm"));
    assert_eq!(picked.path.as_deref(), Some("hall/line 3/robot arm"));
    assert_eq!(picked.mesh, "arm casing");
    assert_eq!(picked.material, "Red");
    assert_eq!(
        picked.extras,
        Some(serde_json::json!({"part": "R-17", "mass_kg": 42.5}))
    );
    assert!((picked.distance_m - 2.5).abs() < 1e-9, "{picked:?}");
    // As the select event writes it.
    let event = vergence::interact::Event::Select {
        hand: "right",
        picked,
    };
    let v = serde_json::to_value(&event).unwrap();
    assert_eq!(v["kind"], "select");
    assert_eq!(v["path"], "hall/line 3/robot arm");
    assert_eq!(v["extras"]["part"], "R-17");
}

#[test]
fn generated_scenes_keep_no_names() {
    let scene = Scene::load("factory:1000").unwrap();
    assert!(scene.instance_node.is_empty() && scene.node_info.is_empty());
    let q = SceneQuery::new(&scene);
    let from = DVec3::new(1.0, 1.0, -1.0);
    let hit = q
        .cast(&Ray {
            origin: from,
            direction: DVec3::NEG_Y,
            max_t: 10.0,
        })
        .expect("the floor");
    let picked = describe(&scene, &hit, from);
    assert_eq!(
        (picked.node, picked.path, picked.extras),
        (None, None, None)
    );
    assert_eq!(picked.mesh, "floor");
}
