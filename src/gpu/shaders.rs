//! The SPIR-V modules the renderer embeds. `build.rs` compiles every
//! `shaders/*.{vert,frag,comp}` with glslc into OUT_DIR; each module is included
//! here at compile time, so a binary carries its shaders and nothing is read
//! or compiled at run time.

/// One embedded SPIR-V module.
#[derive(Clone, Copy, Debug)]
pub struct Module {
    /// Source file name under `shaders/` (e.g. "scene.vert").
    pub name: &'static str,
    /// The SPIR-V, little-endian 32-bit words as bytes.
    pub bytes: &'static [u8],
}

impl Module {
    /// The module as the 32-bit words vkCreateShaderModule takes.
    pub fn words(&self) -> Vec<u32> {
        self.bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }
}

macro_rules! spirv {
    ($name:literal) => {
        Module {
            name: $name,
            bytes: include_bytes!(concat!(env!("OUT_DIR"), "/", $name, ".spv")),
        }
    };
}

/// The scene's vertex shader (instanced, camera-relative positions).
pub static SCENE_VERT: Module = spirv!("scene.vert");
/// The scene's vertex shader taking per-draw data from a uniform buffer
/// record at a dynamic offset (`--per-draw ubo`).
pub static SCENE_UBO_VERT: Module = spirv!("scene_ubo.vert");
/// The scene's vertex shader taking per-draw data from a storage buffer
/// indexed by the draw's firstInstance (`--per-draw ssbo`).
pub static SCENE_SSBO_VERT: Module = spirv!("scene_ssbo.vert");
/// [`SCENE_VERT`] writing the section plane's clip distance.
pub static SCENE_CLIP_VERT: Module = spirv!("scene_clip.vert");
/// [`SCENE_UBO_VERT`] writing the section plane's clip distance.
pub static SCENE_UBO_CLIP_VERT: Module = spirv!("scene_ubo_clip.vert");
/// [`SCENE_SSBO_VERT`] writing the section plane's clip distance.
pub static SCENE_SSBO_CLIP_VERT: Module = spirv!("scene_ssbo_clip.vert");
/// The scene's fragment shader with late fragment tests (alpha mask).
pub static SCENE_FRAG: Module = spirv!("scene.frag");
/// The scene's fragment shader with forced early fragment tests.
pub static SCENE_EARLY_FRAG: Module = spirv!("scene_early.frag");
/// The hidden-area (HMD stencil mask) vertex shader.
pub static HIDDEN_VERT: Module = spirv!("hidden.vert");
/// The hidden-area mask's colour where it is marked in depth.
pub static HIDDEN_FRAG: Module = spirv!("hidden.frag");
/// Radial density masking's checkerboard stencil.
pub static RDM_FRAG: Module = spirv!("rdm.frag");
/// Radial density masking's reconstruction.
pub static RDM_FILL_FRAG: Module = spirv!("rdm_fill.frag");
/// The inset composite (multi-resolution foveated rendering), in compute.
pub static INSET_COMPOSITE_COMP: Module = spirv!("inset_composite.comp");
/// Radial density masking's fill in place (the inset's wide views, LMS's
/// image).
pub static RDM_FILL_IN_PLACE_COMP: Module = spirv!("rdm_fill_in_place.comp");
/// Temporal anti-aliasing of the inset's wide views (`inset-taa`).
pub static INSET_TAA_COMP: Module = spirv!("inset_taa.comp");
/// Temporal upsampling of the inset's wide views to the eye's resolution
/// (`inset-taau`).
pub static INSET_TAAU_COMP: Module = spirv!("inset_taau.comp");
/// Point clouds: the compute rasterizer (64-bit atomic max per pixel).
pub static POINTS_RASTER_COMP: Module = spirv!("points_raster.comp");
/// Point clouds: the keys into the forward scope, with depth.
pub static POINTS_COMPOSITE_FRAG: Module = spirv!("points_composite.frag");
/// Point clouds without 64-bit atomics: one-pixel point primitives.
pub static POINTS_LIST_VERT: Module = spirv!("points_list.vert");
/// The point-list fallback's colour.
pub static POINTS_LIST_FRAG: Module = spirv!("points_list.frag");
/// Lens-matched shading's resample to the rectilinear eye image.
pub static LMS_RESAMPLE_FRAG: Module = spirv!("lms_resample.frag");
/// The sky's geometry under lens-matched shading (one quadrant per draw).
pub static SKY_LMS_VERT: Module = spirv!("sky_lms.vert");
/// The monoscopic far field's composite.
pub static MFFR_COMPOSITE_FRAG: Module = spirv!("mffr_composite.frag");
/// A full-screen triangle passing NDC and the view index on.
pub static FULLSCREEN_VERT: Module = spirv!("fullscreen.vert");
/// The procedural sky.
pub static SKY_FRAG: Module = spirv!("sky.frag");
/// A full-screen triangle with no outputs (raster floor, RDM passes).
pub static FLOOR_VERT: Module = spirv!("floor.vert");
/// A constant colour.
pub static FLAT_FRAG: Module = spirv!("flat.frag");

