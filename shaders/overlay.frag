#version 450
layout(early_fragment_tests) in;
// The interaction overlay's flat colour (linear; the attachment is sRGB).
layout(location = 0) in vec3 v_color;
layout(location = 0) out vec4 out_color;
void main() {
    out_color = vec4(v_color, 1.0);
}
