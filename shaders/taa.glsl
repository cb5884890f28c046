// What the inset's accumulation (inset_taa.comp), upsampling
// (inset_taau.comp) and composite (inset_composite.comp) share: YCoCg (view::taa::to_ycocg / from_ycocg) and
// the Catmull-Rom weights of the four texels around a read at fraction f
// past the second texel's centre, per axis (view::taa::catmull_rom_weights).

vec3 to_ycocg(vec3 c) {
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b,
                0.5 * c.r - 0.5 * c.b,
                -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}

vec3 from_ycocg(vec3 c) {
    return vec3(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z);
}

void catmull_rom_weights(vec2 f, out vec2 w[4]) {
    w[0] = f * (-0.5 + f * (1.0 - 0.5 * f));
    w[1] = 1.0 + f * f * (-2.5 + 1.5 * f);
    w[2] = f * (0.5 + f * (2.0 - 1.5 * f));
    w[3] = f * f * (-0.5 + 0.5 * f);
}