/// GPU-driven culling's compute shader (`gpu-cull`), with subgroup ballots.
pub static GPU_CULL_COMP: Module = spirv!("gpu_cull.comp");
/// GPU-driven culling without subgroup operations (devices lacking ballots).
pub static GPU_CULL_PLAIN_COMP: Module = spirv!("gpu_cull_plain.comp");
/// Occlusion's depth pyramid, level 0 from a single-sample depth image.
pub static HIZ_INIT_COMP: Module = spirv!("hiz_init.comp");
/// Occlusion's depth pyramid, level 0 from a multisampled depth image.
pub static HIZ_INIT_MS_COMP: Module = spirv!("hiz_init_ms.comp");
/// Occlusion's depth pyramid, one level from the one before.
pub static HIZ_REDUCE_COMP: Module = spirv!("hiz_reduce.comp");

/// The interaction overlay's vertex shader (boxes from the frame uniforms).
pub static OVERLAY_VERT: Module = spirv!("overlay.vert");

/// The interaction overlay's fragment shader.
pub static OVERLAY_FRAG: Module = spirv!("overlay.frag");

/// Distortion preview: a full-screen triangle over the panel.
pub static DISTORT_FULLSCREEN_VERT: Module = spirv!("distort_fullscreen.vert");
/// Distortion preview (a): the lens per fragment.
pub static DISTORT_FRAGMENT_FRAG: Module = spirv!("distort_fragment.frag");
/// Distortion preview (b): the grid warped in the vertex shader.
pub static DISTORT_GRID_VERT: Module = spirv!("distort_grid.vert");
/// Distortion preview (b): aberration per fragment.
pub static DISTORT_GRID_FRAG: Module = spirv!("distort_grid.frag");
/// Distortion preview (c): the pre-baked mesh.
pub static DISTORT_MESH_VERT: Module = spirv!("distort_mesh.vert");
/// Distortion preview (c): three samples at the baked uvs.
pub static DISTORT_MESH_FRAG: Module = spirv!("distort_mesh.frag");

/// Distortion preview (d): the lens per panel pixel in compute.
pub static DISTORT_COMPUTE_COMP: Module = spirv!("distort_compute.comp");
/// Timewarp: forward reprojection with depth (keys, then colours).
pub static TIMEWARP_SCATTER_COMP: Module = spirv!("timewarp_scatter.comp");
/// Timewarp: borders, cracks and holes after the scatter.
pub static TIMEWARP_RESOLVE_COMP: Module = spirv!("timewarp_resolve.comp");
/// Timewarp: the rotation-only homography.
pub static TIMEWARP_ROTATE_COMP: Module = spirv!("timewarp_rotate.comp");
/// `raster-floors`: a multisample resolve in compute.
pub static MSAA_RESOLVE_COMP: Module = spirv!("msaa_resolve.comp");

/// Every embedded module.
pub static ALL: [&Module; 45] = [
    &SCENE_VERT,
    &SCENE_UBO_VERT,
    &SCENE_SSBO_VERT,
    &SCENE_CLIP_VERT,
    &SCENE_UBO_CLIP_VERT,
    &SCENE_SSBO_CLIP_VERT,
    &SCENE_FRAG,
    &SCENE_EARLY_FRAG,
    &HIDDEN_FRAG,
    &HIDDEN_VERT,
    &RDM_FRAG,
    &RDM_FILL_FRAG,
    &INSET_COMPOSITE_COMP,
    &RDM_FILL_IN_PLACE_COMP,
    &INSET_TAA_COMP,
    &INSET_TAAU_COMP,
    &LMS_RESAMPLE_FRAG,
    &POINTS_RASTER_COMP,
    &POINTS_COMPOSITE_FRAG,
    &POINTS_LIST_VERT,
    &POINTS_LIST_FRAG,
    &SKY_LMS_VERT,
    &MFFR_COMPOSITE_FRAG,
    &FULLSCREEN_VERT,
    &SKY_FRAG,
    &FLOOR_VERT,
    &FLAT_FRAG,
    &GPU_CULL_COMP,
    &GPU_CULL_PLAIN_COMP,
    &HIZ_INIT_COMP,
    &HIZ_INIT_MS_COMP,
    &HIZ_REDUCE_COMP,
    &OVERLAY_VERT,
    &OVERLAY_FRAG,
    &DISTORT_FULLSCREEN_VERT,
    &DISTORT_FRAGMENT_FRAG,
    &DISTORT_GRID_VERT,
    &DISTORT_GRID_FRAG,
    &DISTORT_MESH_VERT,
    &DISTORT_MESH_FRAG,
    &DISTORT_COMPUTE_COMP,
    &TIMEWARP_SCATTER_COMP,
    &TIMEWARP_RESOLVE_COMP,
    &TIMEWARP_ROTATE_COMP,
    &MSAA_RESOLVE_COMP,
];

/// Every SPIR-V module the renderer uses, by file name (for validation tests).
pub fn shader_modules() -> Vec<(&'static str, &'static [u8])> {
    ALL.iter().map(|m| (m.name, m.bytes)).collect()
}
