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
// width | height << 16 in pc.unused1, and the LMS frames' array element
// with the LMS pixel of NDC (0, 0) (Layout::centre) as
// set | x << 1 | y << 16 in pc.view_offset. The LMS frames are layer
// gl_ViewIndex of that element; the LMS image lies in their top-left part.
// Drawn with the output-free full-screen triangle of floor.vert.
layout(set = 0, binding = 7) uniform sampler2DArray lms_frames[2];
layout(location = 0) out vec4 out_color;
void main() {
    uint set = pc.view_offset & 1u;
    vec2 centre = vec2(float((pc.view_offset >> 1) & 0x7fffu), float(pc.view_offset >> 16));
    uvec2 eye_size = uvec2(pc.unused1 & 0xffffu, pc.unused1 >> 16);
    vec2 eye = vec2(eye_size);
    vec2 ndc = gl_FragCoord.xy / eye * 2.0 - 1.0;
    const float quantum = 1.0 / 1024.0;
    // The side coefficients: left, up (low); right, down (high).
    vec2 lo_k = vec2(float(pc.material & 0xffffu), float(pc.unused0 & 0xffffu)) * quantum;
    vec2 hi_k = vec2(float(pc.material >> 16), float(pc.unused0 >> 16)) * quantum;
    vec2 k = vec2(ndc.x < 0.0 ? lo_k.x : hi_k.x, ndc.y < 0.0 ? lo_k.y : hi_k.y);
    float d = 1.0 + k.x * abs(ndc.x) + k.y * abs(ndc.y);
    vec2 pixel = centre + ndc / d * eye * 0.5;
    // Only the LMS image inside the eye's frustum (eye NDC ±1) was drawn,
    // and a pixel the frustum's edge crosses has uncovered samples. The
    // bilinear footprint is kept between the centres of the outermost
    // pixels wholly inside it (those repeat outwards). Away from the edge
    // the clamp changes nothing: an eye NDC step of s moves the LMS point
    // by at least s / D² (D ≤ 1 + a + b), so points farther than four LMS
    // pixels' worth, 4 D² eye pixels, from the edge skip it.
    float dmax = 1.0 + k.x + k.y;
    vec2 reach = 8.0 * dmax * dmax / eye;
    if (any(greaterThan(abs(ndc), 1.0 - reach))) {
        // Along x, this row's edges x = ±1 land at LMS NDC
        // ±1 / (1 + a + b|y|) (src/view/lms.rs, forward), along y likewise.
        vec2 across = vec2(k.y * abs(ndc.y), k.x * abs(ndc.x));
        vec2 edge_lo = -1.0 / (1.0 + lo_k + across);
        vec2 edge_hi = 1.0 / (1.0 + hi_k + across);
        vec2 first = ceil(centre + edge_lo * eye * 0.5) + 0.5;
        vec2 last = floor(centre + edge_hi * eye * 0.5) - 0.5;
        pixel = clamp(pixel, first, max(first, last));
    }
    // The sampler's bilinear read: one fetch, where reading the four
    // texels by hand (bilinear.glsl) costs more than the LMS image saves
    // on a raster-bound GPU. Its sub-texel rounding follows the targets'
    // size, so a frame drawn in part of larger targets (aq) may differ by
    // a code value at a few pixels.
    vec2 size = vec2(textureSize(lms_frames[set], 0).xy);
    out_color = texture(lms_frames[set], vec3(pixel / size, float(gl_ViewIndex)));
}
