// Smooth conductor (Mitsuba 3's `conductor`): a mirror with the complex Fresnel term.
//
// Bsdf fields: c0 = eta, c2 = k (complex IOR eta + i k per channel), c1 = specular
// reflectance (a tint; 1 for realism). One-sided: wo below the surface reflects
// nothing. The single lobe is a Dirac delta, so eval and pdf are zero for every
// direction pair, and sampling is deterministic (the lobe's probability is 1).
// Radiance and importance transport agree (reflection is symmetric).
#include "bsdf/bsdf_common.glsl"
#include "bsdf/fresnel.glsl"

// The mirror direction of wo (u is unused): weight = c1 F(cos theta_o), pdf = 1.
BsdfSample conductor_sample(Bsdf b, vec3 wo) {
    bool ok = wo.z > 0.0;
    vec3 weight = ok ? b.c1 * fresnel_conductor(wo.z, b.c0, b.c2) : vec3(0.0);
    return BsdfSample(reflect_local(wo), weight, 1.0, 1.0, true, ok);
}
