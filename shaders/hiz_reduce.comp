#version 450
// One level of the depth pyramid from the one before (src/cull/hiz.rs):
// texel (x, y) of eye z is the minimum (reverse-Z: the farthest depth) of
// source texels 2x..2x+1, 2y..2y+1, clamped at the source's edge, so odd
// sizes lose nothing.

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 1) buffer Pyramid { float texel[]; };

layout(push_constant) uniform Push {
    uvec4 src;  // width, height, offset, eye stride (texels)
    uvec4 dst;  // width, height, offset, unused
} pc;

void main() {
    uvec3 t = gl_GlobalInvocationID;
    if (t.x >= pc.dst.x || t.y >= pc.dst.y) {
        return;
    }
    uint eye = t.z * pc.src.w;
    uvec2 last = pc.src.xy - 1u;
    float m = uintBitsToFloat(0x7f800000u);
    for (uint sy = 0u; sy < 2u; ++sy) {
        for (uint sx = 0u; sx < 2u; ++sx) {
            uvec2 p = min(t.xy * 2u + uvec2(sx, sy), last);
            m = min(m, texel[eye + pc.src.z + p.y * pc.src.x + p.x]);
        }
    }
    texel[eye + pc.dst.z + t.y * pc.dst.x + t.x] = m;
}
