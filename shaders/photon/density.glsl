// Density estimation shared by SPPM's deposits (photon/sppm_deposit.glsl) and the
// photon integrator's lookups (photon/photon_gather.glsl).
#include "bsdf/bsdf.glsl"

// Density estimation kernels over the disk of radius r, as functions of q = d / r,
// normalized so that their mean over the disk is 1 (the estimate stays Phi / (pi r^2)):
// uniform 1; cone (Jensen 2001, k = 1) 3 (1 - q); Epanechnikov 2 (1 - q^2).
const uint kKernelUniform = 0u;
const uint kKernelCone = 1u;
const uint kKernelEpanechnikov = 2u;

float density_kernel(uint kernel, float q2) {
    if (kernel == kKernelCone) return 3.0 * (1.0 - sqrt(q2));
    if (kernel == kKernelEpanechnikov) return 2.0 * (1.0 - q2);
    return 1.0;
}
// The same kernels over the ball of radius r (volume photons), normalized to a mean of 1
// over the ball (the estimate stays Phi / ((4/3) pi r^3)): uniform 1; cone 4 (1 - q);
// Epanechnikov 5/2 (1 - q^2).
float density_kernel_3d(uint kernel, float q2) {
    if (kernel == kKernelCone) return 4.0 * (1.0 - sqrt(q2));
    if (kernel == kKernelEpanechnikov) return 2.5 * (1.0 - q2);
    return 1.0;
}

// Surface density estimation: a photon counts at a point only where the two geometric
// normals agree (a photon on the far side of a thin wall, or on the other wall of a
// corner, belongs to another surface).
const float kNormalAgreement = 0.5;   // cos 60 degrees

// What a photon arriving from the unit direction wi (pointing back where it came from)
// contributes toward wo_l (in `frame`, the point's shading frame; ng its unit geometric
// normal) per unit power: f |wi . ns| / |wi . ng|. Photons land on the geometric surface,
// so their density per area is the irradiance through ng, int L_i |wi . ng|, while the
// radiance the camera sees is int f L_i |wi . ns| (bsdf_eval includes |wi . ns|): the
// ratio is Veach's adjoint shading-normal factor at the photon's last vertex (its camera
// side, |wo . ng| / |wo . ns|, cancels against the camera ray's cosine). Without a normal
// map ns = ng and this is f. False (the photon does not count) unless it arrives on
// the geometric side its shading direction claims.
bool photon_bsdf(Bsdf b, Frame frame, vec3 wo_l, vec3 ng, vec3 wi, out vec3 f) {
    vec3 wi_l = frame_to_local(frame, wi);
    f = vec3(0.0);
    float cos_g = dot(wi, ng);
    if (!(abs(wi_l.z) > 0.0) || cos_g * wi_l.z <= 0.0) return false;
    f = bsdf_eval(b, wo_l, wi_l, false) / abs(cos_g);
    return true;
}
