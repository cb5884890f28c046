#version 450
#extension GL_EXT_multiview : require
// One triangle covering the viewport (no vertex buffer): vertices at
// (-1,-1), (3,-1), (-1,3) in NDC; depth 0 is the far plane under reverse-Z.
// The view index is passed on flat so the fragment stage need not read it.
layout(location = 0) out vec2 v_ndc;
layout(location = 1) flat out uint v_view;
void main() {
    vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2) * 2.0 - 1.0;
    v_ndc = p;
    v_view = gl_ViewIndex;
    gl_Position = vec4(p, 0.0, 1.0);
}
