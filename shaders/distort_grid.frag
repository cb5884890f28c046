#version 450
#extension GL_GOOGLE_include_directive : require
#include "distortion.glsl"
// Distortion method (b), fragment side: the green channel's eye uv comes
// interpolated from the grid; red and blue scale its offset from the lens
// axis by D_red(r)/D_green(r) and D_blue(r)/D_green(r) (all channels share
// the direction of q, and the eye uv is affine in the tangent).
layout(set = 0, binding = 0) uniform sampler2DArray eye_image;
layout(location = 0) in vec2 v_green;
layout(location = 1) in vec2 v_q;
layout(location = 0) out vec4 out_color;
void main() {
    vec2 q = lens_of_panel(gl_FragCoord.xy / pc.panel);
    float r = length(q);
    if (r > pc.r_max) {
        discard;
    }
    vec2 axis = eye_uv_of_tangent(pc.tangent_axis.zw);
    float g = lens_factor(1, r);
    vec2 uv_r = axis + (v_green - axis) * (lens_factor(0, r) / g);
    vec2 uv_b = axis + (v_green - axis) * (lens_factor(2, r) / g);
    float layer = float(pc.layer);
    out_color = vec4(texture(eye_image, vec3(uv_r, layer)).r,
                     texture(eye_image, vec3(v_green, layer)).g,
                     texture(eye_image, vec3(uv_b, layer)).b, 1.0);
}
