// Lambertian reflection, f = rho / pi, sampled by the cosine-weighted hemisphere.
#include "bsdf/bsdf_common.glsl"
#include "common/constants.glsl"
#include "sampling/hemisphere.glsl"

// f |cos theta_i| for reflectance b.c0; zero unless both directions are above the surface.
vec3 diffuse_eval(Bsdf b, vec3 wo, vec3 wi) {
    return (wo.z > 0.0 && wi.z > 0.0) ? b.c0 * (kInvPi * wi.z) : vec3(0.0);
}

// Solid-angle pdf of sampling wi: cos theta_i / pi on the upper hemisphere.
float diffuse_pdf(Bsdf b, vec3 wo, vec3 wi) {
    return (wo.z > 0.0 && wi.z > 0.0) ? cosine_hemisphere_pdf(wi.z) : 0.0;
}

// Cosine-weighted sample; u in [0,1)^2. The weight f cos / pdf is exactly rho.
BsdfSample diffuse_sample(Bsdf b, vec3 wo, vec2 u) {
    vec3 wi = sample_cosine_hemisphere(u);
    bool ok = wo.z > 0.0 && wi.z > 0.0;
    return BsdfSample(wi, ok ? b.c0 : vec3(0.0), cosine_hemisphere_pdf(wi.z), 1.0, false, ok);
}
