// Smooth dielectric (Mitsuba 3's `dielectric`): Fresnel-weighted mirror and refraction.
//
// Bsdf fields: eta = int_ior / ext_ior; c0 = specular reflectance, c1 = specular
// transmittance (tints; 1 for realism). Both lobes are Dirac deltas (eval and pdf
// are zero); the surface answers on both sides (wo.z < 0 is inside).
// The lobe is chosen by sampling the Fresnel term (lecture 13's discrete example:
// reflect with probability F, refract with 1 - F; sampling/discrete.glsl), so the
// weight of either lobe is its tint alone (F / F, (1 - F) / (1 - F)).
//
// Transport direction: radiance crossing into a medium of relative IOR eta_it is
// compressed into a smaller solid angle, L_t = (1 - F) L_i / eta_it^2 (Veach 1997,
// sec. 5.2), so the refraction weight carries eta_ti^2 = 1 / eta_it^2 for radiance and
// 1 for importance (adjoint = true: light tracing, photons).
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"
#include "sampling/discrete.glsl"

// Chooses the mirror (u_lobe < F) or the refracted direction of wo; pdf = the
// probability of the chosen lobe; eta = the relative IOR crossed (1 when reflecting).
BsdfSample dielectric_sample(Bsdf b, vec3 wo, float u_lobe, bool adjoint) {
    FresnelDielectric fr = fresnel_dielectric(wo.z, b.eta);
    DiscreteSample lobe = choose_reflect_transmit(fr.F, u_lobe);
    bool reflected = lobe.index == 0u;
    vec3 wi = reflected ? reflect_local(wo) : refract_local(wo, fr.cos_theta_t, fr.eta_ti);
    float scale = adjoint ? 1.0 : fr.eta_ti * fr.eta_ti;
    vec3 weight = reflected ? b.c0 : b.c1 * scale;
    return BsdfSample(wi, weight, lobe.pmf, reflected ? 1.0 : fr.eta_it, true, true);
}
