#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_shader_draw_parameters : require
#define PER_DRAW 2
#include "scene_vert_body.glsl"
