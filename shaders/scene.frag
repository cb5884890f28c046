#version 450
#extension GL_GOOGLE_include_directive : require
// PBR / unlit scene shading; tests run after the shader (alpha-mask
// variants discard, so depth and stencil cannot be tested before it).
#include "scene_body.glsl"
