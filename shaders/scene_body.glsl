// The scene fragment shader body, shared by scene.frag and scene_early.frag
// (the latter forces early fragment tests for variants that never discard).
#extension GL_EXT_multiview : require
#include "common.glsl"

layout(constant_id = 0) const int TEXTURE_COUNT = 1;
layout(constant_id = 1) const int ALPHA_MODE = 0;   // 0 opaque, 1 mask, 2 blend
layout(constant_id = 2) const bool HAS_TANGENTS = false;
layout(constant_id = 3) const bool UNLIT = false;

layout(std430, set = 0, binding = 3) readonly buffer Materials { MaterialData materials[]; };
layout(set = 0, binding = 4) uniform sampler2D textures[TEXTURE_COUNT];

layout(location = 0) in vec3 v_pos;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec4 v_tangent;
layout(location = 3) in vec4 v_uv;
layout(location = 4) in vec4 v_color;
layout(location = 5) flat in uint v_material;
layout(location = 0) out vec4 out_color;

const float PI = 3.14159265358979;

vec4 sample_slot(MaterialData m, int slot, int tex) {
    vec2 uv = ((m.tex1.y >> slot) & 1) != 0 ? v_uv.zw : v_uv.xy;
    return texture(textures[tex], uv);
}

// Metallic-roughness BRDF as in the glTF 2.0 specification, Appendix B:
// GGX distribution, height-correlated Smith visibility, Schlick Fresnel.
vec3 brdf(vec3 n, vec3 v, vec3 l, vec3 base, float metallic, float alpha) {
    vec3 h = normalize(l + v);
    float nl = max(dot(n, l), 0.0);
    float nv = max(dot(n, v), 1e-4);
    float nh = max(dot(n, h), 0.0);
    float vh = max(dot(v, h), 0.0);
    float a2 = alpha * alpha;
    float d = a2 / (PI * pow(nh * nh * (a2 - 1.0) + 1.0, 2.0));
    float vis = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2) + 1e-6);
    vec3 f0 = mix(vec3(0.04), base, metallic);
    vec3 f = f0 + (1.0 - f0) * pow(1.0 - vh, 5.0);
    vec3 diffuse = (1.0 - f) * (1.0 - metallic) * base / PI;
    return (diffuse + f * d * vis) * nl;
}

void main() {
    MaterialData m = materials[v_material];
    vec4 base = m.base_color * v_color;
    if (m.tex0.x >= 0) base *= sample_slot(m, 0, m.tex0.x);
    if (ALPHA_MODE == 1 && base.a < m.emissive_cutoff.a) discard;
    if (UNLIT) {
        out_color = vec4(base.rgb, ALPHA_MODE == 2 ? base.a : 1.0);
        return;
    }
    vec4 mr = m.tex0.y >= 0 ? sample_slot(m, 1, m.tex0.y) : vec4(1.0);
    vec4 nt = m.tex0.z >= 0 ? sample_slot(m, 2, m.tex0.z) : vec4(0.5, 0.5, 1.0, 1.0);
    vec4 ao = m.tex0.w >= 0 ? sample_slot(m, 3, m.tex0.w) : vec4(1.0);
    vec4 em = m.tex1.x >= 0 ? sample_slot(m, 4, m.tex1.x) : vec4(1.0);
    float metallic = clamp(m.mr_scales.x * mr.b, 0.0, 1.0);
    float roughness = clamp(m.mr_scales.y * mr.g, 0.04, 1.0);
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    if (HAS_TANGENTS && m.tex0.z >= 0) {
        vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));
        vec3 b = cross(n, t) * v_tangent.w;
        vec3 tn = (nt.xyz * 2.0 - 1.0) * vec3(m.mr_scales.z, m.mr_scales.z, 1.0);
        n = normalize(mat3(t, b, n) * tn);
    }
    uint view = gl_ViewIndex + pc.view_offset;
    vec3 v = normalize(frame.eye_rel[view].xyz - v_pos);
    vec3 l = normalize(frame.sun_dir.xyz);
    vec3 color = brdf(n, v, l, base.rgb, metallic, roughness * roughness) * frame.sun_color.rgb;
    // Hemispheric ambient between ground and sky colours.
    vec3 ambient = mix(frame.ground.rgb, frame.sky_zenith.rgb, 0.5 + 0.5 * n.y);
    float occlusion = mix(1.0, ao.r, m.mr_scales.w);
    color += ambient * base.rgb * occlusion;
    color += m.emissive_cutoff.rgb * em.rgb;
    out_color = vec4(color, ALPHA_MODE == 2 ? base.a : 1.0);
}
