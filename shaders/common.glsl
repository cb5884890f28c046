// Shared declarations for the scene shaders (set 0).
struct InstanceData {
    vec4 row0;      // linear part row 0, translation (high f32 part) in w
    vec4 row1;
    vec4 row2;
    vec4 trans_lo;  // translation low f32 part (xyz)
};

struct MaterialData {
    vec4 base_color;
    vec4 emissive_cutoff;  // rgb emissive, a alpha cutoff
    vec4 mr_scales;        // metallic, roughness, normal scale, occlusion strength
    ivec4 tex0;            // base colour, metallic-roughness, normal, occlusion (-1 = none)
    ivec4 tex1;            // emissive, uv-set mask (bit i: slot i uses UV1), flags, unused
};

layout(set = 0, binding = 0) uniform FrameData {
    mat4 view_proj[4];     // per view; 2 and 3 are the MFFR far-field cameras or inset's wide views
    mat4 eye_rot[4];       // eye orientation (world from eye), rotation only
    vec4 tangents[4];      // tan(left), tan(right), tan(up), tan(down)
    vec4 eye_rel[4];       // eye position relative to the render origin
    vec4 origin_hi;        // render origin, high f32 part
    vec4 origin_lo;        // render origin, low f32 part
    vec4 sun_dir;          // towards the sun, world space
    vec4 sun_color;
    vec4 sky_zenith;
    vec4 sky_horizon;
    vec4 ground;
    vec4 section;          // clip distance dot(section.xyz, p) + section.w < 0: cut away
    vec4 overlay_info;     // x: overlay boxes in use
    vec4 overlay[640];     // 4 per box: centre + r, half axes + g, b, 1 (MAX_BOXES = 160)
} frame;

layout(push_constant) uniform Push {
    uint material;
    uint view_offset;  // added to gl_ViewIndex: 0 under multiview, the eye in two-pass
    uint unused0;      // geometry draws: lms's w-scaling cx (float bits), else 0
    uint unused1;      // geometry draws: lms's w-scaling cy (float bits), else 0
} pc;

// Lens-matched shading without VK_NV_clip_space_w_scaling (src/view/lms.rs):
// the draw's quadrant coefficients, pushed by the scene, overlay and sky
// draws (zero otherwise, which leaves w unchanged), make
// w' = w + cx·x + cy·y in clip space — the map the extension applies in the
// rasterizer, applied before clipping instead of after.
vec4 lms_scaled(vec4 p) {
    p.w += uintBitsToFloat(pc.unused0) * p.x + uintBitsToFloat(pc.unused1) * p.y;
    return p;
}

#include "rdm.glsl"
