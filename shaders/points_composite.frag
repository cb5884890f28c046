#version 450
#extension GL_EXT_multiview : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// The point cloud's pixels into the forward scope (src/render/passes/points.rs):
// each pixel reads its key from the compute rasterizer; an empty one is
// discarded, else the point's colour is written with its depth, so the
// depth test (reverse-Z GREATER) composites points and meshes whichever is
// nearer, at every MSAA sample of the pixel (the point is resolved at one
// sample and merged). The image's width and height come in pc.unused0/1;
// the view is gl_ViewIndex + pc.view_offset. Drawn with the output-free
// full-screen triangle of floor.vert.
layout(std430, set = 0, binding = 8) readonly buffer PointKeys { uint64_t point_keys[]; };
layout(location = 0) out vec4 out_color;
void main() {
    uvec2 px = uvec2(gl_FragCoord.xy);
    uint view = gl_ViewIndex + pc.view_offset;
    uint64_t key = point_keys[(view * pc.unused1 + px.y) * pc.unused0 + px.x];
    if (key == 0ul) {
        discard;
    }
    vec3 srgb = unpackUnorm4x8(uint(key & 0xfffffffful)).rgb;
    // sRGB to linear (IEC 61966-2-1); the attachment encodes again.
    vec3 lo = srgb / 12.92;
    vec3 hi = pow((srgb + 0.055) / 1.055, vec3(2.4));
    out_color = vec4(mix(hi, lo, lessThanEqual(srgb, vec3(0.04045))), 1.0);
    gl_FragDepth = uintBitsToFloat(uint(key >> 32));
}
