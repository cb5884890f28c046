#version 450
// Distortion method (c): a mesh baked on the CPU
// (src/view/distortion/mesh.rs) with the panel position and the eye uv of
// each colour channel per vertex; nothing is computed here.
layout(location = 0) in vec2 a_ndc;
layout(location = 1) in vec2 a_red;
layout(location = 2) in vec2 a_green;
layout(location = 3) in vec2 a_blue;
layout(location = 0) out vec2 v_red;
layout(location = 1) out vec2 v_green;
layout(location = 2) out vec2 v_blue;
void main() {
    v_red = a_red;
    v_green = a_green;
    v_blue = a_blue;
    gl_Position = vec4(a_ndc, 0.0, 1.0);
}
