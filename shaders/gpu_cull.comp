#version 450
// GPU-driven culling (`gpu-cull`): one thread per instance tests its world
// box against the frame's stereo volumes (src/cull/gpu.rs builds them; its
// `keeps` is this test in Rust) and, when kept, appends the instance to the
// visible list of each of its mesh's primitives and counts it in that
// primitive's indirect draw. The draws' firstInstance (each primitive's
// base in the visible buffer) and the other command fields come from the
// template the frame copies in before the dispatch, instanceCount zeroed.

layout(local_size_x = 64) in;

struct CullInstance {
    vec4 center_hi;  // box centre, high f32 part (xyz); w: first primitive slot (bits)
    vec4 center_lo;  // box centre, low f32 part (xyz); w: primitive count (bits)
    vec4 extent;     // half-extents (xyz)
};

struct DrawCommand {  // VkDrawIndexedIndirectCommand
    uint index_count;
    uint instance_count;
    uint first_index;
    int vertex_offset;
    uint first_instance;
};

layout(std140, set = 0, binding = 0) uniform Volumes {
    uvec4 info;          // kind (0 planes, 1 cones), volumes, planes in set 0, 1
    vec4 planes[12];     // set s, plane i at 6 s + i: normal, offset (origin-relative)
    vec4 cone_apex[2];   // apex (origin-relative), w = 1 with a far plane
    vec4 cone_axis[2];   // unit axis, w = cos
    vec4 cone_far[2];    // far normal, w = depth from the apex
    vec4 cone_sin;       // sin of cone 0, 1; z: relative slack
    vec4 origin_hi;
    vec4 origin_lo;
    uvec4 counts;        // instances, threads per dispatch row
} vol;

layout(std430, set = 0, binding = 1) readonly buffer Instances { CullInstance instances[]; };
layout(std430, set = 0, binding = 2) readonly buffer Prims { uint prim_of_slot[]; };
layout(std430, set = 0, binding = 3) buffer Commands { DrawCommand commands[]; };
// [p]: draws of primitive p this frame (0 or 1); then tested, kept.
layout(std430, set = 0, binding = 4) buffer Counts { uint draw_count[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Visible { uint visible[]; };

layout(push_constant) uniform Push {
    uint primitives;  // index of the "tested" counter in draw_count
} pc;

shared uint group_tested;
shared uint group_kept;

// The conservative box test of src/cull/volume.rs (`Volume::keeps`), widened
// by the relative slack so f32 rounding never drops what the f64 CPU keeps.
bool keeps(vec3 c, vec3 e) {
    float slack = vol.cone_sin.z;
    for (uint s = 0u; s < vol.info.y; ++s) {
        bool kept = true;
        if (vol.info.x == 0u) {
            uint n_planes = s == 0u ? vol.info.z : vol.info.w;
            for (uint i = 0u; i < n_planes; ++i) {
                vec4 p = vol.planes[6u * s + i];
                // Max over the box of n · x + d: n · c + |n| · e + d.
                float reach = dot(p.xyz, c) + dot(abs(p.xyz), e);
                float scale = dot(abs(p.xyz), abs(c)) + dot(abs(p.xyz), e) + abs(p.w) + 1.0;
                if (reach + p.w < -slack * scale) {
                    kept = false;
                    break;
                }
            }
        } else {
            // Eberly, "Intersection of a Sphere and a Cone": the sphere is
            // outside when |d × a| cos θ - (d · a) sin θ exceeds its radius.
            vec4 apex = vol.cone_apex[s];
            vec3 d = c - apex.xyz;
            float r = length(e);
            float scale = slack * (1.0 + length(d) + r);
            vec4 axis = vol.cone_axis[s];
            float side = length(cross(d, axis.xyz)) * axis.w - dot(d, axis.xyz) * vol.cone_sin[s];
            if (side > r + scale) {
                kept = false;
            } else if (apex.w != 0.0) {
                vec4 f = vol.cone_far[s];
                kept = dot(f.xyz, d) - r <= f.w + scale;
            }
        }
        if (kept) {
            return true;
        }
    }
    return false;
}

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        group_tested = 0u;
        group_kept = 0u;
    }
    barrier();
    uint i = gl_WorkGroupID.y * vol.counts.y + gl_GlobalInvocationID.x;
    if (i < vol.counts.x) {
        CullInstance inst = instances[i];
        // Relative-to-origin centre from the two-float split, as scene.vert.
        vec3 c = (inst.center_hi.xyz - vol.origin_hi.xyz) + (inst.center_lo.xyz - vol.origin_lo.xyz);
        atomicAdd(group_tested, 1u);
        if (keeps(c, inst.extent.xyz)) {
            atomicAdd(group_kept, 1u);
            uint first = floatBitsToUint(inst.center_hi.w);
            uint n = floatBitsToUint(inst.center_lo.w);
            for (uint k = 0u; k < n; ++k) {
                uint p = prim_of_slot[first + k];
                uint at = atomicAdd(commands[p].instance_count, 1u);
                visible[commands[p].first_instance + at] = i;
                if (at == 0u) {
                    draw_count[p] = 1u;
                }
            }
        }
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        atomicAdd(draw_count[pc.primitives], group_tested);
        atomicAdd(draw_count[pc.primitives + 1u], group_kept);
    }
}
