#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// One box of the interaction overlay per instance (controllers, rays, the
// teleport arc, markers, label segments): the box's centre and half axes
// come from frame.overlay; vertex i is corner (face i / 6, corner i % 6).

layout(location = 0) out vec3 v_color;

// The two triangles of a face as (u, v) signs.
const vec2 CORNERS[6] = vec2[](
    vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(1.0, 1.0),
    vec2(-1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));

void main() {
    int b = gl_InstanceIndex * 4;
    vec4 c = frame.overlay[b];
    vec4 ax = frame.overlay[b + 1];
    vec4 ay = frame.overlay[b + 2];
    vec4 az = frame.overlay[b + 3];
    mat3 axes = mat3(ax.xyz, ay.xyz, az.xyz);
    int face = gl_VertexIndex / 6;
    int axis = face >> 1;
    float side = (face & 1) == 0 ? -1.0 : 1.0;
    vec2 uv = CORNERS[gl_VertexIndex % 6];
    vec3 s = vec3(0.0);
    s[axis] = side;
    s[(axis + 1) % 3] = uv.x;
    s[(axis + 2) % 3] = uv.y;
    vec3 p = c.xyz + axes * s;
    // Faces lit by the sun a little so the boxes read as solids.
    vec3 n = axes[axis] * side;
    float len = length(n);
    float lit = len > 0.0 ? max(dot(n / len, frame.sun_dir.xyz), 0.0) : 0.0;
    v_color = vec3(c.w, ax.w, ay.w) * (0.7 + 0.3 * lit);
    gl_Position = lms_scaled(frame.view_proj[gl_ViewIndex + pc.view_offset] * vec4(p, 1.0));
}
