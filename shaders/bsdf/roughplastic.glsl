// Rough plastic (Mitsuba 3's `roughplastic`): a diffuse base under a rough dielectric coating.
//
// Bsdf fields: c0 = diffuse reflectance rho, c1 = specular reflectance, eta =
// int_ior / ext_ior, alpha (isotropic: alpha.x is used) and the GGX flag, c2.x =
// specular sampling weight w (as for plastic), c2.y = R_int = the coating's
// hemispherical reflectance from inside; the nonlinear flag; `material` indexes
// T(cos theta), the coating's directional transmittance from outside, tabulated by
// the host at 64 evenly spaced cosines in [0, 1] and interpolated linearly (both
// exactly as Mitsuba 3 computes them: glrender/gpu/microfacet_tables.py); with the flag
// kMaterialFlagAlphaTable (per-texel roughness, bsdf/metallic_roughness.glsl) T comes from
// the table over alpha of the metallic-roughness coating instead (GGX, eta 1.5). Lobes:
//   glossy:  f |cos theta_i| = c1 F(wo.m) D G / (4 cos theta_o)   (roughconductor's form)
//   diffuse: f |cos theta_i| = rho' T(cos theta_o) T(cos theta_i) cos theta_i / (pi eta^2),
//            rho' = rho / (1 - R_int) (or rho / (1 - rho R_int) if nonlinear).
// Sampling picks the glossy lobe with P = (1 - T_o) w / ((1 - T_o) w + T_o (1 - w))
// (plastic's rule with the coating reflectance 1 - T_o), then a visible normal or a
// cosine-weighted direction; pdf is the mixture of both.
// One-sided; reflection only, so radiance and importance transport agree.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"
#include "bsdf/microfacet_distribution.glsl"
#include "bsdf/plastic.glsl"
#include "common/constants.glsl"
#include "common/params.glsl"
#include "sampling/hemisphere.glsl"

// Element i in [0, 64) of the transmittance table of material record `material`.
// Defined where the data lives (bsdf/material.glsl reads scene/layout.glsl's
// MaterialData; tests define it over their own buffer). Mesa refuses to link a call
// to an undefined prototype even from dead code: whoever includes bsdf/bsdf.glsl
// defines it.
float material_table_fetch(uint material, uint i);

const uint kRoughPlasticTableSize = 64u;

#if GLRENDER_METALLIC_ROUGHNESS
// Element i of the coating table over alpha (scene/layout.glsl u_microfacet_tables): row j
// holds T at the 64 cosines, then R_int, for sqrt(alpha) = kAlphaTableMinRoughness + j
// (1 - kAlphaTableMinRoughness) / (kAlphaTableRows - 1). Defined where the data lives
// (bsdf/material.glsl; tests define it over their own buffer).
float alpha_table_fetch(uint i);

// The table's shape: glrender/gpu/microfacet_tables.py ALPHA_TABLE_ROWS, sqrt(ALPHA_TABLE_MIN).
const uint kAlphaTableRows = 32u;
const uint kAlphaTableColumns = kRoughPlasticTableSize + 1u;
const float kAlphaTableMinRoughness = 0.031622776601683794;

// Column `column` of the table over alpha at alpha (clamped to the table's range): linear
// interpolation between the rows around sqrt(alpha).
float alpha_table_lookup(float alpha, uint column) {
    float x = clamp((sqrt(alpha) - kAlphaTableMinRoughness) / (1.0 - kAlphaTableMinRoughness), 0.0, 1.0) *
              float(kAlphaTableRows - 1u);
    uint j = min(uint(x), kAlphaTableRows - 2u);
    return mix(alpha_table_fetch(j * kAlphaTableColumns + column),
               alpha_table_fetch((j + 1u) * kAlphaTableColumns + column), x - float(j));
}

// R_int of the metallic-roughness coating at alpha (bilinear in the table over alpha).
float alpha_table_internal_reflectance(float alpha) {
    return alpha_table_lookup(alpha, kRoughPlasticTableSize);
}
#endif

// T(cos_theta) for cos_theta in [0, 1]: linear interpolation of the table (with
// kMaterialFlagAlphaTable: bilinear in (sqrt(alpha), cos theta) of the table over alpha).
float roughplastic_transmittance(Bsdf b, float cos_theta) {
    float x = cos_theta * float(kRoughPlasticTableSize - 1u);
    uint i = min(uint(x), kRoughPlasticTableSize - 2u);
#if GLRENDER_METALLIC_ROUGHNESS
    if ((b.flags & kMaterialFlagAlphaTable) != 0u)
        return mix(alpha_table_lookup(b.alpha.x, i), alpha_table_lookup(b.alpha.x, i + 1u), x - float(i));
#endif
    return mix(material_table_fetch(b.material, i), material_table_fetch(b.material, i + 1u),
               x - float(i));
}

// f |cos theta_i| and (out) the solid-angle pdf of wi, sharing the half vector.
vec3 roughplastic_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (!(wo.z > 0.0 && wi.z > 0.0)) return vec3(0.0);
    Microfacet md = microfacet_from_bsdf(b);
    md.alpha = md.alpha.xx;
    vec3 m = normalize(wo + wi);
    float D = microfacet_d(md, m);
    float F = fresnel_dielectric(dot(wo, m), b.eta).F;
    float G = microfacet_g(md, wo, wi, m);
    float T_o = roughplastic_transmittance(b, wo.z);
    float T_i = roughplastic_transmittance(b, wi.z);
    float p_s = plastic_specular_probability(b, 1.0 - T_o);
    pdf = p_s * microfacet_reflection_pdf(md, wo, m) +
          (1.0 - p_s) * cosine_hemisphere_pdf(wi.z);
    return b.c1 * (F * D * G / (4.0 * wo.z)) +
           plastic_diffuse_albedo(b) * (kInvPi / (b.eta * b.eta) * wi.z * T_o * T_i);
}

// u_lobe in [0,1) picks the lobe, u in [0,1)^2 the direction; weight = f / pdf of the
// mixture. A glossy reflection below the surface is invalid (lost energy, as in Mitsuba).
BsdfSample roughplastic_sample(Bsdf b, vec3 wo, float u_lobe, vec2 u) {
    if (!(wo.z > 0.0)) return bsdf_sample_invalid();
    float p_s = plastic_specular_probability(b, 1.0 - roughplastic_transmittance(b, wo.z));
    Microfacet md = microfacet_from_bsdf(b);
    md.alpha = md.alpha.xx;
    vec3 wi = u_lobe < p_s ? reflect_about(wo, sample_microfacet_visible_normal(md, wo, u))
                           : sample_cosine_hemisphere(u);
    float pdf;
    vec3 f = roughplastic_eval_pdf(b, wo, wi, pdf);
    bool ok = wi.z > 0.0 && pdf > 0.0;
    return BsdfSample(wi, ok ? f / pdf : vec3(0.0), pdf, 1.0, false, ok);
}
