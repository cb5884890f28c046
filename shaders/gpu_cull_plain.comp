#version 450
// GPU culling without subgroup operations (see gpu_cull_body.glsl).
#define SUBGROUP 0
#include "gpu_cull_body.glsl"
