#version 450
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Point clouds rasterized in compute (src/render/passes/points.rs), after
// Schütz, Kerbl and Wimmer, "Rendering Point Clouds with Compute Shaders
// and Vertex Order Optimization" (EGSR 2021): each point is projected into
// every view and its pixel keeps, by a 64-bit atomic max, the key
// (reverse-Z depth bits << 32 | sRGB colour): the largest depth is the
// nearest point, and positive float bits order like their values. A key of
// 0 is an empty pixel. One thread per point drawn this frame: the frame's
// octree nodes are point ranges, listed as (first thread, first point)
// pairs; a thread finds its range by binary search. Each workgroup adds
// its count of points that landed in a view to `drawn` once.
layout(local_size_x = 256) in;

// The prefix of the frame uniforms (shaders/common.glsl's FrameData).
layout(std140, set = 0, binding = 0) uniform FrameData { mat4 view_proj[4]; } frame;
// The points, spread over up to five buffers of pc.extra.x points each
// (one storage-buffer descriptor reaches at most maxStorageBufferRange
// bytes: 4 GiB, 268 M points, on the H200); unused bindings repeat the first.
layout(std430, set = 0, binding = 1) readonly buffer Points0 { vec4 points0[]; };
layout(std430, set = 0, binding = 5) readonly buffer Points1 { vec4 points1[]; };
layout(std430, set = 0, binding = 6) readonly buffer Points2 { vec4 points2[]; };
layout(std430, set = 0, binding = 7) readonly buffer Points3 { vec4 points3[]; };
layout(std430, set = 0, binding = 8) readonly buffer Points4 { vec4 points4[]; };
layout(std430, set = 0, binding = 2) buffer Keys { uint64_t keys[]; };
layout(std430, set = 0, binding = 3) buffer Drawn { uint drawn; };
layout(std430, set = 0, binding = 4) readonly buffer Ranges { uvec2 ranges[]; };

// offset: the cloud's origin relative to the render origin (w: the range
// count's bits); info: points drawn, image width, height, views; extra.x:
// points per buffer, extra.y: the point size in pixels (float bits),
// extra.z: the distance at which a point has that size (float bits).
// Farther points shrink as 1 / distance, to one pixel at least; a point of
// side s covers the s × s pixels around its own.
layout(push_constant) uniform Push { vec4 offset; uvec4 info; uvec4 extra; } pc;

vec4 fetch(uint i) {
    uint b = i / pc.extra.x;
    uint o = i - b * pc.extra.x;
    if (b == 0u) {
        return points0[o];
    } else if (b == 1u) {
        return points1[o];
    } else if (b == 2u) {
        return points2[o];
    } else if (b == 3u) {
        return points3[o];
    }
    return points4[o];
}

shared uint group_drawn;

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        group_drawn = 0u;
    }
    barrier();
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationIndex;
    if (i < pc.info.x) {
        uint lo = 0u;
        uint hi = floatBitsToUint(pc.offset.w);
        while (hi - lo > 1u) {
            uint mid = (lo + hi) >> 1;
            if (ranges[mid].x <= i) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        vec4 p = fetch(ranges[lo].y + (i - ranges[lo].x));
        vec4 rel = vec4(pc.offset.xyz + p.xyz, 1.0);
        uint64_t colour = uint64_t(floatBitsToUint(p.w));
        uvec2 size = pc.info.yz;
        for (uint v = 0u; v < pc.info.w; v++) {
            vec4 c = frame.view_proj[v] * rel;
            if (c.w <= 0.0) {
                continue;
            }
            vec3 n = c.xyz / c.w;
            if (abs(n.x) >= 1.0 || abs(n.y) >= 1.0 || n.z <= 0.0 || n.z > 1.0) {
                continue;
            }
            uvec2 px = min(uvec2((n.xy * 0.5 + 0.5) * vec2(size)), size - 1u);
            uint64_t key = (uint64_t(floatBitsToUint(n.z)) << 32) | colour;
            float full = uintBitsToFloat(pc.extra.y);
            int side = int(clamp(full * uintBitsToFloat(pc.extra.z) / c.w, 1.0, full));
            int lo = -(side - 1) / 2;
            for (int dy = lo; dy < lo + side; dy++) {
                for (int dx = lo; dx < lo + side; dx++) {
                    ivec2 q = ivec2(px) + ivec2(dx, dy);
                    if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(size)))) {
                        atomicMax(keys[(v * size.y + uint(q.y)) * size.x + uint(q.x)], key);
                    }
                }
            }
            atomicAdd(group_drawn, 1u);
        }
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && group_drawn > 0u) {
        atomicAdd(drawn, group_drawn);
    }
}
