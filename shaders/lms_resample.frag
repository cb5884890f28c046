#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// Lens-matched shading's resample (src/view/lms.rs): each pixel of the
// rectilinear eye image reads the LMS image where its NDC point landed,
// (x, y) / (1 + a|x| + b|y|) with the side coefficients of its quadrant,
// bilinearly. The coefficients come packed as 16-bit counts of 1/1024
// (left | right << 16 in pc.material, up | down << 16 in pc.unused0), the
// LMS pixel of NDC (0, 0) as x | y << 16 in pc.unused1, the eye image's
// size as specialization constants. The LMS frames are array element
// pc.view_offset (the attachment set), layer gl_ViewIndex. Drawn with the
// output-free full-screen triangle of floor.vert.
layout(set = 0, binding = 7) uniform sampler2DArray lms_frames[2];
layout(location = 0) out vec4 out_color;
layout(constant_id = 0) const uint EYE_WIDTH = 1;
layout(constant_id = 1) const uint EYE_HEIGHT = 1;
void main() {
    uint set = pc.view_offset;
    vec2 eye = vec2(float(EYE_WIDTH), float(EYE_HEIGHT));
    vec2 ndc = gl_FragCoord.xy / eye * 2.0 - 1.0;
    const float quantum = 1.0 / 1024.0;
    float a = float(ndc.x < 0.0 ? pc.material & 0xffffu : pc.material >> 16) * quantum;
    float b = float(ndc.y < 0.0 ? pc.unused0 & 0xffffu : pc.unused0 >> 16) * quantum;
    float d = 1.0 + a * abs(ndc.x) + b * abs(ndc.y);
    // Nothing was drawn beyond the eye's frustum (eye NDC ±1), so the
    // bilinear footprint (half an LMS pixel each way, up to D² eye pixels
    // there) is kept inside it: the outermost pixels repeat inwards.
    vec2 margin = d * d / eye;
    ndc = clamp(ndc, margin - 1.0, 1.0 - margin);
    d = 1.0 + a * abs(ndc.x) + b * abs(ndc.y);
    vec2 lms = ndc / d;
    vec2 centre = vec2(float(pc.unused1 & 0xffffu), float(pc.unused1 >> 16));
    vec2 pixel = centre + lms * eye * 0.5;
    vec2 size = vec2(textureSize(lms_frames[set], 0).xy);
    out_color = texture(lms_frames[set], vec3(pixel / size, float(gl_ViewIndex)));
}
