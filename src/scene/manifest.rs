//! Scene manifests (TOML, `manifests/scenes/`): compose glTF files and
//! procedural content, optionally instanced on a grid, into one scene.
//!
//! ```toml
//! name = "ufo-fleet"
//! [[gltf]]
//! file = "../../assets/retroufo/retroufo.glb"   # relative to the manifest
//! translation = [0.0, 0.0, -10.0]
//! yaw_deg = 0.0
//! scale = 1.0
//! grid = { count = [40, 1, 50], spacing = [6.0, 0.0, 6.0] }
//! motion = { spin_deg_s = 30.0, bob_m = 0.2, bob_period_s = 2.0 }  # optional
//! [[procedural]]
//! kind = "factory"
//! instances = 10000
//! seed = 1
//! [[viewpoint]]                 # where a user may stand (run's viewpoint cycle)
//! name = "fleet overview"
//! position = [0.0, 0.0, 20.0]  # the floor under the user
//! yaw_deg = 0.0                # 0 looks down -Z
//! ```

use super::budget::LoadBudget;
use super::motion::{cell_phase, Motion, MovingGroup};
use super::{factory, gltf_load, Scene, SceneCamera};
use crate::error::{Error, Result};
use glam::{DAffine3, DQuat, DVec3};
use serde::Deserialize;
use std::path::Path;

/// Most placements (grid cells) one manifest entry may ask for.
pub const MAX_PLACEMENTS: u64 = 20_000_000;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Grid {
    count: [u32; 3],
    spacing: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Placement {
    #[serde(default)]
    translation: [f64; 3],
    #[serde(default)]
    yaw_deg: f64,
    #[serde(default = "one")]
    scale: f64,
    grid: Option<Grid>,
    /// How every placement moves (none: static).
    motion: Option<Motion>,
}

fn one() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GltfEntry {
    file: String,
    #[serde(flatten)]
    place: Placement,
}

/// A point cloud placed in the scene (`[[points]]`): a LAS/LAZ file with
/// the same placement keys as `[[gltf]]` (a grid or motion is refused).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsEntry {
    file: String,
    #[serde(flatten)]
    place: Placement,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProceduralEntry {
    kind: String,
    instances: usize,
    #[serde(default = "default_seed")]
    seed: u64,
    #[serde(flatten)]
    place: Placement,
}

fn default_seed() -> u64 {
    factory::DEFAULT_SEED
}

/// A named place to stand: the floor point under the user and the yaw.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewpointEntry {
    name: String,
    position: [f64; 3],
    #[serde(default)]
    yaw_deg: f64,
}

/// Eye height above the floor of a manifest viewpoint, metres (a
/// standing viewer, as `run`'s spawn assumes).
pub const VIEWPOINT_EYE_HEIGHT_M: f64 = 1.6;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    name: String,
    #[serde(default)]
    gltf: Vec<GltfEntry>,
    #[serde(default)]
    procedural: Vec<ProceduralEntry>,
    #[serde(default)]
    points: Vec<PointsEntry>,
    #[serde(default)]
    viewpoint: Vec<ViewpointEntry>,
}

/// The manifest's viewpoints as scene cameras (eyes at
/// [`VIEWPOINT_EYE_HEIGHT_M`] over each floor point, looking level along
/// the yaw), numbered after the cameras already there.
fn viewpoint_cameras(path: &Path, entries: &[ViewpointEntry], scene: &mut Scene) -> Result<()> {
    for (i, v) in entries.iter().enumerate() {
        let ok = v.position.iter().all(|c| c.is_finite() && c.abs() <= 1e9)
            && v.yaw_deg.is_finite()
            && v.yaw_deg.abs() <= 36_000.0;
        if !ok {
            return Err(Error::scene(
                path,
                format!(
                    "viewpoint[{i}] '{}': position (at most 1e9 m) and yaw_deg (at most 36000) must be finite",
                    v.name
                ),
            ));
        }
        let eye = DVec3::from(v.position) + DVec3::Y * VIEWPOINT_EYE_HEIGHT_M;
        scene.cameras.push(SceneCamera {
            index: scene.cameras.len(),
            name: v.name.clone(),
            pose: crate::view::Pose::from_euler_deg(eye, v.yaw_deg, 0.0, 0.0),
            yfov: None,
        });
    }
    Ok(())
}

