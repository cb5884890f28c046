#version 450
#extension GL_EXT_multiview : require
// The point-list fallback of the point rasterizer (src/render/passes/points.rs),
// for devices without 64-bit buffer atomics, or with `--opt points-pipeline`:
// each point a one-pixel POINT_LIST primitive drawn inside the forward
// scope, its depth tested and written like the meshes'. The vertex is the
// point's offset from the cloud's origin and its sRGB colour's bits.

// The prefix of the frame uniforms (shaders/common.glsl's FrameData).
layout(std140, set = 0, binding = 0) uniform FrameData { mat4 view_proj[4]; } frame;

// offset: the cloud's origin relative to the render origin; view_offset:
// added to gl_ViewIndex (the eye in two-pass); the image's size.
layout(push_constant) uniform Push { vec4 offset; uint view_offset; uint width; uint height; } pc;

layout(location = 0) in vec4 point;
layout(location = 0) flat out vec4 v_color;

void main() {
    uint view = gl_ViewIndex + pc.view_offset;
    vec4 c = frame.view_proj[view] * vec4(pc.offset.xyz + point.xyz, 1.0);
    // Moved to the centre of its pixel, the one-pixel point square covers
    // that pixel exactly — every MSAA sample of it, as the compute path
    // writes — instead of parts of up to four.
    if (c.w > 0.0) {
        vec2 size = vec2(float(pc.width), float(pc.height));
        vec2 px = floor((c.xy / c.w * 0.5 + 0.5) * size) + 0.5;
        c.xy = (px / size * 2.0 - 1.0) * c.w;
    }
    gl_Position = c;
    gl_PointSize = 1.0;
    vec3 srgb = unpackUnorm4x8(floatBitsToUint(point.w)).rgb;
    vec3 lo = srgb / 12.92;
    vec3 hi = pow((srgb + 0.055) / 1.055, vec3(2.4));
    v_color = vec4(mix(hi, lo, lessThanEqual(srgb, vec3(0.04045))), 1.0);
}
