// BSDF dispatch by material kind; kinds absent from the scene are compiled out.
//
// llvmpipe runs every side of a divergent branch, so the host passes the set of
// material kinds present (kMaterialKinds, common/params.glsl) and each case is
// guarded by a constant test the compiler folds. Two-sided materials answer on
// both sides by mirroring the directions into the upper hemisphere (Mitsuba 3's
// twosided adapter); the dielectric kinds answer on both sides by themselves.
//
// Conventions (bsdf/bsdf_common.glsl): local frame, wo toward the previous vertex,
// wi toward the next; eval = f |cos theta_i|; pdfs per unit solid angle of wi; delta
// lobes are only sampled (eval and pdf ignore them) and report their discrete
// probability in BsdfSample.pdf. `adjoint` selects importance transport, which
// differs from radiance transport only for refraction (dielectric, roughdielectric).
// Whoever includes this file defines material_table_fetch (bsdf/roughplastic.glsl).
#include "bsdf/bsdf_common.glsl"
#include "bsdf/conductor.glsl"
#include "bsdf/dielectric.glsl"
#include "bsdf/diffuse.glsl"
#include "bsdf/fresnel.glsl"
#include "bsdf/plastic.glsl"
#include "bsdf/roughconductor.glsl"
#include "bsdf/roughdielectric.glsl"
#include "bsdf/roughplastic.glsl"
#include "bsdf/thindielectric.glsl"
#include "common/frame.glsl"
#include "common/params.glsl"

bool material_present(uint kind) {
    return (kMaterialKinds & (1u << kind)) != 0u;
}

// True when the material kind is `kind` and the kind is compiled in.
bool material_is(Bsdf b, uint kind) {
    return material_present(kind) && b.kind == kind;
}

// Mirrors directions into the upper hemisphere for two-sided materials.
void bsdf_two_sided(Bsdf b, inout vec3 wo, inout vec3 wi) {
    if ((b.flags & kMaterialFlagTwoSided) != 0u && wo.z < 0.0) {
        wo.z = -wo.z;
        wi.z = -wi.z;
    }
}

// The shadowing term of Conty Estevez, Lecocq & Stein (2019, "A Microfacet-Based
// Shadowing Function to Solve the Bump Terminator Problem", Ray Tracing Gems ch. 12),
// Mitsuba 3's use_shadowing_function: the normal map's normals are read as microfacets
// of a GGX-like surface whose roughness grows with their tilt, alpha^2 = min(tan^2
// theta_n / 8, 1), and the light direction is shadowed by Smith's G1 of that surface,
// 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_l)). cos_tilt is the cosine between the map
// normal and the unperturbed normal, cos_l that between the light direction and the
// unperturbed normal. 1 for an untilted normal; 0 at grazing light over a tilted one.
float normal_shadowing_term(float cos_tilt, float cos_l) {
    float c2 = cos_tilt * cos_tilt;
    float alpha2 = min(0.125 * max(1.0 - c2, 0.0) / c2, 1.0);
    if (!(alpha2 > 0.0)) return 1.0;
    float l2 = cos_l * cos_l;
    if (!(l2 > 0.0)) return 0.0;
    float tan2_l = max(1.0 - l2, 0.0) / l2;
    return 2.0 / (1.0 + sqrt(1.0 + alpha2 * tan2_l));
}

// The normal map's shadowing term of b toward the light-side direction w (local frame):
// wi for radiance, wo for importance transport, so that light and bidirectional paths
// weight a path as the path tracer does (Mitsuba applies it to the sampled or
// evaluated direction in either mode, which is not the adjoint of its radiance BSDF).
// With it, as in Mitsuba, w must be on the same side of the unperturbed and the
// perturbed normal. Compiled in only for scenes that ask for it (kNormalShadowing).
float bsdf_normal_shadowing(Bsdf b, vec3 w) {
    if (!kNormalShadowing || (b.flags & kMaterialFlagNormalShadowing) == 0u) return 1.0;
    float cos_l = dot(w, b.n0);
    if (cos_l * w.z <= 0.0) return 0.0;
    return normal_shadowing_term(b.n0.z, cos_l);
}

// Gives b the unperturbed shading normal ns0 (world) in the local frame `frame`, for
// bsdf_normal_shadowing; a no-op unless a scene's normal map uses the term.
void bsdf_normal_frame(inout Bsdf b, vec3 ns0, Frame frame) {
    if (kNormalShadowing) b.n0 = frame_to_local(frame, ns0);
}

