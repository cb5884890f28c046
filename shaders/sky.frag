#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Early fragment tests: the sky never discards or writes depth, so the
// stencil mask and the depth test reject pixels before it runs.
layout(early_fragment_tests) in;

layout(location = 0) in vec2 v_ndc;
layout(location = 1) flat in uint v_view;
layout(location = 0) out vec4 out_color;

void main() {
    uint view = v_view + pc.view_offset;
    vec4 t = frame.tangents[view];
    // NDC x in [-1,1] spans tan(left)..tan(right); Vulkan NDC y points down,
    // so y = -1 is tan(up).
    float tx = mix(t.x, t.y, v_ndc.x * 0.5 + 0.5);
    float ty = mix(t.z, t.w, v_ndc.y * 0.5 + 0.5);
    vec3 dir = normalize(mat3(frame.eye_rot[view]) * vec3(tx, ty, -1.0));
    vec3 sky = mix(frame.sky_horizon.rgb, frame.sky_zenith.rgb, pow(clamp(dir.y, 0.0, 1.0), 0.5));
    vec3 color = dir.y >= 0.0 ? sky : mix(frame.sky_horizon.rgb, frame.ground.rgb, clamp(-dir.y * 8.0, 0.0, 1.0));
    float sun = smoothstep(0.9995, 0.9998, dot(dir, normalize(frame.sun_dir.xyz)));
    out_color = vec4(color + sun * frame.sun_color.rgb, 1.0);
}
