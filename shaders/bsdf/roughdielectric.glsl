// Rough dielectric (Mitsuba 3's `roughdielectric`): microfacet reflection and refraction.
//
// Walter, Marschner, Li, Torrance, "Microfacet Models for Refraction through Rough
// Surfaces", EGSR 2007. Bsdf fields: eta = int_ior / ext_ior; c0 = specular
// reflectance, c1 = specular transmittance; alpha and the GGX flag pick the
// distribution. The surface answers on both sides (wo.z < 0 is inside). With eta the
// relative IOR seen from wo's side, the generalized half vector is
// m = +-normalize(wo + wi) for reflection and +-normalize(wo + eta wi) for refraction
// (eq. 13 and 16), oriented to +z, and
//   reflection:  f |cos theta_i| = c0 F D G / (4 |cos theta_o|)                  (eq. 20)
//   refraction:  f |cos theta_i| = c1 s (1 - F) D G eta^2 |wo.m| |wi.m|
//                                  / (|cos theta_o| (wo.m + eta wi.m)^2)        (eq. 21)
// with F = F(wo.m), G = G1(wo, m) G1(wi, m). Sampling: a visible normal of wo (Heitz &
// d'Eon 2014), then reflect with probability F or refract (choose_reflect_transmit);
// pdf = D_wo(m) (F or 1 - F) |dm/dwi| with |dm/dwi| = 1 / (4 |wi.m|) (eq. 14) or
// eta^2 |wi.m| / (wo.m + eta wi.m)^2 (eq. 17). Total internal reflection: F = 1.
//
// Transport direction: s = 1 / eta^2 for radiance, 1 for importance (adjoint), the
// solid-angle compression across the interface (Veach 1997, sec. 5.2; the term the
// paper omits). Then f_importance(wo, wi) = f_radiance(wi, wo): the adjoint BSDF is
// the transposed one. Reflection is symmetric.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"
#include "bsdf/microfacet_distribution.glsl"
#include "sampling/discrete.glsl"

// f |cos theta_i| and (out) the solid-angle pdf of wi, sharing the half vector.
vec3 roughdielectric_eval_pdf(Bsdf b, vec3 wo, vec3 wi, bool adjoint, out float pdf) {
    pdf = 0.0;
    if (wo.z == 0.0) return vec3(0.0);
    bool reflected = wo.z * wi.z > 0.0;
    float eta = wo.z > 0.0 ? b.eta : 1.0 / b.eta;
    vec3 m = normalize(wo + wi * (reflected ? 1.0 : eta));
    if (m.z < 0.0) m = -m;
    Microfacet md = microfacet_from_bsdf(b);
    float dot_o = dot(wo, m);
    float dot_i = dot(wi, m);
    float D = microfacet_d(md, m);
    float F = fresnel_dielectric(dot_o, b.eta).F;
    float G = microfacet_g(md, wo, wi, m);
    float denom = dot_o + eta * dot_i;
    float scale = adjoint ? 1.0 : 1.0 / (eta * eta);

    // Density: the visible normal of wo (flipped up), the lobe choice, the Jacobian
    if (dot_o * wo.z > 0.0 && dot_i * wi.z > 0.0) {
        float dm_dwi = reflected ? 1.0 / (4.0 * dot_i) : eta * eta * dot_i / (denom * denom);
        float pdf_m = microfacet_visible_normal_pdf(md, wo.z > 0.0 ? wo : -wo, m);
        pdf = pdf_m * (reflected ? F : 1.0 - F) * abs(dm_dwi);
    }
    if (reflected) return b.c0 * (F * D * G / (4.0 * abs(wo.z)));
    return b.c1 * abs(scale * (1.0 - F) * D * G * eta * eta * dot_o * dot_i / (wo.z * denom * denom));
}

// u in [0,1)^2 picks a visible normal, u_lobe in [0,1) reflection or refraction. A
// direction that leaves on the wrong side of the surface (shadowed by the
// macro-surface) is invalid: its probability is energy lost, as in Mitsuba.
BsdfSample roughdielectric_sample(Bsdf b, vec3 wo, float u_lobe, vec2 u, bool adjoint) {
    if (wo.z == 0.0) return bsdf_sample_invalid();
    vec3 m = sample_microfacet_visible_normal(microfacet_from_bsdf(b), wo.z > 0.0 ? wo : -wo, u);
    FresnelDielectric fr = fresnel_dielectric(dot(wo, m), b.eta);
    bool reflected = choose_reflect_transmit(fr.F, u_lobe).index == 0u;
    vec3 wi = reflected ? reflect_about(wo, m) : refract_about(wo, m, fr.cos_theta_t, fr.eta_ti);
    float pdf;
    vec3 f = roughdielectric_eval_pdf(b, wo, wi, adjoint, pdf);
    bool ok = (reflected ? wo.z * wi.z > 0.0 : wo.z * wi.z < 0.0) && pdf > 0.0;
    return BsdfSample(wi, ok ? f / pdf : vec3(0.0), pdf, reflected ? 1.0 : fr.eta_it, false, ok);
}
