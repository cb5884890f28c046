// GPU-driven culling (`gpu-cull`): one thread per instance tests its world
// box against the frame's stereo volumes (src/cull/gpu.rs builds them; its
// `keeps` is this test in Rust) and, when kept, appends the instance to the
// visible list of each of its mesh's primitives and counts it in that
// primitive's indirect draw. The draws' firstInstance (each primitive's
// base in the visible buffer) and the other command fields come from the
// template the frame copies in before the dispatch, instanceCount zeroed.
//
// With `occlusion` the pass runs twice (src/cull/hiz.rs has the math and
// its tests): phase 1 (`cull-early`) draws the instances inside the volumes
// that were visible last frame; phase 2 (`cull-late`), after this frame's
// depth pyramid is built from what phase 1 drew, tests every instance inside
// the volumes against it in both eyes, records which are visible for the
// next frame, and draws those phase 1 did not. The late commands and
// counts follow the early ones (index + primitives), and the late visible
// ranges follow the early ones (firstInstance in the late template).
// Phase 2 also lists the instances it finds visible (the early list) and
// sizes the next frame's phase 1 dispatch to them, so phase 1 runs one
// thread per instance visible last frame instead of one per instance; with
// occlusion phase 2 therefore counts the tested, inside and dropped ones.
//
// With a monoscopic far field (`mffr`, no occlusion) the second set is the
// far pass's: an instance whose bounding sphere reaches nearer than the
// split goes to the near views' set, one reaching beyond it to the far
// set (a straddling one to both), as the CPU batcher splits.
//
// With `inset` (no occlusion) the second set is the inset views': an
// instance whose box one eye's volume through the inset keeps goes to it,
// and every instance but those whose box both eyes' volumes through the
// inset's core contain (the wide views' hole) to the wide views' first set.

// Included by gpu_cull.comp (SUBGROUP 1: appends and counters aggregated
// per subgroup with ballots, one atomic per subgroup and command instead of
// one per instance) and gpu_cull_plain.comp (SUBGROUP 0, for devices
// without subgroup ballots).

layout(local_size_x = 64) in;

struct CullInstance {
    vec4 center_hi;  // box centre, high f32 part (xyz); w: first primitive slot (bits)
    vec4 center_lo;  // box centre, low f32 part (xyz); w: primitive count (bits)
    vec4 extent;     // half-extents (xyz); w: largest axis scale of the transform
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
    vec4 split_axes[8];  // mffr: eye 0, eye 1, far 0, far 1: position (w 1: used), forward
    vec4 split;          // mffr: near threshold, far threshold
    uvec4 inset_info;    // inset lists: x 1 split, 2 every instance in both; y 1 with the hole
    vec4 inset_planes[16]; // side planes: inset eye 0, eye 1, core eye 0, eye 1 (4 each)
} vol;

