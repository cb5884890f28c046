#version 450
#extension GL_EXT_multiview : require
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_shader_draw_parameters : require
// With the section plane's clip distance (pipelines built when a plane is first set).
#define PER_DRAW 2
#define SECTION 1
#include "scene_vert_body.glsl"
