#version 450
#extension GL_GOOGLE_include_directive : require
#include "timewarp.glsl"
// After the scatter, per target pixel nothing landed on:
// - border: the rotation-only map sends it outside the old image (nothing
//   there was rendered): black, counted;
// - crack: both neighbours on one axis were hit at depths within 10 %, or
//   at least two of its 3x3 neighbours were, all within 10 % of each other
//   (the old image was sampled sparser than the new one there, no depth
//   edge): their mean, counted;
// - hole: a disocclusion, next to a depth edge: counted; mode 1 fills it
//   with the farthest (background) hit found along the four axes within
//   8 pixels, mode 0 leaves it black.
const uint BLACK = 0xFF000000u;

bool hit(ivec2 q, out float depth) {
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(pc.size)))) {
        depth = 0.0;
        return false;
    }
    uint k = keys[pixel_index(uvec2(q))];
    depth = k == 0u ? 0.0 : uintBitsToFloat(k - 1u);
    return k != 0u;
}


bool close_depths(float a, float b) {
    return abs(a - b) <= 0.1 * max(a, b);
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, pc.size))) {
        return;
    }
    uint i = pixel_index(p);
    if (keys[i] != 0u) {
        return;
    }
    vec4 s = rotation_inverse[pc.eye] * vec4(ndc_of(p), 0.0, 1.0);
    vec2 src = s.xy / s.w;
    if (s.w <= 0.0 || any(greaterThan(abs(src), vec2(1.0)))) {
        out_colour[i] = BLACK;
        atomicAdd(counters[pc.eye * 3u + 1u], 1u);
        return;
    }
    ivec2 q = ivec2(p);
    float dl, dr, du, dd;
    bool across = hit(q + ivec2(-1, 0), dl) && hit(q + ivec2(1, 0), dr) && close_depths(dl, dr);
    bool along = hit(q + ivec2(0, -1), du) && hit(q + ivec2(0, 1), dd) && close_depths(du, dd);
    uint count = 0u;
    float lo = 2.0, hi = -1.0;
    uvec4 sum = uvec4(0u);
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            float depth;
            ivec2 n = q + ivec2(dx, dy);
            if (hit(n, depth)) {
                uint c = out_colour[pixel_index(uvec2(n))];
                sum += uvec4(c, c >> 8, c >> 16, c >> 24) & 0xFFu;
                lo = min(lo, depth);
                hi = max(hi, depth);
                count++;
            }
        }
    }
    if (across || along || (count >= 2u && close_depths(lo, hi))) {
        // The mean of the pair that qualified, else of the window.
        if (across || along) {
            ivec2 a = across ? ivec2(-1, 0) : ivec2(0, -1);
            uint c0 = out_colour[pixel_index(uvec2(q + a))];
            uint c1 = out_colour[pixel_index(uvec2(q - a))];
            sum = (uvec4(c0, c0 >> 8, c0 >> 16, c0 >> 24) & 0xFFu) + (uvec4(c1, c1 >> 8, c1 >> 16, c1 >> 24) & 0xFFu);
            count = 2u;
        }
        uvec4 m = (sum + count / 2u) / count;
        out_colour[i] = m.x | (m.y << 8) | (m.z << 16) | (m.w << 24);
        atomicAdd(counters[pc.eye * 3u + 2u], 1u);
        return;
    }
    atomicAdd(counters[pc.eye * 3u], 1u);
    if (pc.mode == 0u) {
        out_colour[i] = BLACK;
        return;
    }
    ivec2 dirs[4] = ivec2[4](ivec2(-1, 0), ivec2(1, 0), ivec2(0, -1), ivec2(0, 1));
    float best_depth = 2.0;
    uint best = BLACK;
    for (int k = 0; k < 4; k++) {
        for (int step = 1; step <= 8; step++) {
            ivec2 n = q + dirs[k] * step;
            float depth;
            if (hit(n, depth)) {
                if (depth < best_depth) {
                    best_depth = depth;
                    best = out_colour[pixel_index(uvec2(n))];
                }
                break;
            }
        }
    }
    out_colour[i] = best;
}
