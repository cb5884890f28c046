#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Radial density masking (Vlachos, "Advanced VR Rendering Performance",
// GDC 2016): outside an NDC radius, every other 2×2 pixel quad in a
// checkerboard is written to stencil (bit 1) so the scene skips it; the fill
// pass reconstructs those quads from their neighbours. The radius arrives as
// float bits in pc.unused1. Colour writes are off; only stencil is written.
layout(location = 0) in vec2 v_ndc;
layout(location = 1) flat in uint v_view;
layout(location = 0) out vec4 out_color;
void main() {
    ivec2 quad = ivec2(gl_FragCoord.xy) >> 1;
    bool checker = ((quad.x + quad.y) & 1) == 1;
    if (!checker || length(v_ndc) < uintBitsToFloat(pc.unused1)) discard;
    out_color = vec4(float(v_view));
}
