#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#define PER_DRAW 1
#include "scene_vert_body.glsl"
