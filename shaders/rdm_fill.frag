#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Radial density masking reconstruction: a quad skipped by rdm.frag takes
// the mean of the four quads around it (2 pixels left, right, up, down, all
// rendered under the checkerboard; at the border the other side's twice). Every texel fetch happens before the
// select, outside any branch. The rendered frame is array element
// pc.view_offset (the attachment set), layer gl_ViewIndex; the size drawn
// this frame (within the image: adaptive quality draws from its top-left
// corner) arrives packed in pc.unused0 (width | height << 16), the radius
// as float bits in pc.unused1. Drawn with the output-free full-screen
// triangle of floor.vert.
layout(set = 0, binding = 6) uniform sampler2DArray frames[2];
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int layer = int(gl_ViewIndex);
    ivec2 hi = ivec2(pc.unused0 & 0xffffu, pc.unused0 >> 16) - 1;
    vec4 c = texelFetch(frames[pc.view_offset], ivec3(p, layer), 0);
    // At the drawn area's edge the neighbour past it is replaced by the
    // one on the other side (also a rendered quad), so a skipped quad on
    // the border is not darkened by its own unrendered pixels.
    ivec2 lo = ivec2(p.x - 2 >= 0 ? p.x - 2 : p.x + 2, p.y - 2 >= 0 ? p.y - 2 : p.y + 2);
    ivec2 up = ivec2(p.x + 2 <= hi.x ? p.x + 2 : p.x - 2, p.y + 2 <= hi.y ? p.y + 2 : p.y - 2);
    lo = clamp(lo, ivec2(0), hi);
    up = clamp(up, ivec2(0), hi);
    vec4 l = texelFetch(frames[pc.view_offset], ivec3(lo.x, p.y, layer), 0);
    vec4 r = texelFetch(frames[pc.view_offset], ivec3(up.x, p.y, layer), 0);
    vec4 u = texelFetch(frames[pc.view_offset], ivec3(p.x, lo.y, layer), 0);
    vec4 d = texelFetch(frames[pc.view_offset], ivec3(p.x, up.y, layer), 0);
    bool skipped = rdm_skipped(gl_FragCoord.xy, vec2(hi + 1), uintBitsToFloat(pc.unused1));
    out_color = skipped ? (l + r + u + d) * 0.25 : c;
}
