#version 450
#extension GL_GOOGLE_include_directive : require
#include "taa.glsl"
// Temporal upsampling of the inset's wide views to the eye's resolution
// (inset-taau; src/view/taau.rs has the derivation and the CPU model this
// follows; src/render/passes/inset_taa.rs records it in its upsampling
// mode). One invocation per eye pixel of one layer (one eye) of one wide
// attachment set: the 3x3 jittered wide samples around the pixel
// (linear: the sampler decodes sRGB), weighted by their distance to the
// pixel centre in eye pixels, give the frame's estimate and its weight;
// the eye-sized history, read where the pixel's surface point lay in the
// previous frame and clamped to the samples' box, is blended with the
// estimate in proportion to the two weights. The colour and the
// accumulated weight (alpha) go into this frame's history layer, which
// the composite reads as the wide view at the eye's size.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0) uniform sampler2DArray current[2];
layout(set = 0, binding = 1) uniform sampler2DArray depth[2];
layout(set = 0, binding = 2) uniform sampler2DArray history[2];
layout(set = 0, binding = 3, rgba16f) uniform writeonly image2DArray next[2];

layout(push_constant) uniform Push {
    mat4 to_previous; // current (NDC x, NDC y, depth, 1) -> previous clip
    uint size;        // the wide view's drawn size, width | height << 16
    uint set;         // wide attachment set (0 or 1)
    uint layer;       // the set's layer (the eye under multiview)
    uint read_layer;  // the history layer of the previous frame
    uint write_layer; // the history layer this frame writes
    uint valid;       // 1: the previous frame's history may be read
    float alpha;      // sets the weight cap N_max = (pi / K) s_x s_y / alpha
    float jitter_x;   // this frame's viewport offset, wide pixels
    float jitter_y;
    uint eye_size;    // the eyes' size (the history's), width | height << 16
    uint lanczos;     // 1: read the history through Lanczos-3, else Catmull-Rom
} pc;

// view::taa::VARIANCE_GAMMA and view::taau::GAUSSIAN_K.
const float GAMMA = 1.25;
const float GAUSSIAN_K = 2.29;

// The history at eye position `at` (pixels, centres at + 0.5) through the
// Catmull-Rom filter over the 4x4 texels around it (weights as
// view::taa::catmull_rom_weights; texels clamped to `size`).
vec4 filtered(sampler2DArray hist, vec2 at, ivec2 size, int layer) {
    vec2 t = at - 0.5;
    vec2 f = fract(t);
    ivec2 base = ivec2(floor(t)) - 1;
    vec2 w[4];
    catmull_rom_weights(f, w);
    vec4 sum = vec4(0.0);
    for (int j = 0; j < 4; j++) {
        for (int i = 0; i < 4; i++) {
            ivec2 q = clamp(base + ivec2(i, j), ivec2(0), size - 1);
            sum += w[i].x * w[j].y * texelFetch(hist, ivec3(q, layer), 0);
        }
    }
    return max(sum, vec4(0.0));
}

// The Lanczos window of three lobes at x texels (view::lanczos::lanczos3),
// per axis.
vec2 lanczos3(vec2 x) {
    vec2 px = 3.14159265 * x;
    vec2 l = 3.0 * sin(px) * sin(px / 3.0) / max(px * px, vec2(1e-12));
    l = mix(l, vec2(1.0), lessThan(abs(x), vec2(1e-5)));
    return mix(l, vec2(0.0), greaterThanEqual(abs(x), vec2(3.0)));
}

// The history at eye position `at` through the renormalized Lanczos-3
// filter over the 6x6 texels around it (weights as view::lanczos::weights;
// texels clamped to `size`, as the sampler's clamp to edge does), in
// 5x5 bilinear reads: along each axis the two middle texels, whose
// weights are both positive, are read as one at their weighted position
// (view::lanczos::merged; the usual trick for Catmull-Rom, Jimenez,
// "Filmic SMAA", SIGGRAPH 2016).
vec4 filtered_lanczos(sampler2DArray hist, vec2 at, ivec2 size, int layer) {
    vec2 t = at - 0.5;
    vec2 f = fract(t);
    vec2 base = floor(t) - 2.0;
    vec2 w[6];
    vec2 total = vec2(0.0);
    for (int i = 0; i < 6; i++) {
        w[i] = lanczos3(f + float(2 - i));
        total += w[i];
    }
    // The five reads per axis: texel centres (+ 0.5) and weights.
    vec2 mid = w[2] + w[3];
    vec2 pos[5] = vec2[5](base + 0.5, base + 1.5, base + 2.5 + w[3] / mid, base + 4.5, base + 5.5);
    vec2 wt[5] = vec2[5](w[0], w[1], mid, w[4], w[5]);
    vec2 inv = 1.0 / vec2(size);
    vec4 sum = vec4(0.0);
    for (int j = 0; j < 5; j++) {
        vec4 row = vec4(0.0);
        for (int i = 0; i < 5; i++) {
            vec2 uv = vec2(pos[i].x, pos[j].y) * inv;
            row += wt[i].x * textureLod(hist, vec3(uv, float(layer)), 0.0);
        }
        sum += wt[j].y * row;
    }
    return max(sum / (total.x * total.y), vec4(0.0));
}

