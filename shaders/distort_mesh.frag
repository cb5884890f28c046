#version 450
#extension GL_GOOGLE_include_directive : require
#include "distortion.glsl"
// Distortion method (c), fragment side: three samples at the interpolated
// per-channel uvs; panel pixels beyond the visible lens are dropped.
layout(set = 0, binding = 0) uniform sampler2DArray eye_image;
layout(location = 0) in vec2 v_red;
layout(location = 1) in vec2 v_green;
layout(location = 2) in vec2 v_blue;
layout(location = 0) out vec4 out_color;
void main() {
    vec2 q = lens_of_panel(gl_FragCoord.xy / pc.panel);
    if (dot(q, q) > pc.r_max * pc.r_max) {
        discard;
    }
    float layer = float(pc.layer);
    out_color = vec4(texture(eye_image, vec3(v_red, layer)).r,
                     texture(eye_image, vec3(v_green, layer)).g,
                     texture(eye_image, vec3(v_blue, layer)).b, 1.0);
}
