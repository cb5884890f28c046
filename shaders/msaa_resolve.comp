#version 450
#extension GL_GOOGLE_include_directive : require
#include "srgb.glsl"
// A multisample resolve in a compute shader (`vergence raster-floors`'
// compute-resolve variants): pixel (x, y) of layer z is the mean of its
// samples, averaged in linear light (the colour image is sRGB, so the
// sampler decodes) and encoded back to sRGB with the piecewise curve of
// IEC 61966-2-1 before the store into a UNORM storage image.

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0) uniform sampler2DMSArray colour;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2DArray resolved;

layout(push_constant) uniform Push {
    uvec4 size;   // width, height, layers, samples
} pc;

void main() {
    uvec3 p = gl_GlobalInvocationID;
    if (p.x >= pc.size.x || p.y >= pc.size.y || p.z >= pc.size.z) {
        return;
    }
    vec4 sum = vec4(0.0);
    for (uint s = 0u; s < pc.size.w; s++) {
        sum += texelFetch(colour, ivec3(p), int(s));
    }
    vec4 mean = sum / float(pc.size.w);
    imageStore(resolved, ivec3(p), vec4(encode_srgb(mean.rgb), mean.a));
}
