// Thin dielectric sheet (Mitsuba 3's `thindielectric`): a pane of glass of no thickness.
//
// Bsdf fields: eta = int_ior / ext_ior; c0 = specular reflectance, c1 = specular
// transmittance. Light that enters the sheet leaves it undeflected, after any number
// of internal reflections: R = F + (1 - F)^2 F (1 + F^2 + F^4 + ...) = 2 F / (1 + F)
// with F = F(|cos theta_o|), and T = 1 - R (Mitsuba 3; pbrt-v4's ThinDielectricBxDF).
// Both lobes are Dirac deltas on both sides; the transmitted direction is -wo (no
// bending, no solid-angle compression), so radiance and importance transport agree.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"
#include "sampling/discrete.glsl"

// Reflectance of the sheet including its internal reflections.
float thindielectric_reflectance(float cos_theta, float eta) {
    float F = fresnel_dielectric(abs(cos_theta), eta).F;
    return 2.0 * F / (1.0 + F);
}

// Chooses the mirror direction (u_lobe < R) or straight transmission (-wo); pdf = the
// probability of the chosen lobe; the weight is that lobe's tint.
BsdfSample thindielectric_sample(Bsdf b, vec3 wo, float u_lobe) {
    DiscreteSample lobe = choose_reflect_transmit(thindielectric_reflectance(wo.z, b.eta), u_lobe);
    bool reflected = lobe.index == 0u;
    return BsdfSample(reflected ? reflect_local(wo) : -wo, reflected ? b.c0 : b.c1, lobe.pmf, 1.0,
                      true, true);
}
