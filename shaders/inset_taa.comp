#version 450
#extension GL_GOOGLE_include_directive : require
#include "taa.glsl"
// Temporal anti-aliasing of the inset's wide views (src/view/taa.rs has
// the derivation and the CPU model this follows;
// src/render/passes/inset_taa.rs records it). One invocation per pixel of
// one layer (one eye) of one wide attachment set: the current frame's
// jittered colour (linear: the sampler decodes sRGB), its 3x3
// neighbourhood's box in YCoCg, the history read where the pixel's
// surface point lay in the previous frame (its NDC and stored depth
// carried by pc.to_previous, view::reproject::reprojection from the
// current to the previous view, Catmull-Rom filtered), clamped to the
// box, and the blend
// history + alpha (current - history) stored into this frame's history
// layer, which the composite then reads as the wide view.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0) uniform sampler2DArray current[2];
layout(set = 0, binding = 1) uniform sampler2DArray depth[2];
layout(set = 0, binding = 2) uniform sampler2DArray history[2];
layout(set = 0, binding = 3, rgba16f) uniform writeonly image2DArray next[2];

layout(push_constant) uniform Push {
    mat4 to_previous; // current (NDC x, NDC y, depth, 1) -> previous clip
    uint size;        // the wide view's drawn size, width | height << 16
    uint set;         // wide attachment set (0 or 1)
    uint layer;       // the set's layer (the eye under multiview)
    uint read_layer;  // the history layer of the previous frame
    uint write_layer; // the history layer this frame writes
    uint valid;       // 1: the previous frame's history may be read
    float alpha;      // the current frame's weight
    float jitter_x;   // this frame's viewport offset, pixels (two
    float jitter_y;   // floats: a vec2 would be aligned past word 23)
} pc;

// The variance box's half-width in standard deviations
// (view::taa::VARIANCE_GAMMA).
const float GAMMA = 1.25;

// The image at pixel position `at` (pixel units, centres at + 0.5) of
// layer `layer`, Catmull-Rom filtered over the 4x4 texels around it
// (weights as view::taa::catmull_rom_weights; texels clamped to the
// view's `size`): the history where the pixel was (a bilinear read each
// frame would blur it a little more with every fractional move), and the
// current frame where the unjittered pixel centre lies.
vec3 filtered(sampler2DArray hist, vec2 at, ivec2 size, int layer) {
    vec2 t = at - 0.5;
    vec2 f = fract(t);
    ivec2 base = ivec2(floor(t)) - 1;
    vec2 w[4];
    catmull_rom_weights(f, w);
    vec3 sum = vec3(0.0);
    for (int j = 0; j < 4; j++) {
        for (int i = 0; i < 4; i++) {
            ivec2 q = clamp(base + ivec2(i, j), ivec2(0), size - 1);
            sum += w[i].x * w[j].y * texelFetch(hist, ivec3(q, layer), 0).rgb;
        }
    }
    return max(sum, vec3(0.0));
}

vec4 resolve(sampler2DArray cur, sampler2DArray dep, sampler2DArray hist, ivec2 p, ivec2 size) {
    // The current frame at the pixel's centre: the viewport moved the
    // image by the jitter, so the centre's scene point lies at + jitter.
    vec4 c = vec4(filtered(cur, vec2(p) + 0.5 + vec2(pc.jitter_x, pc.jitter_y), size, int(pc.layer)),
                  texelFetch(cur, ivec3(p, int(pc.layer)), 0).a);
    if (pc.valid == 0u) {
        return c;
    }
    // The neighbourhood's box (the pixel included, texels clamped to the
    // view): its extremes, narrowed to mean +- GAMMA standard deviations
    // (variance clipping), and its nearest depth (reverse-Z: the largest),
    // whose surface the pixel is reprojected with.
    vec3 lo = vec3(1e30);
    vec3 hi = vec3(-1e30);
    vec3 m1 = vec3(0.0);
    vec3 m2 = vec3(0.0);
    float z = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec3 q = ivec3(clamp(p + ivec2(dx, dy), ivec2(0), size - 1), int(pc.layer));
            vec3 y = to_ycocg(texelFetch(cur, q, 0).rgb);
            lo = min(lo, y);
            hi = max(hi, y);
            m1 += y;
            m2 += y * y;
            z = max(z, texelFetch(dep, q, 0).r);
        }
    }
    vec3 mean = m1 / 9.0;
    vec3 sigma = sqrt(max(m2 / 9.0 - mean * mean, vec3(0.0)));
    // Narrowed, but never past the pixel's own colour: a thin feature
    // whose pixel lies outside its neighbourhood's spread is kept.
    vec3 own = to_ycocg(c.rgb);
    lo = min(max(lo, mean - GAMMA * sigma), own);
    hi = max(min(hi, mean + GAMMA * sigma), own);
    vec2 fsize = vec2(size);
    vec2 ndc = (vec2(p) + 0.5) / fsize * 2.0 - 1.0;
    vec4 prev = pc.to_previous * vec4(ndc, z, 1.0);
    // Behind the previous eye, or off its view: no history.
    if (prev.w <= 0.0) {
        return c;
    }
    vec2 at = (prev.xy / prev.w * 0.5 + 0.5) * fsize;
    if (any(lessThan(at, vec2(0.0))) || any(greaterThan(at, fsize))) {
        return c;
    }
    vec3 h = filtered(hist, at, size, int(pc.read_layer));
    h = from_ycocg(clamp(to_ycocg(h), lo, hi));
    return vec4(h + pc.alpha * (c.rgb - h), c.a);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(int(pc.size & 0xffffu), int(pc.size >> 16));
    if (p.x >= size.x || p.y >= size.y) {
        return;
    }
    // Constant indices into the arrays (no dynamic indexing needed).
    ivec3 o = ivec3(p, int(pc.write_layer));
    if (pc.set == 0u) {
        imageStore(next[0], o, resolve(current[0], depth[0], history[0], p, size));
    } else {
        imageStore(next[1], o, resolve(current[1], depth[1], history[1], p, size));
    }
}
