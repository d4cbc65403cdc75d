// The metallic-roughness model per surface point: a material of kind
// kMaterialMetallicRoughness becomes, where it is hit, the (rough) conductor or (rough)
// plastic that the metallic and roughness values there pick. The rule is
// glrender/scene/loaders/pbr.py's (metallic_roughness_bsdf), which the loaders apply to
// uniform materials; tests/bsdf/test_metallic_roughness.py checks the two agree:
//   metallic >= 1/2: a conductor (eta 0, k 1: F = 1) reflecting the base colour,
//   otherwise a plastic over the base colour (IOR 1.5, white specular);
//   roughness r clamped to [0, 1], GGX alpha = max(r^2, 1e-3), smooth below r = 0.03.
// Rough plastic's coating (T(cos theta) and R_int) depends on alpha: it is read from the
// table over alpha (bsdf/roughplastic.glsl, kMaterialFlagAlphaTable).
#include "bsdf/bsdf_common.glsl"
#include "bsdf/roughplastic.glsl"
#include "common/params.glsl"

const float kMetallicThreshold = 0.5;
const float kSmoothRoughness = 0.03;
const float kMinMetallicRoughnessAlpha = 1e-3;

// The BSDF kind (kMaterial*) of a point of `metallic` and `roughness` (any reals; roughness
// is clamped to [0, 1]), and (out) its GGX alpha.
uint metallic_roughness_kind(float metallic, float roughness, out float alpha) {
    float r = clamp(roughness, 0.0, 1.0);
    alpha = max(r * r, kMinMetallicRoughnessAlpha);
    bool smooth_surface = r < kSmoothRoughness;
    if (metallic >= kMetallicThreshold) return smooth_surface ? kMaterialConductor : kMaterialRoughConductor;
    return smooth_surface ? kMaterialPlastic : kMaterialRoughPlastic;
}

// The BSDF at one point of a metallic-roughness material b, its textures looked up there:
// c0 the base colour, c1 (-, roughness, metallic), c2 the plastic's specular sampling
// weight and its smooth coating's Fdr_int, eta 1.5 (glrender/gpu/pack.py).
Bsdf metallic_roughness_resolve(Bsdf b) {
    float alpha;
    uint kind = metallic_roughness_kind(b.c1.b, b.c1.g, alpha);
    vec3 base = b.c0;
    b.kind = kind;
    b.alpha = vec2(alpha);
    if (kind == kMaterialConductor || kind == kMaterialRoughConductor) {
        b.c0 = vec3(0.0);   // eta
        b.c1 = base;        // specular reflectance
        b.c2 = vec3(1.0);   // k
    } else {
        b.c1 = vec3(1.0);   // specular reflectance
#if GLRENDER_METALLIC_ROUGHNESS
        if (kind == kMaterialRoughPlastic) {
            b.c2.y = alpha_table_internal_reflectance(alpha);
            b.flags |= kMaterialFlagAlphaTable;
        }
#endif
    }
    return b;
}
