#version 450
// One triangle covering the panel (no vertex buffer); the per-fragment
// distortion method computes everything from gl_FragCoord.
void main() {
    vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
