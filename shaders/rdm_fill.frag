#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Radial density masking reconstruction: a quad skipped by rdm.frag takes
// the mean of the four quads around it (2 pixels left, right, up, down, all
// rendered under the checkerboard). Every texel fetch happens before the
// select, outside any branch. The rendered frame is array element
// pc.view_offset (the attachment set), layer gl_ViewIndex. Drawn with the
// output-free full-screen triangle of floor.vert.
layout(set = 0, binding = 6) uniform sampler2DArray frames[2];
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int layer = int(gl_ViewIndex);
    ivec2 hi = textureSize(frames[pc.view_offset], 0).xy - 1;
    vec4 c = texelFetch(frames[pc.view_offset], ivec3(p, layer), 0);
    vec4 l = texelFetch(frames[pc.view_offset], ivec3(clamp(p + ivec2(-2, 0), ivec2(0), hi), layer), 0);
    vec4 r = texelFetch(frames[pc.view_offset], ivec3(clamp(p + ivec2(2, 0), ivec2(0), hi), layer), 0);
    vec4 u = texelFetch(frames[pc.view_offset], ivec3(clamp(p + ivec2(0, -2), ivec2(0), hi), layer), 0);
    vec4 d = texelFetch(frames[pc.view_offset], ivec3(clamp(p + ivec2(0, 2), ivec2(0), hi), layer), 0);
    bool skipped = rdm_skipped(gl_FragCoord.xy, vec2(hi + 1), uintBitsToFloat(pc.unused1));
    out_color = skipped ? (l + r + u + d) * 0.25 : c;
}
