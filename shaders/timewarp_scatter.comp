#version 450
#extension GL_GOOGLE_include_directive : require
#include "timewarp.glsl"
// Forward reprojection with depth: every old pixel is unprojected with its
// depth and projected into the new view; mode 0 keeps the nearest depth
// per target pixel (reverse-Z: the largest), mode 1 writes the colour of
// the pixel whose depth won.
void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, pc.size))) {
        return;
    }
    uint i = pixel_index(p);
    if (pc.mode == 1u) {
        uvec2 s = scatter[i];
        if (s.x != 0u && keys[s.x - 1u] == s.y) {
            out_colour[s.x - 1u] = src_colour[i];
        }
        return;
    }
    scatter[i] = uvec2(0u);
    vec4 c = reproject[pc.eye] * vec4(ndc_of(p), src_depth[i], 1.0);
    if (c.w <= 0.0) {
        return;
    }
    vec3 n = c.xyz / c.w;
    vec2 t = floor((n.xy * 0.5 + 0.5) * vec2(pc.size));
    if (any(lessThan(t, vec2(0.0))) || any(greaterThanEqual(t, vec2(pc.size)))) {
        return;
    }
    uint target = pixel_index(uvec2(t));
    // Sky (depth 0) may come out as -0.0, whose bits would win every max.
    uint key = floatBitsToUint(n.z > 0.0 ? n.z : 0.0) + 1u;
    scatter[i] = uvec2(target + 1u, key);
    atomicMax(keys[target], key);
}
