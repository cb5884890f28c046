#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Multi-resolution foveated rendering's composite (src/view/inset.rs): the
// eye pixel takes the wide view, bilinearly upsampled from its lower
// resolution at the same image position, and inside the inset rectangle
// the full-density inset, fading over `feather` pixels inside its edge
// (the same weight as view::inset::weight). The frames are array element
// pc.view_offset (the attachment set), layer gl_ViewIndex. The rectangle
// comes packed: x0 | y0 << 16 in pc.material, x1 | y1 << 16 in
// pc.unused0; the feather as float bits in pc.unused1. Drawn with the
// output-free full-screen triangle of floor.vert.
layout(set = 0, binding = 6) uniform sampler2DArray inset_frames[2];
layout(set = 0, binding = 7) uniform sampler2DArray wide_frames[2];
layout(location = 0) out vec4 out_color;
void main() {
    uint set = pc.view_offset;
    float layer = float(gl_ViewIndex);
    vec2 size = vec2(textureSize(inset_frames[set], 0).xy);
    vec4 wide = texture(wide_frames[set], vec3(gl_FragCoord.xy / size, layer));
    vec4 inset = texelFetch(inset_frames[set], ivec3(ivec2(gl_FragCoord.xy), int(gl_ViewIndex)), 0);
    vec2 lo = vec2(float(pc.material & 0xffffu), float(pc.material >> 16));
    vec2 hi = vec2(float(pc.unused0 & 0xffffu), float(pc.unused0 >> 16));
    vec2 p = gl_FragCoord.xy;
    float d = min(min(p.x - lo.x, hi.x - p.x), min(p.y - lo.y, hi.y - p.y));
    float w = clamp(d / max(uintBitsToFloat(pc.unused1), 1e-6), 0.0, 1.0);
    // Outside the rectangle the inset image was never drawn: select, do not
    // blend, so nothing of it reaches the pixel.
    out_color = w > 0.0 ? mix(wide, inset, w) : wide;
}
