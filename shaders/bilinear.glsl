// Bilinear reads in texel space: `p` is a continuous pixel position
// (texel i's centre at i + 0.5) within the first `size` texels of the
// image (the part drawn this frame), which are clamped to as
// clamp-to-edge clamps to the whole image. The weights are computed in
// full float precision from `p` alone, so the same position reads the
// same value whatever size the image was made at (a sampler's normalized
// coordinates and its sub-texel precision would not). texelFetch decodes
// sRGB, so the mix is in linear light as a sampler's. Included by
// mffr_composite.frag.
vec4 bilinear_mix(vec4 a, vec4 b, vec4 c, vec4 d, vec2 f) {
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

vec4 bilinear(sampler2D t, vec2 p, ivec2 size) {
    vec2 q = p - 0.5;
    ivec2 i = ivec2(floor(q));
    vec2 f = q - vec2(i);
    ivec2 lo = clamp(i, ivec2(0), size - 1);
    ivec2 hi = clamp(i + 1, ivec2(0), size - 1);
    return bilinear_mix(texelFetch(t, lo, 0), texelFetch(t, ivec2(hi.x, lo.y), 0),
        texelFetch(t, ivec2(lo.x, hi.y), 0), texelFetch(t, hi, 0), f);
}

vec4 bilinear(sampler2DArray t, vec2 p, int layer, ivec2 size) {
    vec2 q = p - 0.5;
    ivec2 i = ivec2(floor(q));
    vec2 f = q - vec2(i);
    ivec2 lo = clamp(i, ivec2(0), size - 1);
    ivec2 hi = clamp(i + 1, ivec2(0), size - 1);
    return bilinear_mix(texelFetch(t, ivec3(lo, layer), 0), texelFetch(t, ivec3(hi.x, lo.y, layer), 0),
        texelFetch(t, ivec3(lo.x, hi.y, layer), 0), texelFetch(t, ivec3(hi, layer), 0), f);
}
