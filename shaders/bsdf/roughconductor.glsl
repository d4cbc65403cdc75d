// Rough conductor (Mitsuba 3's `roughconductor`): Walter et al. 2007 microfacet reflection.
//
// Bsdf fields: c0 = eta, c2 = k, c1 = specular reflectance; alpha (anisotropic) and the
// GGX flag pick the distribution. f |cos theta_i| = c1 F(wo.m) D(m) G(wo, wi, m) /
// (4 cos theta_o) with m = normalize(wo + wi) (Walter et al. 2007, eq. 20), zero unless
// both directions are above the surface. wi is sampled by reflecting wo about a
// visible normal (Heitz & d'Eon 2014): pdf = D_wo(m) / (4 wi.m). Reflection is
// symmetric: radiance and importance transport agree.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"
#include "bsdf/microfacet_distribution.glsl"

// f |cos theta_i| and (out) the solid-angle pdf of wi, sharing the half vector.
vec3 roughconductor_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (!(wo.z > 0.0 && wi.z > 0.0)) return vec3(0.0);
    Microfacet md = microfacet_from_bsdf(b);
    vec3 m = normalize(wo + wi);
    pdf = microfacet_reflection_pdf(md, wo, m);
    float D = microfacet_d(md, m);
    float G = microfacet_g(md, wo, wi, m);
    return b.c1 * fresnel_conductor(dot(wo, m), b.c0, b.c2) * (D * G / (4.0 * wo.z));
}

// Reflects wo about a visible microfacet normal sampled with u in [0,1)^2; invalid when
// the reflection leaves below the surface (that probability is lost energy, as in Mitsuba).
BsdfSample roughconductor_sample(Bsdf b, vec3 wo, vec2 u) {
    if (!(wo.z > 0.0)) return bsdf_sample_invalid();
    vec3 m = sample_microfacet_visible_normal(microfacet_from_bsdf(b), wo, u);
    vec3 wi = reflect_about(wo, m);
    float pdf;
    vec3 f = roughconductor_eval_pdf(b, wo, wi, pdf);
    bool ok = wi.z > 0.0 && pdf > 0.0;
    return BsdfSample(wi, ok ? f / pdf : vec3(0.0), pdf, 1.0, false, ok);
}
