#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "bilinear.glsl"
// Monoscopic far field: each eye pixel's ray (from the eye's FOV tangents
// and orientation) is looked up in the far-field image rendered once from
// the centre camera (view 2). Plain: the ray direction itself (exact for
// points at infinity). Depth shift (flag bit 0): the direction from the
// centre camera to the point at the split distance D along the eye's ray,
// so the far field sits at the disparity of D (exact for points at D).
// Alternate eye (flag bit 1): each eye has its own far image (view 2 + eye),
// rendered from that eye on alternate frames; otherwise both use view 2.
// D arrives as float bits in pc.unused1, the flags in pc.material, the
// part of the far image drawn (with aq) in pc.unused0.
layout(early_fragment_tests) in;
layout(set = 0, binding = 7) uniform sampler2D far_field[2];
layout(location = 0) in vec2 v_ndc;
layout(location = 1) flat in uint v_view;
layout(location = 0) out vec4 out_color;
void main() {
    uint view = v_view + pc.view_offset;
    vec4 t = frame.tangents[view];
    float tx = mix(t.x, t.y, v_ndc.x * 0.5 + 0.5);
    float ty = mix(t.z, t.w, v_ndc.y * 0.5 + 0.5);
    vec3 dir = normalize(mat3(frame.eye_rot[view]) * vec3(tx, ty, -1.0));
    float split = uintBitsToFloat(pc.unused1);
    uint image = (pc.material & 2u) != 0u ? view : 0u;
    uint far_view = 2u + image;
    vec3 shifted = frame.eye_rel[view].xyz - frame.eye_rel[far_view].xyz + split * dir;
    vec3 world = (pc.material & 1u) != 0u ? shifted : dir;
    vec3 c = transpose(mat3(frame.eye_rot[far_view])) * world;
    vec4 ft = frame.tangents[far_view];
    vec2 tan_c = c.xy / -c.z;
    vec2 uv = vec2((tan_c.x - ft.x) / (ft.y - ft.x), (tan_c.y - ft.z) / (ft.w - ft.z));
    // With aq the far image holds this frame's far field in its top-left
    // part (pc.unused0: width | height << 16; 0 when it fills the image):
    // read that part, clamped to its edge texels as the whole image is,
    // bilinearly in texel space (bilinear.glsl: the same at any image
    // size).
    ivec2 drawn = pc.unused0 != 0u
        ? ivec2(pc.unused0 & 0xffffu, pc.unused0 >> 16)
        : textureSize(far_field[image], 0);
    out_color = bilinear(far_field[image], uv * vec2(drawn), drawn);
}
