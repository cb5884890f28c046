#version 450
#extension GL_GOOGLE_include_directive : require
#include "distortion.glsl"
// Distortion method (a), per fragment: each panel pixel evaluates the lens
// for red, green and blue and samples the eye image three times.
layout(set = 0, binding = 0) uniform sampler2DArray eye_image;
layout(location = 0) out vec4 out_color;
void main() {
    vec2 q = lens_of_panel(gl_FragCoord.xy / pc.panel);
    float r = length(q);
    if (r > pc.r_max) {
        out_color = vec4(0.0, 0.0, 0.0, 1.0);
        return;
    }
    vec3 c;
    for (int k = 0; k < 3; k++) {
        vec2 uv = eye_uv_of_tangent(tangent_of_undistorted(q * lens_factor(k, r)));
        c[k] = texture(eye_image, vec3(uv, float(pc.layer)))[k];
    }
    out_color = vec4(c, 1.0);
}
