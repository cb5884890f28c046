// Level 0 of the depth pyramid (src/cull/hiz.rs): texel (x, y) of eye z is
// the minimum (reverse-Z: the farthest depth) over pixels 2x..2x+1,
// 2y..2y+1, clamped at the image edge, and over every sample. Included by
// hiz_init.comp (one sample) and hiz_init_ms.comp (MSAA) with MS set.

layout(local_size_x = 8, local_size_y = 8) in;

#if MS
layout(set = 0, binding = 0) uniform sampler2DMSArray depth_image[2];
#else
layout(set = 0, binding = 0) uniform sampler2DArray depth_image[2];
#endif
layout(std430, set = 0, binding = 1) writeonly buffer Pyramid { float texel[]; };

layout(push_constant) uniform Push {
    uvec4 image;   // width, height, samples, 1 when both eyes share one 2-layer image
    uvec4 level;   // width, height, eye stride (texels), unused
} pc;

float fetch(uint eye, ivec2 p, int s) {
    // Constant indices into the sampler array (no dynamic indexing needed).
    int layer = pc.image.w == 1u ? int(eye) : 0;
#if MS
    return eye == 0u ? texelFetch(depth_image[0], ivec3(p, layer), s).r
                     : texelFetch(depth_image[1], ivec3(p, layer), s).r;
#else
    return eye == 0u ? texelFetch(depth_image[0], ivec3(p, layer), 0).r
                     : texelFetch(depth_image[1], ivec3(p, layer), 0).r;
#endif
}

void main() {
    uvec3 t = gl_GlobalInvocationID;
    if (t.x >= pc.level.x || t.y >= pc.level.y) {
        return;
    }
    ivec2 last = ivec2(pc.image.xy) - 1;
    float m = uintBitsToFloat(0x7f800000u);
    for (int sy = 0; sy < 2; ++sy) {
        for (int sx = 0; sx < 2; ++sx) {
            ivec2 p = min(ivec2(t.xy) * 2 + ivec2(sx, sy), last);
            for (int s = 0; s < int(pc.image.z); ++s) {
                m = min(m, fetch(t.z, p, s));
            }
        }
    }
    texel[t.z * pc.level.z + t.y * pc.level.x + t.x] = m;
}
