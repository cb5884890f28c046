#version 450
#define MS 1
#include "hiz_init_body.glsl"
