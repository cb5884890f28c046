#version 450
// The hidden-area mask marked in depth (src/render/passes/stencil_mask.rs):
// the hidden samples get the colour a cleared frame gives them (opaque
// black), so the frame need not clear its colour.
layout(early_fragment_tests) in;
layout(location = 0) out vec4 out_color;
void main() {
    out_color = vec4(0.0, 0.0, 0.0, 1.0);
}
