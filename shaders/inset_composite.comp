#version 450
#extension GL_GOOGLE_include_directive : require
#include "srgb.glsl"
#include "taa.glsl"
// Multi-resolution foveated rendering's composite (src/view/inset.rs), in
// compute: the eye pixel takes the wide view, upsampled from its lower
// resolution at the same image position, bilinearly or (pc.filter_, the
// option inset-catmull-rom) through the Catmull-Rom filter (the sampler
// and texelFetch decode sRGB before filtering; the wide view lies in a
// region of its frame,
// the whole of a frame of its own or, with four views, a region of
// layers 2 and 3 of the eye's frame, read clamped to the region's edge
// texel centres as clamp-to-edge reads a whole image), and inside the
// inset rectangle the
// full-density inset, fading over `feather` pixels inside its edge (the
// same weight as view::inset::weight, at the pixel centre). One
// invocation per pixel of layer gl_GlobalInvocationID.z of attachment set
// pc.set; the result is encoded to sRGB and stored through the output
// image's UNORM view.
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(set = 0, binding = 0) uniform sampler2DArray inset_frames[2];
layout(set = 0, binding = 1) uniform sampler2DArray wide_frames[2];
layout(set = 0, binding = 2, rgba8) uniform writeonly image2DArray composed[2];

layout(push_constant) uniform Push {
    uint lo;       // x0 | y0 << 16
    uint hi;       // x1 | y1 << 16
    uint feather;  // float bits, pixels
    uint set;      // attachment set (0 or 1)
    uint wide_lo;  // the wide view's region in its frame: x0 | y0 << 16
    uint wide_size; // and its width | height << 16
    uint wide_layer; // the wide frame's layer of eye layer 0
    uint eye_size; // the eyes' drawn size, width | height << 16 (with aq
                   // smaller than the images)
    uint filter_;  // the wide view's upsampling: 0 bilinear, 1 Catmull-Rom,
                   // 2 none (inset-taau: the wide view is the eye-sized
                   // history, read at the pixel; its alpha is a weight, the
                   // output opaque)
    float sharpen; // inset-sharpen's strength with filter 2 (0: off)
} pc;

// The wide view at `q` (pixels of its region, centres at + 0.5) through
// the Catmull-Rom filter (Keys 1981, a = -1/2; weights as
// view::taa::catmull_rom_weights) over the 4x4 texels around it, clamped
// to the region: sharper than the bilinear read, whose ramp spreads an
// edge over 2 / s eye pixels, and interpolating (texel centres keep
// their values). Negative lobes can overshoot at an edge: the result is
// clamped to the 2x2 texels nearest q (the bilinear read's range), so no
// ringing outside what the texels hold.
vec4 catmull_rom(sampler2DArray frame, vec2 q, ivec2 origin, ivec2 size, int layer) {
    vec2 t = q - 0.5;
    vec2 f = fract(t);
    ivec2 base = ivec2(floor(t)) - 1;
    vec2 w[4];
    catmull_rom_weights(f, w);
    vec4 sum = vec4(0.0);
    vec4 lo = vec4(1e30);
    vec4 hi = vec4(-1e30);
    for (int j = 0; j < 4; j++) {
        for (int i = 0; i < 4; i++) {
            ivec2 k = clamp(base + ivec2(i, j), ivec2(0), size - 1);
            vec4 c = texelFetch(frame, ivec3(origin + k, layer), 0);
            sum += w[i].x * w[j].y * c;
            if ((i == 1 || i == 2) && (j == 1 || j == 2)) {
                lo = min(lo, c);
                hi = max(hi, c);
            }
        }
    }
    return clamp(sum, lo, hi);
}

