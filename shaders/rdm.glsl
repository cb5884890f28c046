// Radial density masking's checkerboard (rdm.frag writes it to stencil,
// rdm_fill.frag and rdm_fill_in_place.comp fill it): the pixel at `frag` (gl_FragCoord.xy) of an image
// `size` pixels large is skipped when its 2×2 quad is a "black" checker
// square and its centre lies at least `radius` from the image centre in NDC.
bool rdm_skipped(vec2 frag, vec2 size, float radius) {
    ivec2 quad = ivec2(frag) >> 1;
    vec2 ndc = frag / size * 2.0 - 1.0;
    return ((quad.x + quad.y) & 1) == 1 && length(ndc) >= radius;
}
