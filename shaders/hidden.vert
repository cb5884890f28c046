#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// The HMD stencil mask: the hidden-area triangles of each view, in tangent
// space (the z = -1 plane, as XR_KHR_visibility_mask gives them), mapped to
// NDC with the view's FOV tangents like the projection does:
// x_ndc = (2 tx - (r + l)) / (r - l), y_ndc = -(2 ty - (u + d)) / (u - d).
// View v's vertices start at v * pc.material (the per-view stride). Depth 1
// is the near plane under reverse-Z: where the mask is marked in depth
// instead of stencil, every later draw fails its depth test there. In a
// lens-matched shading quadrant the mask goes through the quadrant's w
// scaling like the scene (depth 1/D there, which the scene's depth at the
// same pixel, divided by the same D, still never passes).
layout(std430, set = 0, binding = 5) readonly buffer Hidden { vec2 hidden[]; };
void main() {
    uint view = gl_ViewIndex + pc.view_offset;
    vec2 t = hidden[view * pc.material + gl_VertexIndex];
    vec4 tan = frame.tangents[view];
    float x = (2.0 * t.x - (tan.y + tan.x)) / (tan.y - tan.x);
    float y = -(2.0 * t.y - (tan.z + tan.w)) / (tan.z - tan.w);
    gl_Position = lms_scaled(vec4(x, y, 1.0, 1.0));
}
