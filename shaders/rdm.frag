#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Radial density masking (Vlachos, "Advanced VR Rendering Performance",
// GDC 2016): outside an NDC radius, every other 2×2 pixel quad in a
// checkerboard is written to stencil (bit 1) so the scene skips it; the fill
// pass reconstructs those quads from their neighbours. Drawn with the
// full-screen triangle of floor.vert; the image size arrives packed in
// pc.unused0 (width | height << 16), the radius as float bits in
// pc.unused1. Colour writes are off; only stencil is written.
layout(location = 0) out vec4 out_color;
void main() {
    vec2 size = vec2(pc.unused0 & 0xffffu, pc.unused0 >> 16);
    if (!rdm_skipped(gl_FragCoord.xy, size, uintBitsToFloat(pc.unused1))) discard;
    out_color = vec4(0.0);
}
