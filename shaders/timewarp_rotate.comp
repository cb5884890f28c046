#version 450
#extension GL_GOOGLE_include_directive : require
#include "timewarp.glsl"
// Rotation-only timewarp: each new pixel looks up where the rotation-only
// map sends it in the old image (a homography, depth not needed) and takes
// the bilinear sample there; outside the old image it is black (border).
vec4 unpack(uint c) {
    return vec4(c & 0xFFu, (c >> 8) & 0xFFu, (c >> 16) & 0xFFu, c >> 24);
}

vec4 texel(ivec2 q) {
    q = clamp(q, ivec2(0), ivec2(pc.size) - 1);
    return unpack(src_colour[pixel_index(uvec2(q))]);
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, pc.size))) {
        return;
    }
    uint i = pixel_index(p);
    vec4 s = rotation_inverse[pc.eye] * vec4(ndc_of(p), 0.0, 1.0);
    vec2 src = s.xy / s.w;
    if (s.w <= 0.0 || any(greaterThan(abs(src), vec2(1.0)))) {
        out_colour[i] = 0xFF000000u;
        atomicAdd(counters[pc.eye * 3u + 1u], 1u);
        return;
    }
    vec2 f = (src * 0.5 + 0.5) * vec2(pc.size) - 0.5;
    ivec2 b = ivec2(floor(f));
    vec2 w = f - vec2(b);
    vec4 c = mix(mix(texel(b), texel(b + ivec2(1, 0)), w.x),
                 mix(texel(b + ivec2(0, 1)), texel(b + ivec2(1, 1)), w.x), w.y);
    uvec4 u = uvec4(round(c));
    out_colour[i] = u.x | (u.y << 8) | (u.z << 16) | (u.w << 24);
}
