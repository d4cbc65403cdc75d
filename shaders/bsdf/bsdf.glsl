// BSDF dispatch by material kind; kinds absent from the scene are compiled out.
//
// llvmpipe runs every side of a divergent branch, so the host passes the set of
// material kinds present (kMaterialKinds, common/params.glsl) and each case is
// guarded by a constant test the compiler folds. Two-sided materials answer on
// both sides by mirroring the directions into the upper hemisphere.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/diffuse.glsl"
#include "common/params.glsl"

bool material_present(uint kind) {
    return (kMaterialKinds & (1u << kind)) != 0u;
}

// Mirrors directions into the upper hemisphere for two-sided materials.
void bsdf_two_sided(Bsdf b, inout vec3 wo, inout vec3 wi) {
    if ((b.flags & kMaterialFlagTwoSided) != 0u && wo.z < 0.0) {
        wo.z = -wo.z;
        wi.z = -wi.z;
    }
}

// f(wo, wi) |cos theta_i| of the non-delta lobes.
vec3 bsdf_eval(Bsdf b, vec3 wo, vec3 wi, bool adjoint) {
    bsdf_two_sided(b, wo, wi);
    vec3 f = vec3(0.0);
    if (material_present(kMaterialDiffuse) && b.kind == kMaterialDiffuse) f = diffuse_eval(b, wo, wi);
    return f;
}

// Solid-angle pdf with which bsdf_sample returns wi (non-delta lobes).
float bsdf_pdf(Bsdf b, vec3 wo, vec3 wi) {
    bsdf_two_sided(b, wo, wi);
    float pdf = 0.0;
    if (material_present(kMaterialDiffuse) && b.kind == kMaterialDiffuse) pdf = diffuse_pdf(b, wo, wi);
    return pdf;
}

// Samples wi given wo; u_lobe in [0,1) picks a lobe, u in [0,1)^2 the direction.
BsdfSample bsdf_sample(Bsdf b, vec3 wo, float u_lobe, vec2 u, bool adjoint) {
    bool flip = (b.flags & kMaterialFlagTwoSided) != 0u && wo.z < 0.0;
    if (flip) wo.z = -wo.z;
    BsdfSample s = bsdf_sample_invalid();
    if (material_present(kMaterialDiffuse) && b.kind == kMaterialDiffuse) s = diffuse_sample(b, wo, u);
    if (flip) s.wi.z = -s.wi.z;
    return s;
}

// True when every lobe of the material is a Dirac delta (no light sampling helps).
bool bsdf_is_delta(Bsdf b) {
    return b.kind == kMaterialConductor || b.kind == kMaterialDielectric ||
           b.kind == kMaterialThinDielectric || b.kind == kMaterialNull;
}

// Directional-hemispherical reflectance estimate for the albedo AOV.
vec3 bsdf_albedo(Bsdf b) {
    if (b.kind == kMaterialDiffuse || b.kind == kMaterialPlastic || b.kind == kMaterialRoughPlastic)
        return b.c0;
    return b.c1;
}
