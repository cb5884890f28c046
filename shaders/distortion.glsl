// Lens distortion preview, shared by its three methods
// (src/render/distortion.rs; the math is src/view/distortion/mod.rs):
// panel uv -> lens coordinates q = (uv - centre)/unit, radius r = |q|;
// undistorted q' = q * D_k(r) per colour channel k; tangent
// t = (q'.x * tan.x + axis.x, -q'.y * tan.y + axis.y); eye uv from the
// view's FOV tangents. D is PanoTools (model 0: a cubic in r, lowest power
// first, the channel's aberration scale folded in) or DPOLY3 (model 1:
// 1/(1 + k1 r^2 + k2 r^4 + k3 r^6) + k4).
layout(push_constant) uniform LensParams {
    vec4 k[3];         // per channel red, green, blue
    vec4 centre_unit;  // centre.xy, unit.xy (panel uv)
    vec4 tangent_axis; // tangent per lens unit.xy, lens axis tangent.xy
    vec4 fov;          // tan left, right, up, down
    vec2 panel;        // panel pixels
    float r_max;       // visible lens radius
    int model;         // 0 panotools, 1 dpoly3
    int layer;         // eye: layer of the source image
    int cells;         // grid method: cells per side
} pc;

float lens_factor(int c, float r) {
    vec4 k = pc.k[c];
    if (pc.model == 0) {
        return ((k.w * r + k.z) * r + k.y) * r + k.x;
    }
    float s = r * r;
    return 1.0 / (1.0 + s * (k.x + s * (k.y + s * k.z))) + k.w;
}

// d/dr of r * D(r) for the green channel (the grid method's Newton steps).
float lens_radius_slope(float r) {
    vec4 k = pc.k[1];
    if (pc.model == 0) {
        return ((4.0 * k.w * r + 3.0 * k.z) * r + 2.0 * k.y) * r + k.x;
    }
    float s = r * r;
    float b = 1.0 + s * (k.x + s * (k.y + s * k.z));
    float db = (k.x + s * (2.0 * k.y + 3.0 * k.z * s)) * 2.0 * r;
    return 1.0 / b + k.w - r * db / (b * b);
}

vec2 lens_of_panel(vec2 uv) {
    return (uv - pc.centre_unit.xy) / pc.centre_unit.zw;
}

vec2 tangent_of_undistorted(vec2 qd) {
    return vec2(qd.x * pc.tangent_axis.x, -qd.y * pc.tangent_axis.y) + pc.tangent_axis.zw;
}

vec2 eye_uv_of_tangent(vec2 t) {
    return vec2((t.x - pc.fov.x) / (pc.fov.y - pc.fov.x), (pc.fov.z - t.y) / (pc.fov.z - pc.fov.w));
}
