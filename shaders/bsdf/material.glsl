// From a material record and texture coordinates to the Bsdf of one surface point.
#include "bsdf/bsdf_common.glsl"
#include "scene/layout.glsl"

// Reads texture layer (index + 1; 0 = none) at uv, or returns the constant colour.
vec3 material_color(vec3 constant, uint texture_plus_one, vec2 uv) {
    if (texture_plus_one == 0u) return constant;
    return textureLod(u_textures, vec3(uv, float(texture_plus_one - 1u)), 0.0).rgb;
}

// The record's members are read one by one: a copy of the whole MaterialData would
// also load its table, which only roughplastic reads, and then a few entries.
Bsdf bsdf_from_material(uint material, vec2 uv) {
    uvec4 info = materials[material].info;
    vec4 params = materials[material].params;
    Bsdf b;
    b.kind = info.x;
    b.flags = info.y;
    b.c0 = material_color(materials[material].color0.rgb, info.z, uv);
    b.c1 = material_color(materials[material].color1.rgb, info.w, uv);
    b.c2 = materials[material].color2.rgb;
    b.alpha = params.xy;
    b.eta = params.z;
    b.material = material;
    return b;
}

// The tabulated data of a material record (bsdf/roughplastic.glsl's prototype).
float material_table_fetch(uint material, uint i) {
    return materials[material].table[i];
}
