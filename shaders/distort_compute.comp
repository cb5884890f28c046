#version 450
#extension GL_GOOGLE_include_directive : require
#include "distortion.glsl"
// Distortion method (d), in compute: one invocation per panel pixel
// evaluates the lens per colour channel as the fragment method does and
// stores the sRGB-encoded result (storage images have no sRGB formats), so
// no rasterizer is involved.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform sampler2DArray eye_image;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2DArray panel_image;

vec3 srgb_encode(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, ivec2(pc.panel)))) {
        return;
    }
    vec2 q = lens_of_panel((vec2(p) + 0.5) / pc.panel);
    float r = length(q);
    vec3 c = vec3(0.0);
    if (r <= pc.r_max) {
        for (int k = 0; k < 3; k++) {
            vec2 uv = eye_uv_of_tangent(tangent_of_undistorted(q * lens_factor(k, r)));
            c[k] = textureLod(eye_image, vec3(uv, float(pc.layer)), 0.0)[k];
        }
    }
    imageStore(panel_image, ivec3(p, pc.layer), vec4(srgb_encode(c), 1.0));
}