/// Grid cells of a placement (1 without a grid), in checked arithmetic,
/// before anything is built.
fn cells(path: &Path, what: &str, p: &Placement) -> Result<u64> {
    let Some(g) = &p.grid else {
        return Ok(1);
    };
    crate::count::within(
        &format!("grid count {:?}: the number of cells", g.count),
        crate::count::product(g.count.iter().map(|&c| c as u64)),
        MAX_PLACEMENTS,
    )
    .map_err(|m| Error::scene(path, format!("{what}: {m}")))
}

fn placements(
    path: &Path,
    what: &str,
    p: &Placement,
    budget: &LoadBudget,
) -> Result<Vec<DAffine3>> {
    let err = |m: String| Error::scene(path, format!("{what}: {m}"));
    if !(p.scale.is_finite() && (1e-6..=1e6).contains(&p.scale)) {
        return Err(err(format!(
            "scale {} must be a number in [1e-6, 1e6]",
            p.scale
        )));
    }
    if !p
        .translation
        .iter()
        .all(|v| v.is_finite() && v.abs() <= 1e9)
        || !p.yaw_deg.is_finite()
    {
        return Err(err(
            "translation (at most 1e9 m) and yaw_deg must be finite".into(),
        ));
    }
    let base = DAffine3::from_scale_rotation_translation(
        DVec3::splat(p.scale),
        DQuat::from_rotation_y(p.yaw_deg.to_radians()),
        DVec3::from_array(p.translation),
    );
    let Some(g) = &p.grid else {
        return Ok(vec![base]);
    };
    let cells = cells(path, what, p)?;
    if !g.spacing.iter().all(|v| v.is_finite() && v.abs() <= 1e6) {
        return Err(err("grid spacing must be finite, at most 1e6 m".into()));
    }
    let reach = (0..3)
        .map(|k| p.translation[k].abs() + g.count[k] as f64 * g.spacing[k].abs())
        .fold(0.0, f64::max);
    if reach > 1e9 {
        return Err(err(format!(
            "the grid reaches {reach:.3e} m from the origin, beyond 1e9 m"
        )));
    }
    budget
        .spend(
            crate::count::bytes_of::<DAffine3>(cells),
            &format!("{what}: {cells} grid placements"),
        )
        .map_err(|m| Error::scene(path, m))?;
    let mut out = Vec::with_capacity(cells as usize);
    for z in 0..g.count[2] {
        for y in 0..g.count[1] {
            for x in 0..g.count[0] {
                let off = DVec3::new(
                    x as f64 * g.spacing[0],
                    y as f64 * g.spacing[1],
                    -(z as f64) * g.spacing[2],
                );
                out.push(DAffine3::from_translation(off) * base);
            }
        }
    }
    Ok(out)
}

/// Fails when adding `n` instances at each of `cells` placements would take
/// the scene over [`MAX_INSTANCES`] or its memory budget (checked
/// arithmetic throughout).
fn check_budget(
    path: &Path,
    what: &str,
    scene: &Scene,
    n: u64,
    cells: u64,
    budget: &LoadBudget,
) -> Result<()> {
    let added = crate::count::product([n, cells]);
    let total = added.and_then(|a| crate::count::sum([a, scene.instances.len() as u64]));
    match total {
        Some(t) if t <= MAX_INSTANCES => {}
        _ => {
            return Err(Error::scene(
                path,
                format!(
                    "{what}: {n} instances × {cells} placements would exceed the {MAX_INSTANCES} instance limit"
                ),
            ))
        }
    }
    budget
        .spend(
            added.and_then(crate::count::bytes_of::<super::Instance>),
            &format!("{what}: {n} instances × {cells} placements"),
        )
        .map_err(|m| Error::scene(path, m))
}

