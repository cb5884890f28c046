#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// The sky's geometry under lens-matched shading (src/view/lms.rs): one
// quadrant of the eye's NDC square per draw (quadrant pc.material: bit 0
// the right half, bit 1 the bottom half) as two triangles, scaled like the
// scene. A full-screen triangle cannot be drawn through the scaling: its
// corners outside the square would get w' <= 0. v_ndc is the unscaled NDC;
// perspective-correct interpolation against the scaled w gives each pixel
// its eye NDC back, which sky.frag turns into a direction.
layout(location = 0) out vec2 v_ndc;
layout(location = 1) flat out uint v_view;
const vec2 CORNERS[6] = vec2[](
    vec2(0.0, 0.0), vec2(1.0, 0.0), vec2(1.0, 1.0),
    vec2(0.0, 0.0), vec2(1.0, 1.0), vec2(0.0, 1.0));
void main() {
    vec2 sign = vec2((pc.material & 1u) != 0u ? 1.0 : -1.0, (pc.material & 2u) != 0u ? 1.0 : -1.0);
    vec2 p = CORNERS[gl_VertexIndex] * sign;
    v_ndc = p;
    v_view = gl_ViewIndex;
    gl_Position = lms_scaled(vec4(p, 0.0, 1.0));
}