// f(wo, wi) |cos theta_i| of the non-delta lobes and (out) the solid-angle pdf with
// which bsdf_sample returns wi; each model computes both from one half vector.
vec3 bsdf_eval_pdf(Bsdf b, vec3 wo, vec3 wi, bool adjoint, out float pdf) {
    float shadowing = bsdf_normal_shadowing(b, adjoint ? wo : wi);
    bsdf_two_sided(b, wo, wi);
    vec3 f = vec3(0.0);
    pdf = 0.0;
    if (material_is(b, kMaterialDiffuse)) {
        f = diffuse_eval(b, wo, wi);
        pdf = diffuse_pdf(b, wo, wi);
    }
    if (material_is(b, kMaterialRoughConductor)) f = roughconductor_eval_pdf(b, wo, wi, pdf);
    if (material_is(b, kMaterialRoughDielectric)) f = roughdielectric_eval_pdf(b, wo, wi, adjoint, pdf);
    if (material_is(b, kMaterialPlastic)) f = plastic_eval_pdf(b, wo, wi, pdf);
    if (material_is(b, kMaterialRoughPlastic)) f = roughplastic_eval_pdf(b, wo, wi, pdf);
    return f * shadowing;
}

// f(wo, wi) |cos theta_i| of the non-delta lobes (the pdf's code is dropped as dead).
vec3 bsdf_eval(Bsdf b, vec3 wo, vec3 wi, bool adjoint) {
    float pdf;
    return bsdf_eval_pdf(b, wo, wi, adjoint, pdf);
}

// Solid-angle pdf with which bsdf_sample returns wi (non-delta lobes; the same for
// radiance and importance transport).
float bsdf_pdf(Bsdf b, vec3 wo, vec3 wi) {
    float pdf;
    bsdf_eval_pdf(b, wo, wi, false, pdf);
    return pdf;
}

// Samples wi given wo; u_lobe in [0,1) picks a lobe, u in [0,1)^2 the direction.
BsdfSample bsdf_sample(Bsdf b, vec3 wo, float u_lobe, vec2 u, bool adjoint) {
    bool flip = (b.flags & kMaterialFlagTwoSided) != 0u && wo.z < 0.0;
    if (flip) wo.z = -wo.z;
    BsdfSample s = bsdf_sample_invalid();
    if (material_is(b, kMaterialDiffuse)) s = diffuse_sample(b, wo, u);
    if (material_is(b, kMaterialConductor)) s = conductor_sample(b, wo);
    if (material_is(b, kMaterialRoughConductor)) s = roughconductor_sample(b, wo, u);
    if (material_is(b, kMaterialDielectric)) s = dielectric_sample(b, wo, u_lobe, adjoint);
    if (material_is(b, kMaterialRoughDielectric)) s = roughdielectric_sample(b, wo, u_lobe, u, adjoint);
    if (material_is(b, kMaterialThinDielectric)) s = thindielectric_sample(b, wo, u_lobe);
    if (material_is(b, kMaterialPlastic)) s = plastic_sample(b, wo, u_lobe, u);
    if (material_is(b, kMaterialRoughPlastic)) s = roughplastic_sample(b, wo, u_lobe, u);
    // null: the surface is not there (Mitsuba's null BSDF): continue straight on
    if (material_is(b, kMaterialNull)) s = BsdfSample(-wo, vec3(1.0), 1.0, 1.0, true, true);
    if (flip) {
        wo.z = -wo.z;
        s.wi.z = -s.wi.z;
    }
    float shadowing = bsdf_normal_shadowing(b, adjoint ? wo : s.wi);
    if (!(shadowing > 0.0)) return bsdf_sample_invalid();
    s.weight *= shadowing;
    return s;
}

// True when every lobe of the material is a Dirac delta (no light sampling helps).
bool bsdf_is_delta(Bsdf b) {
    return b.kind == kMaterialConductor || b.kind == kMaterialDielectric ||
           b.kind == kMaterialThinDielectric || b.kind == kMaterialNull;
}

// A reflectance for the albedo AOV: the diffuse reflectance of diffuse and plastic
// kinds; for the others what the surface reflects (and transmits) at normal incidence.
vec3 bsdf_albedo(Bsdf b) {
    if (b.kind == kMaterialDiffuse || b.kind == kMaterialPlastic || b.kind == kMaterialRoughPlastic)
        return b.c0;
    if (b.kind == kMaterialConductor || b.kind == kMaterialRoughConductor)
        return b.c1 * fresnel_conductor(1.0, b.c0, b.c2);
    if (b.kind == kMaterialDielectric || b.kind == kMaterialRoughDielectric) {
        float F = fresnel_dielectric(1.0, b.eta).F;
        return F * b.c0 + (1.0 - F) * b.c1;
    }
    if (b.kind == kMaterialThinDielectric) {
        float R = thindielectric_reflectance(1.0, b.eta);
        return R * b.c0 + (1.0 - R) * b.c1;
    }
    return vec3(0.0);
}
