// Timewarp simulation (src/render/timewarp.rs; the math is
// src/view/reproject.rs): buffers of both eyes' pixels, eye after eye,
// row-major; colours packed RGBA8 (sRGB bytes), depth reverse-Z.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, set = 0, binding = 0) readonly buffer SrcColour { uint src_colour[]; };
layout(std430, set = 0, binding = 1) readonly buffer SrcDepth { float src_depth[]; };
// Per target pixel: 0 when nothing landed, else floatBitsToUint(depth) + 1.
layout(std430, set = 0, binding = 2) buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 3) buffer Out { uint out_colour[]; };
// Per eye: holes, border pixels, cracks.
layout(std430, set = 0, binding = 4) buffer Counters { uint counters[]; };
// Per eye: the clip-to-clip reprojection (with depth), and the inverse of
// the rotation-only map (new NDC -> old NDC).
layout(std430, set = 0, binding = 5) readonly buffer Params { mat4 reproject[2]; mat4 rotation_inverse[2]; };
// Per source pixel, from the scatter's first pass to its second: the target
// pixel + 1 (0: none) and the key it competed with, so the second pass does
// not recompute them (a recomputation may round differently).
layout(std430, set = 0, binding = 6) buffer Scatter { uvec2 scatter[]; };
layout(push_constant) uniform Push {
    uvec2 size;   // pixels per eye
    uint eye;
    uint mode;    // scatter: 0 depth keys, 1 colours; resolve: 0 leave holes, 1 fill
} pc;

uint pixel_index(uvec2 p) {
    return pc.eye * pc.size.x * pc.size.y + p.y * pc.size.x + p.x;
}

vec2 ndc_of(uvec2 p) {
    return (vec2(p) + 0.5) / vec2(pc.size) * 2.0 - 1.0;
}
