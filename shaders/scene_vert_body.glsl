// The scene's vertex shader body, shared by scene.vert (per-draw data in
// push constants), scene_ubo.vert and scene_ssbo.vert; each defines
// PER_DRAW before including it. Their *_clip.vert twins define SECTION 1
// and write the section plane's clip distance: an output the rasterizer
// clips against costs even when it never cuts (factory:1000000 on the
// H200: 45.6 ms without it, 77.3 ms with it), so frames without a plane use
// the variants without.
#ifndef SECTION
#define SECTION 0
#endif
#include "common.glsl"

layout(std430, set = 0, binding = 1) readonly buffer Instances { InstanceData instances[]; };
layout(std430, set = 0, binding = 2) readonly buffer Visible { uint visible[]; };

layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec4 in_tangent;
layout(location = 3) in vec2 in_uv0;
layout(location = 4) in vec2 in_uv1;
layout(location = 5) in vec4 in_color;

layout(location = 0) out vec3 v_pos;      // relative to the render origin
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec4 v_tangent;
layout(location = 3) out vec4 v_uv;
layout(location = 4) out vec4 v_color;
layout(location = 5) flat out uint v_material;

// Each draw's own data: its material, and where its instances start in the
// visible list. PER_DRAW 0 takes them from push constants (the instances
// start at the draw's firstInstance), 1 from a uniform buffer record the
// draw binds by dynamic offset, 2 from a storage buffer record indexed by
// the draw's firstInstance (gl_BaseInstance, SPIR-V DrawParameters).
#if PER_DRAW == 1
layout(std140, set = 1, binding = 0) uniform DrawRecord { uvec4 record; } draw;
#elif PER_DRAW == 2
layout(std430, set = 1, binding = 0) readonly buffer DrawRecords { uvec2 records[]; };
#endif

#if SECTION
out gl_PerVertex {
    vec4 gl_Position;
    float gl_ClipDistance[1];
};
#endif

void main() {
#if PER_DRAW == 0
    uint slot = gl_InstanceIndex;
    v_material = pc.material;
#elif PER_DRAW == 1
    uint slot = draw.record.y + gl_InstanceIndex;
    v_material = draw.record.x;
#else
    uvec2 record = records[gl_BaseInstanceARB];
    uint slot = record.y + (gl_InstanceIndex - gl_BaseInstanceARB);
    v_material = record.x;
#endif
    InstanceData inst = instances[visible[slot]];
    mat3 m = transpose(mat3(inst.row0.xyz, inst.row1.xyz, inst.row2.xyz));
    // Relative-to-eye translation from a two-float split (Ohlarik, "Precisions,
    // Precisions", 2008): the high parts cancel exactly, the low parts carry
    // the remainder, so positions far from the world origin keep precision.
    vec3 t_hi = vec3(inst.row0.w, inst.row1.w, inst.row2.w);
    vec3 t = (t_hi - frame.origin_hi.xyz) + (inst.trans_lo.xyz - frame.origin_lo.xyz);
    vec3 p = m * in_pos + t;
    // Normals transform by the cofactor matrix (inverse transpose up to the
    // determinant's scale, which the normalization removes).
    mat3 cof = mat3(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1]));
    uint view = gl_ViewIndex + pc.view_offset;
    v_pos = p;
    v_normal = cof * in_normal;
    v_tangent = vec4(m * in_tangent.xyz, in_tangent.w);
    v_uv = vec4(in_uv0, in_uv1);
    v_color = in_color;
    gl_Position = lms_scaled(frame.view_proj[view] * vec4(p, 1.0));
#if SECTION
    // The section plane: negative beyond it, so the rasterizer cuts there.
    gl_ClipDistance[0] = dot(frame.section.xyz, p) + frame.section.w;
#endif
}
