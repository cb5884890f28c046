//! What the renderer chose for each technique it was built with — the
//! paths that ran (or why one fell back), LMS's image, LOD's chains —
//! as one block that `stats.json`, `run --stats-out` and bench results
//! embed alike.

use super::passes::lms::LmsReport;
use super::{LodReport, Renderer};

/// The renderer's per-technique choices, embedded (flattened) in every
/// report that describes a rendered run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RendererReport {
    /// Which foveation path ran: "off", the Vulkan path, or why it fell
    /// back to off.
    #[serde(default, alias = "foveation_path")]
    pub foveation: String,
    /// With `inset`: how its views were drawn, "four-view multiview" or
    /// "two scopes (why)".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inset_path: Option<String>,
    /// With `lms`: the path that scaled w, the coefficients and the LMS
    /// image's size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lms: Option<LmsReport>,
    /// With `lod`: the chains built at load (levels, index bytes, build ms,
    /// the cache's use).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod: Option<LodReport>,
    /// Which path drew the scene's point cloud: "compute (64-bit atomic
    /// max)", or the point-list pipeline and why (absent without a cloud).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points_path: Option<String>,
    /// Points in the scene's cloud (None: no cloud); stats.json gives it
    /// its own key.
    #[serde(skip)]
    pub points_total: Option<u64>,
    /// Per-view render areas: offered by the device or not, and why
    /// vergence does not use them.
    #[serde(default)]
    pub per_view_render_areas: String,
}

impl Renderer {
    /// The per-technique choices of this renderer, as the reports embed
    /// them.
    pub fn report(&self) -> RendererReport {
        let mut r = RendererReport {
            foveation: self.foveation_path.clone(),
            inset_path: self.inset_path.clone(),
            lms: self.passes.lms.as_ref().map(|l| l.report()),
            lod: self.lod.clone(),
            points_path: None,
            points_total: None,
            per_view_render_areas: per_view_render_areas(
                self.ctx.caps.per_view_render_areas,
                &self.ctx.device_name,
            ),
        };
        for t in &self.passes.techniques {
            t.report(&mut r);
        }
        r
    }
}

/// The stats line on VK_QCOM_multiview_per_view_render_areas: whether
/// `device` offers it (`offered`, from the device's extension list), and
/// that vergence does not use it, with the reason.
pub fn per_view_render_areas(offered: bool, device: &str) -> String {
    format!(
        "{} by {device}; unused: each view has its own projection over its whole image, so there is no padding to skip",
        if offered { "offered" } else { "not offered" }
    )
}
