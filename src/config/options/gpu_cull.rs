//! `gpu-cull`, `occlusion`, `lod[=PX]` and `lod-cache`: culling and level
//! of detail on the GPU ([`crate::render::passes::gpu_cull`]).

use super::{flag, optional, Entry, Rule, Technique};
use crate::config::{Culling, RenderConfig, MAX_LOD_BOUND_PX};
use crate::error::{Error, Result};

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "GPU-driven culling, occlusion, LOD",
    page: "gpu-cull",
    summary: "culls on the GPU with indirect draws, two-phase hierarchical-Z occlusion, per-instance level of detail by projected error",
    options: &[
        flag("gpu-cull"),
        flag("occlusion"),
        optional("lod", "PX", "2"),
        flag("lod-cache"),
    ],
    parse,
    print,
    rules: &[
        Rule::always(
            |c| c.culling.gpu_cull && c.culling.cull == Culling::None,
            "gpu-cull needs a culling strategy (per-eye, superfrustum, conical, conical-superfrustum, round-robin, round-robin-conical)",
        ),
        Rule::always(
            |c| c.culling.occlusion && !c.culling.gpu_cull,
            "occlusion runs inside the GPU cull: add gpu-cull (e.g. multiview,superfrustum,gpu-cull,occlusion)",
        ),
        Rule::always(
            |c| c.culling.lod_cache && c.culling.lod.is_none(),
            "lod-cache keeps the chains lod builds: add lod (e.g. multiview,superfrustum,gpu-cull,lod,lod-cache)",
        ),
        Rule::always(
            |c| c.culling.lod.is_some() && !c.culling.gpu_cull,
            "lod selects levels inside the GPU cull: add gpu-cull (e.g. multiview,superfrustum,gpu-cull,lod)",
        ),
        Rule::always(
            |c| c.culling.occlusion && c.effort.mffr.is_some(),
            "occlusion and mffr cannot be combined: the depth pyramid would see only the near field's depth (gpu-cull alone splits near from far)",
        ),
    ],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    match (e.name, e.value) {
        ("gpu-cull", _) => c.culling.gpu_cull = true,
        ("occlusion", _) => c.culling.occlusion = true,
        ("lod-cache", _) => c.culling.lod_cache = true,
        (_, None) => c.culling.lod = Some(c.culling.lod.unwrap_or(crate::view::lod::DEFAULT_BOUND_PX)),
        (_, Some(v)) => match v.parse::<f64>() {
            Ok(px) if px.is_finite() && px > 0.0 && px <= MAX_LOD_BOUND_PX => c.culling.lod = Some(px),
            _ => {
                return Err(Error::config(
                    "--opt",
                    format!(
                        "'{}': expected lod=PX with 0 < PX <= {MAX_LOD_BOUND_PX} (pixels of projected error)",
                        e.item
                    ),
                ))
            }
        },
    }
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.culling.gpu_cull {
        out.push("gpu-cull".into());
    }
    if c.culling.occlusion {
        out.push("occlusion".into());
    }
    if let Some(px) = c.culling.lod {
        out.push(format!("lod={px}"));
    }
    if c.culling.lod_cache {
        out.push("lod-cache".into());
    }
}
