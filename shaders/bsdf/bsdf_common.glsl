// The BSDF interface shared by every material model: the evaluated material and a sample record.
//
// Conventions (pbrt's): directions are in the local shading frame (+z = shading
// normal), both pointing away from the surface: wo toward the viewer (or the
// previous path vertex), wi toward the light (or the next vertex). eval returns
// f(wo, wi) |cos theta_i| (the cosine is included, as in Mitsuba); pdfs are per unit
// solid angle of wi. `adjoint` is true when importance (from the camera) flows
// along the path instead of radiance - light tracing and photon mapping - which
// changes the 1/eta^2 scaling of refraction (Veach 1997, sec. 5.2).

// Material kinds: the values of glrender.gpu.layout.MATERIAL_KINDS.
const uint kMaterialDiffuse = 0u;
const uint kMaterialConductor = 1u;
const uint kMaterialRoughConductor = 2u;
const uint kMaterialDielectric = 3u;
const uint kMaterialRoughDielectric = 4u;
const uint kMaterialThinDielectric = 5u;
const uint kMaterialPlastic = 6u;
const uint kMaterialRoughPlastic = 7u;
const uint kMaterialNull = 8u;
// resolved per surface point into one of the above (bsdf/metallic_roughness.glsl)
const uint kMaterialMetallicRoughness = 9u;

// Material flags (kMaterialFlag*): common/bindings.glsl.
#include "common/bindings.glsl"

// A material at one surface point, its textures already looked up. The meaning of
// c0, c1, c2 per kind is that of MaterialData (scene/layout.glsl).
struct Bsdf {
    uint kind;
    uint flags;
    vec3 c0;
    vec3 c1;
    vec3 c2;
    vec2 alpha;   // microfacet roughness along local x and y
    float eta;    // interior IOR / exterior IOR
    uint material;  // index of the material record, for tabulated data (roughplastic)
    vec3 n0;        // the shading normal before the normal map, in the local frame (bsdf_normal_frame)
};

// One sampled direction.
struct BsdfSample {
    vec3 wi;       // sampled direction, local frame
    vec3 weight;   // f |cos theta_i| / pdf (for a delta lobe: its contribution / probability)
    float pdf;     // solid-angle pdf of wi (delta lobes: the probability of choosing the lobe)
    float eta;     // relative IOR crossed (1 for reflection)
    bool delta;    // a Dirac lobe was sampled
    bool valid;    // false: no direction (the path ends)
};

BsdfSample bsdf_sample_invalid() {
    return BsdfSample(vec3(0.0, 0.0, 1.0), vec3(0.0), 0.0, 1.0, false, false);
}