/// Appends `sub` at every placement of `place`; with a `motion` that
/// moves, its instances join the scene's moving groups and stand where
/// the motion has them at time 0.
fn append_placed(
    path: &Path,
    what: &str,
    scene: &mut Scene,
    sub: &Scene,
    place: &[DAffine3],
    motion: Option<Motion>,
) -> Result<()> {
    let first = scene.instances.len();
    let m0 = scene.meshes.len() as u32;
    scene.append(sub, place);
    let Some(motion) = motion else {
        return Ok(());
    };
    motion
        .validate()
        .map_err(|m| Error::scene(path, format!("{what}: {m}")))?;
    if !motion.moves() || sub.instances.is_empty() {
        return Ok(());
    }
    let n = sub.instances.len();
    let group = MovingGroup {
        motion,
        locals: sub
            .instances
            .iter()
            .map(|i| (i.mesh + m0, i.transform))
            .collect(),
        placements: place
            .iter()
            .enumerate()
            .map(|(k, p)| (*p, cell_phase(k), (first + k * n) as u32))
            .collect(),
    };
    let mut at0 = Vec::new();
    super::motion::transforms_at(std::slice::from_ref(&group), 0.0, &mut at0);
    for m in at0 {
        scene.instances[m.index as usize].transform = m.transform;
    }
    scene.moving.push(group);
    Ok(())
}

/// Most instances a manifest may produce in all.
pub const MAX_INSTANCES: u64 = 50_000_000;

/// Loads a scene manifest; relative file paths resolve against its folder.
pub fn load(path: &Path) -> Result<Scene> {
    load_with(path, false)
}

