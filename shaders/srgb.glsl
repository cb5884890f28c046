// The sRGB transfer function's encoding (IEC 61966-2-1: linear below
// 0.0031308, else 1.055 c^(1/2.4) - 0.055), for compute shaders that store
// into a UNORM view of an sRGB image (hardware encodes only on attachment
// and sRGB-view writes), and its decoding for those that read one (linear
// below 0.04045, else ((e + 0.055) / 1.055)^2.4). Included by
// msaa_resolve.comp, inset_composite.comp and rdm_fill_in_place.comp.
vec3 encode_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 lo = c * 12.92;
    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(hi, lo, lessThanEqual(c, vec3(0.0031308)));
}

vec3 decode_srgb(vec3 e) {
    vec3 lo = e / 12.92;
    vec3 hi = pow((e + 0.055) / 1.055, vec3(2.4));
    return mix(hi, lo, lessThanEqual(e, vec3(0.04045)));
}
