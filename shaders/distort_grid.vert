#version 450
#extension GL_GOOGLE_include_directive : require
#include "distortion.glsl"
// Distortion method (b): a regular grid over the eye image (no vertex
// buffer: vertex i of cell c from gl_VertexIndex), each vertex moved to the
// panel point that shows it by inverting the green channel's radial map in
// the shader, with Newton steps safeguarded by bisection on [0, r_max]
// (the rtsafe scheme of src/view/distortion/inverse.rs, fixed step count).
layout(location = 0) out vec2 v_green;
layout(location = 1) out vec2 v_q;
void main() {
    int n = pc.cells;
    int cell = gl_VertexIndex / 6;
    int corner = gl_VertexIndex % 6;
    // Two triangles per cell: (0,0) (0,1) (1,0), (1,0) (0,1) (1,1).
    ivec2 offs[6] = ivec2[6](ivec2(0, 0), ivec2(0, 1), ivec2(1, 0), ivec2(1, 0), ivec2(0, 1), ivec2(1, 1));
    ivec2 ij = ivec2(cell % n, cell / n) + offs[corner];
    // The grid reaches GRID_MARGIN (src/view/distortion/mesh.rs) beyond
    // the image on each side.
    const float margin = 0.05;
    vec2 uv = vec2(ij) / float(n) * (1.0 + 2.0 * margin) - margin;
    vec2 t = vec2(mix(pc.fov.x, pc.fov.y, uv.x), mix(pc.fov.z, pc.fov.w, uv.y));
    vec2 qd = vec2((t.x - pc.tangent_axis.z) / pc.tangent_axis.x, -(t.y - pc.tangent_axis.w) / pc.tangent_axis.y);
    float rho = length(qd);
    float lo = 0.0;
    float hi = pc.r_max;
    float r;
    if (rho >= hi * lens_factor(1, hi)) {
        r = hi;
    } else {
        r = rho / max(lens_factor(1, 0.0), 1e-6);
        r = clamp(r, lo, hi);
        for (int it = 0; it < 24; it++) {
            float f = r * lens_factor(1, r) - rho;
            if (f < 0.0) { lo = r; } else { hi = r; }
            float slope = lens_radius_slope(r);
            float next = r - f / slope;
            r = (slope > 0.0 && next > lo && next < hi) ? next : 0.5 * (lo + hi);
        }
    }
    vec2 q = rho > 0.0 ? qd * (r / rho) : vec2(0.0);
    vec2 panel = pc.centre_unit.xy + q * pc.centre_unit.zw;
    v_green = uv;
    v_q = q;
    gl_Position = vec4(panel * 2.0 - 1.0, 0.0, 1.0);
}
