#version 450
#define MS 0
#include "hiz_init_body.glsl"
