// From a material record and texture coordinates to the Bsdf of one surface point.
#include "bsdf/bsdf_common.glsl"
#include "bsdf/metallic_roughness.glsl"
#include "bsdf/texture.glsl"
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "@scene"

// A material colour at surface uv: the constant, or texture (index + 1; 0 = none)
// evaluated there (bsdf/texture.glsl). Linear RGB.
vec3 material_color(vec3 constant, uint texture_plus_one, vec2 uv) {
    if (texture_plus_one == 0u) return constant;
    return texture_eval(texture_plus_one - 1u, uv);
}

// The header comes from the generated scene code (constants when the scene has few
// materials: an SSBO gather of the record per hit measured 25% of a Cornell-box path).
Bsdf bsdf_from_material(uint material, vec2 uv) {
    MaterialHeader m = scene_material(material);
    Bsdf b;
    b.kind = m.info.x;
    b.flags = m.info.y;
    b.c0 = material_color(m.color0.rgb, m.info.z, uv);
    b.c1 = material_color(m.color1.rgb, m.info.w, uv);
    b.c2 = m.color2.rgb;
    b.alpha = m.params.xy;
    b.eta = m.params.z;
    b.material = material;
    b.n0 = vec3(0.0, 0.0, 1.0);
    if (kMetallicRoughness && b.kind == kMaterialMetallicRoughness) b = metallic_roughness_resolve(b);
    return b;
}

// The tabulated data of a material record (bsdf/roughplastic.glsl's prototype).
float material_table_fetch(uint material, uint i) {
    return materials[material].table[i];
}

#if GLRENDER_METALLIC_ROUGHNESS
// The coating table over alpha (bsdf/roughplastic.glsl's prototype).
float alpha_table_fetch(uint i) {
    return texelFetch(u_microfacet_tables, int(i)).x;
}
#endif
