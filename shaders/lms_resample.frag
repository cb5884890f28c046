#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Lens-matched shading's resample (src/view/lms.rs): each pixel of the
// rectilinear eye image reads the LMS image where its NDC point landed,
// (x, y) / (1 + a|x| + b|y|) with the side coefficients of its quadrant,
// bilinearly. The coefficients come packed as 16-bit counts of 1/1024
// (left | right << 16 in pc.material, up | down << 16 in pc.unused0), the
// eye image's size drawn this frame (adaptive quality's) as
// width | height << 16 in pc.unused1. The LMS pixel of NDC (0, 0) is
// Layout::new's ceil((size / 2) / (1 + k)) for the left and up sides, here
// in integers: ceil(size * 512 / (1024 + count)). The LMS frames are array
// element pc.view_offset (the attachment set), layer gl_ViewIndex; the LMS
// image lies in their top-left part. Drawn with the output-free full-screen
// triangle of floor.vert.
layout(set = 0, binding = 7) uniform sampler2DArray lms_frames[2];
layout(location = 0) out vec4 out_color;
void main() {
    uint set = pc.view_offset;
    uvec2 eye_size = uvec2(pc.unused1 & 0xffffu, pc.unused1 >> 16);
    vec2 eye = vec2(eye_size);
    vec2 ndc = gl_FragCoord.xy / eye * 2.0 - 1.0;
    const float quantum = 1.0 / 1024.0;
    uvec2 low = uvec2(pc.material & 0xffffu, pc.unused0 & 0xffffu);
    uvec2 high = uvec2(pc.material >> 16, pc.unused0 >> 16);
    // The side coefficients: left, right (x); up, down (y).
    vec2 lo_k = vec2(low) * quantum;
    vec2 hi_k = vec2(high) * quantum;
    float a = ndc.x < 0.0 ? lo_k.x : hi_k.x;
    float b = ndc.y < 0.0 ? lo_k.y : hi_k.y;
    float d = 1.0 + a * abs(ndc.x) + b * abs(ndc.y);
    vec2 lms = ndc / d;
    uvec2 den = 1024u + low;
    uvec2 centre = (eye_size * 512u + den - 1u) / den;
    vec2 pixel = vec2(centre) + lms * eye * 0.5;
    // Only the LMS image inside the eye's frustum (eye NDC ±1) was drawn,
    // and a pixel the frustum's edge crosses has uncovered samples. Along
    // x, this row's edges x = ±1 land at LMS NDC ±1 / (1 + a + b|y|)
    // (src/view/lms.rs, forward); the bilinear footprint is kept between
    // the centres of the outermost pixels wholly inside them (those
    // repeat outwards), and along y likewise.
    vec2 edge_lo = -1.0 / (1.0 + lo_k + vec2(b * abs(ndc.y), a * abs(ndc.x)));
    vec2 edge_hi = 1.0 / (1.0 + hi_k + vec2(b * abs(ndc.y), a * abs(ndc.x)));
    vec2 first = ceil(vec2(centre) + edge_lo * eye * 0.5) + 0.5;
    vec2 last = floor(vec2(centre) + edge_hi * eye * 0.5) - 0.5;
    pixel = clamp(pixel, first, max(first, last));
    // The sampler's bilinear read: one fetch, where reading the four
    // texels by hand (bilinear.glsl) costs more than the LMS image saves
    // on a raster-bound GPU. Its sub-texel rounding follows the targets'
    // size, so a frame drawn in part of larger targets (aq) may differ by
    // a code value at a few pixels.
    vec2 size = vec2(textureSize(lms_frames[set], 0).xy);
    out_color = texture(lms_frames[set], vec3(pixel / size, float(gl_ViewIndex)));
}
