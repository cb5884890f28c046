#version 450
#extension GL_GOOGLE_include_directive : require
#include "srgb.glsl"
#include "rdm.glsl"
// Radial density masking's fill in place (src/render/passes/rdm_in_place.rs):
// in the inset's wide views and in lens-matched shading's image, which are
// read by later passes, the skipped quads are filled in the resolved image
// itself. Each skipped pixel takes the mean of the pixels two to its left,
// right, top and bottom (as rdm_fill.frag: mirrored at the drawn area's
// edge), averaged in linear light (decoded from and encoded back to sRGB:
// the image is read and written through its UNORM view). Those neighbours
// lie in rendered quads, which no invocation writes, so reading and
// writing the one image is race-free. One invocation per pixel of layer
// gl_GlobalInvocationID.z of attachment set pc.set, over the drawn size.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0, rgba8) uniform image2DArray frames[2];

layout(push_constant) uniform Push {
    uint size;    // the drawn size, width | height << 16
    float radius; // NDC radius
    uint set;     // attachment set (0 or 1)
    uint unused;
} pc;

vec4 linear_at(ivec2 p, int layer) {
    vec4 e = imageLoad(frames[pc.set], ivec3(p, layer));
    return vec4(decode_srgb(e.rgb), e.a);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int layer = int(gl_GlobalInvocationID.z);
    ivec2 hi = ivec2(pc.size & 0xffffu, pc.size >> 16) - 1;
    if (p.x > hi.x || p.y > hi.y || !rdm_skipped(vec2(p) + 0.5, vec2(hi + 1), pc.radius)) {
        return;
    }
    ivec2 lo = ivec2(p.x - 2 >= 0 ? p.x - 2 : p.x + 2, p.y - 2 >= 0 ? p.y - 2 : p.y + 2);
    ivec2 up = ivec2(p.x + 2 <= hi.x ? p.x + 2 : p.x - 2, p.y + 2 <= hi.y ? p.y + 2 : p.y - 2);
    lo = clamp(lo, ivec2(0), hi);
    up = clamp(up, ivec2(0), hi);
    vec4 sum = linear_at(ivec2(lo.x, p.y), layer) + linear_at(ivec2(up.x, p.y), layer)
        + linear_at(ivec2(p.x, lo.y), layer) + linear_at(ivec2(p.x, up.y), layer);
    vec4 c = sum * 0.25;
    imageStore(frames[pc.set], ivec3(p, layer), vec4(encode_srgb(c.rgb), c.a));
}
