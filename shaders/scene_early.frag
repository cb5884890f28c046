#version 450
#extension GL_GOOGLE_include_directive : require
// The scene shader with early fragment tests forced: used for the variants
// that never discard (opaque, blend), so the HMD stencil mask rejects
// hidden pixels before any shading work.
#include "scene_body.glsl"
layout(early_fragment_tests) in;
