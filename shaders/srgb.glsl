// The sRGB transfer function's encoding (IEC 61966-2-1: linear below
// 0.0031308, else 1.055 c^(1/2.4) - 0.055), for compute shaders that store
// into a UNORM view of an sRGB image (hardware encodes only on attachment
// and sRGB-view writes). Included by msaa_resolve.comp and
// inset_composite.comp.
vec3 encode_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 lo = c * 12.92;
    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(hi, lo, lessThanEqual(c, vec3(0.0031308)));
}
