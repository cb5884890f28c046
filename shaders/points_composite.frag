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
//
// Eye-dome lighting (`--opt edl[=S]`; pc.material holds k = 300·S as float
// bits, 0: off), after Boucheny, "Interactive Scientific Visualization of
// Large Datasets" (PhD thesis, 2009), as Potree applies it to points: a
// pixel darkens by exp(−k · r), r the mean over its 8 neighbours (at one
// pixel) of max(0, log2 z − log2 z_n) for the neighbours holding a point,
// z the view depth — so a point just behind a nearer one's silhouette
// darkens and a surface facing the eye does not. With the infinite
// reverse-Z projection (src/view/projection.rs) the stored depth is
// d = near / z, so log2 z − log2 z_n = log2 d_n − log2 d: no matrix needed.
layout(std430, set = 0, binding = 8) readonly buffer PointKeys { uint64_t point_keys[]; };
layout(location = 0) out vec4 out_color;

uint64_t key_at(uint view, ivec2 p) {
    return point_keys[(view * pc.unused1 + uint(p.y)) * pc.unused0 + uint(p.x)];
}

float edl_shade(uint view, ivec2 px, float depth) {
    float k = uintBitsToFloat(pc.material);
    ivec2 size = ivec2(pc.unused0, pc.unused1);
    float sum = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 q = px + ivec2(dx, dy);
            if ((dx == 0 && dy == 0) || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) {
                continue;
            }
            uint64_t n = key_at(view, q);
            if (n != 0ul) {
                sum += max(0.0, log2(uintBitsToFloat(uint(n >> 32))) - log2(depth));
            }
        }
    }
    return exp(-k * sum / 8.0);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    uint view = gl_ViewIndex + pc.view_offset;
    uint64_t key = key_at(view, px);
    if (key == 0ul) {
        discard;
    }
    float depth = uintBitsToFloat(uint(key >> 32));
    vec3 srgb = unpackUnorm4x8(uint(key & 0xfffffffful)).rgb;
    // sRGB to linear (IEC 61966-2-1); the attachment encodes again.
    vec3 lo = srgb / 12.92;
    vec3 hi = pow((srgb + 0.055) / 1.055, vec3(2.4));
    vec3 linear = mix(hi, lo, lessThanEqual(srgb, vec3(0.04045)));
    if (pc.material != 0u) {
        linear *= edl_shade(view, px, depth);
    }
    out_color = vec4(linear, 1.0);
    gl_FragDepth = depth;
}
