// Smooth plastic (Mitsuba 3's `plastic`): a diffuse base under a smooth dielectric coating.
//
// Bsdf fields: c0 = diffuse reflectance rho, c1 = specular reflectance (tint of the
// coating's mirror lobe), eta = int_ior / ext_ior, c2.x = specular sampling weight
// w = mean(c1) / (mean(rho) + mean(c1)), c2.y = Fdr_int = the coating's diffuse
// reflectance from inside (Fdr(1 / eta), glrender/gpu/pack.py); the nonlinear flag.
// Lobes (Mitsuba 3; Weidlich & Wilkie 2007 for the layering):
//   specular: a Dirac mirror lobe of weight c1 F(cos theta_o);
//   diffuse:  f |cos theta_i| = rho' (1 - F_o) (1 - F_i) cos theta_i / (pi eta^2),
//             rho' = rho / (1 - Fdr_int) (or rho / (1 - rho Fdr_int) if nonlinear:
//             the inter-reflections inside the coating tint the colour).
// eval and pdf cover the diffuse lobe only. The lobe is sampled with
// P(specular) = F_o w / (F_o w + (1 - F_o)(1 - w)). One-sided; reflection only, so
// radiance and importance transport agree.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"
#include "common/constants.glsl"
#include "sampling/hemisphere.glsl"

// The diffuse albedo after the coating's internal reflections (rho' above).
vec3 plastic_diffuse_albedo(Bsdf b) {
    bool nonlinear = (b.flags & kMaterialFlagNonlinear) != 0u;
    return b.c0 / (1.0 - (nonlinear ? b.c0 * b.c2.y : vec3(b.c2.y)));
}

// Probability of sampling the specular lobe given the coating's reflectance R_o at wo:
// R_o w / (R_o w + (1 - R_o)(1 - w)), w = c2.x the specular sampling weight.
float plastic_specular_probability(Bsdf b, float R_o) {
    float p_s = R_o * b.c2.x;
    float p_d = (1.0 - R_o) * (1.0 - b.c2.x);
    return p_s / (p_s + p_d);
}

// f |cos theta_i| of the diffuse lobe and (out) its solid-angle pdf.
vec3 plastic_eval_pdf(Bsdf b, vec3 wo, vec3 wi, out float pdf) {
    pdf = 0.0;
    if (!(wo.z > 0.0 && wi.z > 0.0)) return vec3(0.0);
    float F_o = fresnel_dielectric(wo.z, b.eta).F;
    float F_i = fresnel_dielectric(wi.z, b.eta).F;
    float cos_pdf = cosine_hemisphere_pdf(wi.z);  // cos theta_i / pi
    pdf = (1.0 - plastic_specular_probability(b, F_o)) * cos_pdf;
    return plastic_diffuse_albedo(b) * (cos_pdf / (b.eta * b.eta) * (1.0 - F_o) * (1.0 - F_i));
}

// u_lobe in [0,1) picks the mirror (delta, pdf = its probability) or the diffuse lobe
// (cosine-weighted by u in [0,1)^2, pdf per solid angle).
BsdfSample plastic_sample(Bsdf b, vec3 wo, float u_lobe, vec2 u) {
    if (!(wo.z > 0.0)) return bsdf_sample_invalid();
    float F_o = fresnel_dielectric(wo.z, b.eta).F;
    float p_s = plastic_specular_probability(b, F_o);
    if (u_lobe < p_s)
        return BsdfSample(reflect_local(wo), b.c1 * (F_o / p_s), p_s, 1.0, true, true);
    vec3 wi = sample_cosine_hemisphere(u);
    float pdf;
    vec3 f = plastic_eval_pdf(b, wo, wi, pdf);
    bool ok = pdf > 0.0;
    return BsdfSample(wi, ok ? f / pdf : vec3(0.0), pdf, 1.0, false, ok);
}