vec4 resolve(sampler2DArray cur, sampler2DArray dep, sampler2DArray hist, ivec2 p,
             ivec2 wsize, ivec2 esize) {
    vec2 s = vec2(wsize) / vec2(esize);
    vec2 j = vec2(pc.jitter_x, pc.jitter_y);
    // The pixel centre in unjittered wide pixels, and the texel whose area
    // holds it in the jittered image (view::taau::nearest_texel).
    vec2 u = (vec2(p) + 0.5) * s;
    ivec2 k0 = ivec2(floor(u + j));
    // The 3x3 samples: the weighted estimate and its weight
    // (view::taau::estimate), their YCoCg box, and the nearest depth
    // (reverse-Z: the largest), whose surface the pixel is reprojected
    // with.
    vec3 sum = vec3(0.0);
    float total = 0.0;
    vec3 lo = vec3(1e30);
    vec3 hi = vec3(-1e30);
    vec3 m1 = vec3(0.0);
    vec3 m2 = vec3(0.0);
    float z = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 k = clamp(k0 + ivec2(dx, dy), ivec2(0), wsize - 1);
            ivec3 q = ivec3(k, int(pc.layer));
            vec3 c = texelFetch(cur, q, 0).rgb;
            // The sample's scene point k + 0.5 - j, its offset from the
            // pixel centre in eye pixels (view::taau::sample_position).
            vec2 d = (vec2(k) + 0.5 - j - u) / s;
            float w = exp(-GAUSSIAN_K * dot(d, d));
            sum += w * c;
            total += w;
            vec3 y = to_ycocg(c);
            lo = min(lo, y);
            hi = max(hi, y);
            m1 += y;
            m2 += y * y;
            z = max(z, texelFetch(dep, q, 0).r);
        }
    }
    vec3 x = sum / max(total, 1e-30);
    // view::taau::weight_cap.
    float cap = 3.14159265 / GAUSSIAN_K * s.x * s.y / max(pc.alpha, 1e-6);
    if (pc.valid == 0u) {
        return vec4(x, min(total, cap));
    }
    vec3 mean = m1 / 9.0;
    vec3 sigma = sqrt(max(m2 / 9.0 - mean * mean, vec3(0.0)));
    // Narrowed, but never past the estimate itself.
    vec3 own = to_ycocg(x);
    lo = min(max(lo, mean - GAMMA * sigma), own);
    hi = max(min(hi, mean + GAMMA * sigma), own);
    vec2 fsize = vec2(esize);
    vec2 ndc = (vec2(p) + 0.5) / fsize * 2.0 - 1.0;
    vec4 prev = pc.to_previous * vec4(ndc, z, 1.0);
    // Behind the previous eye, or off its view: no history.
    if (prev.w <= 0.0) {
        return vec4(x, min(total, cap));
    }
    vec2 at = (prev.xy / prev.w * 0.5 + 0.5) * fsize;
    if (any(lessThan(at, vec2(0.0))) || any(greaterThan(at, fsize))) {
        return vec4(x, min(total, cap));
    }
    vec4 h = pc.lanczos == 1u ? filtered_lanczos(hist, at, esize, int(pc.read_layer))
                              : filtered(hist, at, esize, int(pc.read_layer));
    vec3 hc = from_ycocg(clamp(to_ycocg(h.rgb), lo, hi));
    // view::taau::accumulate.
    float n = clamp(h.a, 0.0, cap);
    float beta = total / max(n + total, 1e-30);
    return vec4(hc + beta * (x - hc), min(n + total, cap));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 esize = ivec2(int(pc.eye_size & 0xffffu), int(pc.eye_size >> 16));
    ivec2 wsize = ivec2(int(pc.size & 0xffffu), int(pc.size >> 16));
    if (p.x >= esize.x || p.y >= esize.y) {
        return;
    }
    // Constant indices into the arrays (no dynamic indexing needed).
    ivec3 o = ivec3(p, int(pc.write_layer));
    if (pc.set == 0u) {
        imageStore(next[0], o, resolve(current[0], depth[0], history[0], p, wsize, esize));
    } else {
        imageStore(next[1], o, resolve(current[1], depth[1], history[1], p, wsize, esize));
    }
}
