#version 450
// GPU culling with subgroup-aggregated appends and counters (see
// gpu_cull_body.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#define SUBGROUP 1
#include "gpu_cull_body.glsl"
