#version 450
layout(early_fragment_tests) in;
// The trivial fragment shader of the raster-floor measurement.
layout(location = 0) out vec4 out_color;
void main() {
    out_color = vec4(0.5, 0.5, 0.5, 1.0);
}