layout(std430, set = 0, binding = 1) readonly buffer Instances { CullInstance instances[]; };
layout(std430, set = 0, binding = 2) readonly buffer Prims { uint prim_of_slot[]; };
layout(std430, set = 0, binding = 3) buffer Commands { DrawCommand commands[]; };
// [p]: early draws of primitive p this frame (0 or 1); [primitives + p]:
// late draws (p counts draw commands: primitives × LOD levels); then
// tested, inside the volumes, drawn early, drawn late, hidden, dropped.
layout(std430, set = 0, binding = 4) buffer Counts { uint draw_count[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Visible { uint visible[]; };
// The frame's uniform block, its first member only (common.glsl's FrameData).
layout(std140, set = 0, binding = 6) uniform FrameData { mat4 view_proj[4]; } frame;
// Per eye, every pyramid level; then the levels' shape (width, height, offset).
layout(std430, set = 0, binding = 7) readonly buffer Pyramid { float texel[]; };
layout(std430, set = 0, binding = 8) readonly buffer Levels { uvec4 level[]; };
// 1 where the instance was visible at the end of the last frame.
layout(std430, set = 0, binding = 9) buffer Visibility { uint visibility[]; };
// Per primitive: its level-0 draw command and LOD level count.
layout(std430, set = 0, binding = 10) readonly buffer LodLevels { uvec4 lod_level[]; };
// Per draw command: its level's object-space error (src/scene/lod.rs).
layout(std430, set = 0, binding = 11) readonly buffer LodErrors { float lod_error[]; };
// The instances visible at the end of the last frame (phase 2 writes,
// phase 1 reads), after phase 1's indirect dispatch size.
layout(std430, set = 0, binding = 12) buffer EarlyList {
    uint early_groups_x;  // EARLY_ROW
    uint early_groups_y;  // rows: ceil(listed / (EARLY_ROW · 64))
    uint early_groups_z;  // 1
    uint listed;
    uint early_list[];
};

layout(push_constant) uniform Push {
    uint primitives;  // draw commands per phase (the late commands' offset)
    uint phase;       // 0: no occlusion, 1: early, 2: late
    uint levels;      // pyramid levels
    uint eye_stride;  // pyramid texels per eye
    uvec2 size;       // eye image pixels
    float near;       // near plane distance
    uint lod;         // 1: select LOD levels and drop sub-bound instances
    float lod_k;      // pixel density over the error bound
    float eye_slack;  // the eyes' largest distance from the render origin
    uint far_mode;    // mffr: 0 all near, 1 split (vol.split_axes), 2 all in both
    float lod_k_wide; // inset's wide views: lod_k at their density (lod_k x their scale)
} pc;

const float PIXEL_SLACK = 0.5;
// Workgroups per row of phase 1's dispatch (EARLY_ROW in
// src/render/passes/gpu_cull.rs).
const uint EARLY_ROW = 256u;
const float DEPTH_SLACK = 1e-6;

shared uint group_tested;
shared uint group_kept;
shared uint group_drawn;
shared uint group_hidden;
shared uint group_dropped;

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

// src/cull/hiz.rs `footprint` + `occluded` for eye `eye`.
bool hidden_in(uint eye, vec3 c, vec3 e) {
    mat4 m = frame.view_proj[eye];
    vec2 lo = vec2(uintBitsToFloat(0x7f800000u));
    vec2 hi = -lo;
    float depth = 0.0;
    for (uint k = 0u; k < 8u; ++k) {
        vec3 s = vec3((k & 1u) == 0u ? -1.0 : 1.0, (k & 2u) == 0u ? -1.0 : 1.0, (k & 4u) == 0u ? -1.0 : 1.0);
        vec4 clip = m * vec4(c + s * e, 1.0);
        if (!(clip.w > pc.near)) {
            return false;
        }
        vec3 ndc = clip.xyz / clip.w;
        lo = min(lo, ndc.xy);
        hi = max(hi, ndc.xy);
        depth = max(depth, ndc.z);
    }
    vec2 size = vec2(pc.size);
    vec2 px_lo = (lo + 1.0) * 0.5 * size - PIXEL_SLACK;
    vec2 px_hi = (hi + 1.0) * 0.5 * size + PIXEL_SLACK;
    if (px_hi.x < 0.0 || px_hi.y < 0.0 || px_lo.x >= size.x || px_lo.y >= size.y) {
        return true;
    }
    uvec2 a = min(uvec2(floor(max(px_lo, vec2(0.0)))), pc.size - 1u);
    uvec2 b = min(uvec2(floor(max(px_hi, vec2(0.0)))), pc.size - 1u);
    depth *= 1.0 + DEPTH_SLACK;
    uint k = 0u;
    while (k + 1u < pc.levels) {
        uint shift = k + 1u;
        if ((b.x >> shift) - (a.x >> shift) <= 1u && (b.y >> shift) - (a.y >> shift) <= 1u) {
            break;
        }
        k += 1u;
    }
    uvec4 l = level[k];
    uint shift = k + 1u;
    uvec2 t0 = a >> shift;
    uvec2 t1 = min(b >> shift, l.xy - 1u);
    float farthest = uintBitsToFloat(0x7f800000u);
    uint base = eye * pc.eye_stride + l.z;
    for (uint ty = t0.y; ty <= t1.y; ++ty) {
        for (uint tx = t0.x; tx <= t1.x; ++tx) {
            farthest = min(farthest, texel[base + ty * l.x + tx]);
        }
    }
    return depth < farthest;
}

// src/view/lod.rs `selection_distance`: to the bounding sphere's nearest
// point, less the eyes' offset, at least the near plane.
float lod_distance(vec3 c, vec3 e) {
    return max(length(c) - length(e) - pc.eye_slack, pc.near);
}

// src/view/lod.rs `select` (the drop test is in main): the coarsest level
// of primitive p whose world error projects to at most the bound.
uint lod_command(uint p, float scale, float dist, float k) {
    uvec4 l = lod_level[p];
    uint level = 0u;
    if (pc.lod != 0u) {
        for (uint j = 1u; j < l.y; ++j) {
            if (lod_error[l.x + j] * scale * k <= dist) {
                level = j;
            } else {
                break;
            }
        }
    }
    return l.x + level;
}

// Appends instance `i` to the visible list of each of its primitives (at
// the level LOD picks for views of density `lod_k`) and counts it in their
// draws at command offset `base` (0 early, the command count late).
void append_at(uint i, CullInstance inst, vec3 c, uint base, float lod_k) {
    uint first = floatBitsToUint(inst.center_hi.w);
    uint n = floatBitsToUint(inst.center_lo.w);
    float dist = lod_distance(c, inst.extent.xyz);
    for (uint k = 0u; k < n; ++k) {
        uint p = base + lod_command(prim_of_slot[first + k], inst.extent.w, dist, lod_k);
#if SUBGROUP
        // The lanes appending to the same command take consecutive slots
        // after one atomic by the first of them; the others loop.
        for (;;) {
            if (subgroupBroadcastFirst(p) == p) {
                uvec4 lanes = subgroupBallot(true);
                uint rank = subgroupBallotExclusiveBitCount(lanes);
                uint at = 0u;
                if (rank == 0u) {
                    at = atomicAdd(commands[p].instance_count, subgroupBallotBitCount(lanes));
                }
                at = subgroupBroadcastFirst(at) + rank;
                visible[commands[p].first_instance + at] = i;
                if (at == 0u) {
                    draw_count[p] = 1u;
                }
                break;
            }
        }
#else
        uint at = atomicAdd(commands[p].instance_count, 1u);
        visible[commands[p].first_instance + at] = i;
        if (at == 0u) {
            draw_count[p] = 1u;
        }
#endif
    }
}

// append_at for the views of the frame's density.
void append(uint i, CullInstance inst, vec3 c, uint base) {
    append_at(i, inst, c, base, pc.lod_k);
}

// Phase 2: appends visible instance `i` to the next frame's early list and
// grows that dispatch's rows to cover it.
void list_visible(uint i) {
    const uint row = EARLY_ROW * 64u;
#if SUBGROUP
    uvec4 lanes = subgroupBallot(true);
    uint rank = subgroupBallotExclusiveBitCount(lanes);
    uint n = subgroupBallotBitCount(lanes);
    uint at = 0u;
    if (rank == 0u) {
        at = atomicAdd(listed, n);
        atomicMax(early_groups_y, (at + n + row - 1u) / row);
    }
    at = subgroupBroadcastFirst(at) + rank;
#else
    uint at = atomicAdd(listed, 1u);
    atomicMax(early_groups_y, (at + row) / row);
#endif
    early_list[at] = i;
}

// Adds each of `v`'s flags over the subgroup (or per invocation) into the
// group's counters.
void count(bvec4 v, bool dropped) {
#if SUBGROUP
    uint a = subgroupBallotBitCount(subgroupBallot(v.x));
    uint b = subgroupBallotBitCount(subgroupBallot(v.y));
    uint c = subgroupBallotBitCount(subgroupBallot(v.z));
    uint d = subgroupBallotBitCount(subgroupBallot(v.w));
    uint e = subgroupBallotBitCount(subgroupBallot(dropped));
    if (subgroupElect()) {
        if (a != 0u) atomicAdd(group_tested, a);
        if (b != 0u) atomicAdd(group_kept, b);
        if (c != 0u) atomicAdd(group_drawn, c);
        if (d != 0u) atomicAdd(group_hidden, d);
        if (e != 0u) atomicAdd(group_dropped, e);
    }
#else
    if (v.x) atomicAdd(group_tested, 1u);
    if (v.y) atomicAdd(group_kept, 1u);
    if (v.z) atomicAdd(group_drawn, 1u);
    if (v.w) atomicAdd(group_hidden, 1u);
    if (dropped) atomicAdd(group_dropped, 1u);
#endif
}

// src/cull/gpu.rs `box_reach`: the signed distance of the box to plane p
// at its farthest (toward) or nearest point, and the magnitude its
// rounding scales with.
float box_reach(vec4 p, vec3 c, vec3 e, bool toward, out float scale) {
    float spread = dot(abs(p.xyz), e);
    scale = dot(abs(p.xyz), abs(c)) + spread + abs(p.w) + 1.0;
    return dot(p.xyz, c) + (toward ? spread : -spread) + p.w;
}

// src/cull/gpu.rs `inset_keeps`: some eye's volume through the inset keeps
// the box (widened by the slack).
bool inset_keeps(vec3 c, vec3 e) {
    float slack = vol.cone_sin.z;
    for (uint eye = 0u; eye < 2u; ++eye) {
        bool kept = true;
        for (uint k = 0u; k < 4u; ++k) {
            float scale;
            float at = box_reach(vol.inset_planes[4u * eye + k], c, e, true, scale);
            kept = kept && at >= -slack * scale;
        }
        if (kept) {
            return true;
        }
    }
    return false;
}

// src/cull/gpu.rs `core_contains`: both eyes' volumes through the inset's
// core contain the box (narrowed by the slack), and the frame has a hole.
bool core_contains(vec3 c, vec3 e) {
    if (vol.inset_info.y == 0u) {
        return false;
    }
    float slack = vol.cone_sin.z;
    for (uint k = 0u; k < 8u; ++k) {
        float scale;
        float at = box_reach(vol.inset_planes[8u + k], c, e, false, scale);
        if (at < slack * scale) {
            return false;
        }
    }
    return true;
}

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        group_tested = 0u;
        group_kept = 0u;
        group_drawn = 0u;
        group_hidden = 0u;
        group_dropped = 0u;
    }
    barrier();
    // Phase 1 runs over the early list, in rows of its own dispatch.
    uint t = gl_WorkGroupID.y * gl_NumWorkGroups.x * 64u + gl_GlobalInvocationID.x;
    uint i = t;
    bool valid = t < vol.counts.x;
    if (pc.phase == 1u) {
        valid = t < listed;
        if (valid) {
            i = early_list[t];
            valid = i < vol.counts.x;
        }
    }
    // tested, kept, drawn, hidden; dropped: counted below in uniform
    // control flow.
    bvec4 flags = bvec4(false);
    bool was_dropped = false;
    if (valid) {
        CullInstance inst = instances[i];
        // Relative-to-origin centre from the two-float split, as scene.vert.
        vec3 c = (inst.center_hi.xyz - vol.origin_hi.xyz) + (inst.center_lo.xyz - vol.origin_lo.xyz);
        bool inside = keeps(c, inst.extent.xyz);
        // src/view/lod.rs: an instance whose bounding sphere's diameter
        // projects to at most the bound is not drawn.
        bool dropped = pc.lod != 0u
            && 2.0 * length(inst.extent.xyz) * pc.lod_k <= lod_distance(c, inst.extent.xyz);
        if (pc.phase == 1u) {
            // Listed: visible at the end of the last frame.
            flags.x = true;
            if (inside && !dropped) {
                flags.z = true;
                append(i, inst, c, 0u);
            }
        } else if (pc.phase == 0u) {
            flags.x = true;
            if (inside) {
                flags.y = true;
                if (dropped) {
                    was_dropped = true;
                } else if (pc.phase == 0u && pc.far_mode != 0u) {
                    // src/cull/gpu.rs `FarSplitAxes`: near along an eye's
                    // axis, far along a far camera's.
                    float r = length(inst.extent.xyz);
                    bool near = pc.far_mode == 2u;
                    bool far = near;
                    for (uint k = 0u; k < 4u; ++k) {
                        vec4 p = vol.split_axes[2u * k];
                        if (p.w == 0.0) {
                            continue;
                        }
                        float along = dot(c - p.xyz, vol.split_axes[2u * k + 1u].xyz);
                        if (k < 2u) {
                            near = near || along - r < vol.split.x;
                        } else {
                            far = far || along + r > vol.split.y;
                        }
                    }
                    flags.z = true;
                    if (near) {
                        append(i, inst, c, 0u);
                    }
                    if (far) {
                        append(i, inst, c, pc.primitives);
                    }
                } else if (vol.inset_info.x != 0u) {
                    // src/cull/gpu.rs `InsetLists`: the wide views' list
                    // (first set) and the inset's (second).
                    bool both = vol.inset_info.x == 2u;
                    // The wide views select LOD levels, and drop what
                    // projects under the bound, at their own density.
                    bool wide_dropped = pc.lod != 0u
                        && 2.0 * length(inst.extent.xyz) * pc.lod_k_wide <= lod_distance(c, inst.extent.xyz);
                    bool to_wide = both || (!wide_dropped && !core_contains(c, inst.extent.xyz));
                    bool to_inset = both || inset_keeps(c, inst.extent.xyz);
                    // Drawn: in either list (one dropped from the wide list
                    // at its density and outside both insets is in none).
                    flags.z = to_wide || to_inset;
                    if (to_wide) {
                        append_at(i, inst, c, 0u, pc.lod_k_wide);
                    }
                    if (to_inset) {
                        append(i, inst, c, pc.primitives);
                    }
                } else {
                    flags.z = true;
                    append(i, inst, c, 0u);
                }
            }
        } else {
            flags.x = true;
            if (!inside) {
                visibility[i] = 0u;
            } else {
                flags.y = true;
                was_dropped = dropped;
                bool seen = !hidden_in(0u, c, inst.extent.xyz) || !hidden_in(1u, c, inst.extent.xyz);
                if (seen && visibility[i] == 0u && !dropped) {
                    flags.z = true;
                    append(i, inst, c, pc.primitives);
                }
                if (seen) {
                    list_visible(i);
                }
                flags.w = !seen;
                visibility[i] = seen ? 1u : 0u;
            }
        }
    }
    count(flags, was_dropped);
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        uint at = 2u * pc.primitives;
        // Zero counts are not added (most groups have nothing drawn or
        // hidden): fewer atomics on the same few words.
        if (pc.phase == 1u) {
            if (group_tested != 0u) atomicAdd(draw_count[at + 6u], group_tested);
            if (group_drawn != 0u) atomicAdd(draw_count[at + 2u], group_drawn);
        } else {
            atomicAdd(draw_count[at], group_tested);
            if (group_kept != 0u) atomicAdd(draw_count[at + 1u], group_kept);
            if (group_dropped != 0u) atomicAdd(draw_count[at + 5u], group_dropped);
            uint drawn = pc.phase == 0u ? at + 2u : at + 3u;
            if (group_drawn != 0u) atomicAdd(draw_count[drawn], group_drawn);
            if (group_hidden != 0u) atomicAdd(draw_count[at + 4u], group_hidden);
        }
    }
}