// The eye-sized history at `p` sharpened against its four edge
// neighbours with strength `s`, clamped to their and its range per
// channel (inset-sharpen; view::sharpen::sharpen, which has the
// derivation; neighbours past the border clamped to it).
vec3 sharpened(sampler2DArray hist, ivec2 p, int layer, ivec2 size, float s) {
    vec3 c = texelFetch(hist, ivec3(p, layer), 0).rgb;
    if (s <= 0.0) {
        return c;
    }
    ivec2 last = size - 1;
    vec3 l = texelFetch(hist, ivec3(clamp(p - ivec2(1, 0), ivec2(0), last), layer), 0).rgb;
    vec3 r = texelFetch(hist, ivec3(clamp(p + ivec2(1, 0), ivec2(0), last), layer), 0).rgb;
    vec3 u = texelFetch(hist, ivec3(clamp(p - ivec2(0, 1), ivec2(0), last), layer), 0).rgb;
    vec3 d = texelFetch(hist, ivec3(clamp(p + ivec2(0, 1), ivec2(0), last), layer), 0).rgb;
    vec3 lo = min(c, min(min(l, r), min(u, d)));
    vec3 hi = max(c, max(max(l, r), max(u, d)));
    return clamp(c + s * (c - 0.25 * (l + r + u + d)), lo, hi);
}

vec4 composite(sampler2DArray inset_frame, sampler2DArray wide_frame, ivec3 p) {
    vec2 size = vec2(float(pc.eye_size & 0xffffu), float(pc.eye_size >> 16));
    vec2 at = vec2(p.xy) + 0.5;
    vec2 wsize = vec2(float(pc.wide_size & 0xffffu), float(pc.wide_size >> 16));
    vec2 worigin = vec2(float(pc.wide_lo & 0xffffu), float(pc.wide_lo >> 16));
    vec2 q = clamp(at / size * wsize, vec2(0.5), wsize - 0.5);
    int layer = p.z + int(pc.wide_layer);
    vec4 wide;
    if (pc.filter_ == 2u) {
        wide = vec4(sharpened(wide_frame, p.xy, layer, ivec2(size), pc.sharpen), 1.0);
    } else if (pc.filter_ == 0u) {
        vec2 uv = (worigin + q) / vec2(textureSize(wide_frame, 0).xy);
        wide = texture(wide_frame, vec3(uv, float(layer)));
    } else {
        wide = catmull_rom(wide_frame, q, ivec2(worigin), ivec2(wsize), layer);
    }
    vec2 lo = vec2(float(pc.lo & 0xffffu), float(pc.lo >> 16));
    vec2 hi = vec2(float(pc.hi & 0xffffu), float(pc.hi >> 16));
    float d = min(min(at.x - lo.x, hi.x - at.x), min(at.y - lo.y, hi.y - at.y));
    float w = clamp(d / max(uintBitsToFloat(pc.feather), 1e-6), 0.0, 1.0);
    // Outside the rectangle the inset image was never drawn: select, do not
    // blend, so nothing of it reaches the pixel.
    if (w <= 0.0) {
        return wide;
    }
    // Deep inside, the inset alone (a select, not mix's arithmetic: the
    // wide views' hole, src/view/inset_hole.rs, relies on it).
    vec4 inset = texelFetch(inset_frame, p, 0);
    return w >= 1.0 ? inset : mix(wide, inset, w);
}

void main() {
    ivec3 p = ivec3(gl_GlobalInvocationID);
    // Constant indices into the arrays (no dynamic indexing needed).
    ivec2 size = ivec2(int(pc.eye_size & 0xffffu), int(pc.eye_size >> 16));
    if (p.x >= size.x || p.y >= size.y) {
        return;
    }
    vec4 c = pc.set == 0u ? composite(inset_frames[0], wide_frames[0], p)
                          : composite(inset_frames[1], wide_frames[1], p);
    vec4 out_c = vec4(encode_srgb(c.rgb), c.a);
    if (pc.set == 0u) {
        imageStore(composed[0], p, out_c);
    } else {
        imageStore(composed[1], p, out_c);
    }
}