/// [`load`]; with `write_octree_cache`, the point clouds' octree is built
/// and written to the manifest's cache file (`FILE.toml.octree`).
pub fn load_with(path: &Path, write_octree_cache: bool) -> Result<Scene> {
    let text =
        crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES).map_err(|source| {
            Error::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
    from_text_with(path, &text, &LoadBudget::default(), write_octree_cache)
}

/// Builds the scene of manifest `text` read from `path`, within one
/// memory budget ([`LoadBudget`]) for everything it names.
pub fn from_text(path: &Path, text: &str) -> Result<Scene> {
    from_text_in(path, text, &LoadBudget::default())
}

/// [`from_text`] within `budget`.
pub fn from_text_in(path: &Path, text: &str, budget: &LoadBudget) -> Result<Scene> {
    from_text_with(path, text, budget, false)
}

/// [`from_text_in`]; with `write_octree_cache`, the clouds' octree is
/// built and written to the manifest's cache file.
fn from_text_with(
    path: &Path,
    text: &str,
    budget: &LoadBudget,
    write_octree_cache: bool,
) -> Result<Scene> {
    let m: Manifest = toml::from_str(text)
        .map_err(|e| Error::scene(path, format!("malformed scene manifest: {}", e.message())))?;
    if m.gltf.is_empty() && m.procedural.is_empty() && m.points.is_empty() {
        return Err(Error::scene(
            path,
            "manifest lists no [[gltf]], [[procedural]] or [[points]] entries",
        ));
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut scene = Scene {
        name: m.name.clone(),
        ..Scene::default()
    };
    for (i, g) in m.gltf.iter().enumerate() {
        let what = format!("gltf[{i}]");
        let n_cells = cells(path, &what, &g.place)?;
        let sub = gltf_load::load_in(&dir.join(&g.file), budget)?;
        check_budget(
            path,
            &what,
            &scene,
            sub.instances.len() as u64,
            n_cells,
            budget,
        )?;
        let place = placements(path, &what, &g.place, budget)?;
        append_placed(path, &what, &mut scene, &sub, &place, g.place.motion)?;
    }
    for (i, p) in m.procedural.iter().enumerate() {
        let what = format!("procedural[{i}]");
        if p.instances == 0 || p.instances > factory::MAX_INSTANCES {
            return Err(Error::scene(
                path,
                format!(
                    "{what}: instances = {} must be within 1..={}",
                    p.instances,
                    factory::MAX_INSTANCES
                ),
            ));
        }
        let n_cells = cells(path, &what, &p.place)?;
        check_budget(path, &what, &scene, p.instances as u64, n_cells, budget)?;
        let place = placements(path, &what, &p.place, budget)?;
        let sub = match p.kind.as_str() {
            "factory" => factory::generate(p.instances, p.seed)?,
            other => {
                return Err(Error::scene(
                    path,
                    format!("procedural[{i}]: unknown kind '{other}' (known: factory)"),
                ))
            }
        };
        append_placed(path, &what, &mut scene, &sub, &place, p.place.motion)?;
    }
    for (i, p) in m.points.iter().enumerate() {
        let what = format!("points[{i}]");
        if p.place.grid.is_some() || p.place.motion.is_some() {
            return Err(Error::scene(
                path,
                format!("{what}: a point cloud takes translation, yaw_deg and scale, not a grid or motion"),
            ));
        }
        let place = placements(path, &what, &p.place, budget)?[0];
        let cloud = super::point_files::read_file(&dir.join(&p.file))?.placed(&place);
        let merged = match scene.points.take() {
            Some(mut all) => {
                std::sync::Arc::make_mut(&mut all).append(&cloud);
                all
            }
            None => std::sync::Arc::new(cloud),
        };
        if merged.len() as u64 > super::points::MAX_POINTS {
            return Err(Error::scene(
                path,
                format!(
                    "{what}: the clouds hold over {} points together",
                    super::points::MAX_POINTS
                ),
            ));
        }
        scene.points = Some(merged);
    }
    if let Some(all) = scene.points.take() {
        let cloud = std::sync::Arc::try_unwrap(all).unwrap_or_else(|shared| (*shared).clone());
        scene.points = Some(std::sync::Arc::new(
            cloud.with_octree_cached(path, write_octree_cache),
        ));
    }
    viewpoint_cameras(path, &m.viewpoint, &mut scene)?;
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viewpoints_become_named_cameras_at_eye_height() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let path = root.join("manifests/scenes/viewpoints-test.toml");
        let text = "name = \"v\"\n[[gltf]]\nfile = \"../../assets/Box/Box.gltf\"\n\
                    [[viewpoint]]\nname = \"front\"\nposition = [0.0, 0.0, 3.0]\n\
                    [[viewpoint]]\nname = \"side\"\nposition = [3.0, 1.0, 0.0]\nyaw_deg = 90.0\n";
        let scene = from_text_in(&path, text, &LoadBudget::new(1 << 30)).unwrap();
        let names: Vec<&str> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["front", "side"]);
        let side = &scene.cameras[1];
        assert!(side.pose.position.distance(DVec3::new(3.0, 2.6, 0.0)) < 1e-12);
        // Yaw 90° looks down −X (a left turn from −Z).
        assert!(side.pose.forward().distance(DVec3::NEG_X) < 1e-12);
        let bad = text.replace("yaw_deg = 90.0", "yaw_deg = nan");
        let e = from_text_in(&path, &bad, &LoadBudget::new(1 << 30)).unwrap_err();
        assert!(e.to_string().contains("viewpoint[1] 'side'"), "{e}");
    }

    /// A manifest's entries share one budget: naming the same file again
    /// and again runs out of it instead of multiplying memory.
    #[test]
    fn entries_share_one_budget() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let path = root.join("manifests/scenes/budget-test.toml");
        let entry = "[[gltf]]\nfile = \"../../assets/Box/Box.gltf\"\n";
        let text = format!("name = \"x\"\n{}", entry.repeat(40));
        let one = {
            let b = LoadBudget::new(1 << 30);
            from_text_in(&path, &format!("name = \"x\"\n{entry}"), &b).unwrap();
            (1u64 << 30) - b.left()
        };
        assert!(one > 0, "a load spends from its budget");
        let budget = LoadBudget::new(one * 10);
        let e = from_text_in(&path, &text, &budget).unwrap_err().to_string();
        assert!(e.contains("memory budget of one scene load"), "{e}");
        let scene = from_text_in(&path, &text, &LoadBudget::new(one * 41)).unwrap();
        assert_eq!(scene.meshes.len(), 40);
    }
}
