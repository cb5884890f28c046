#version 450
// The full-screen triangle of the raster-floor measurement: no outputs, so
// the trivial fragment shader has no inputs to interpolate.
void main() {
    vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
