// Choosing one light for next-event estimation: uniformly, by power with an alias table, or
// by a light BVH at the shading point (bvh).
//
// Lecture 13: p_i = Phi_i / sum_j Phi_j. The host writes each light's selection
// probability into LightData.selection_pmf (used by MIS to evaluate the pdf of a light hit
// by BSDF sampling) and, for power selection, the alias table at offset 0 of the
// packed distributions. With "bvh" the light samples of the path tracer, direct lighting
// and the photon integrators' camera paths descend the light tree (lights/light_tree.glsl)
// from the shading point (select_light_at, light_selection_pmf_at), packed after the alias
// table; light subpaths (bdpt, lighttrace, vcm, photons), which start without a shading
// point, choose by power (select_light), and so do bdpt's and vcm's light samples, whose
// MIS weights take a light's density from the light subpaths' choice.
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "sampling/alias_table.glsl"
#include "lights/light.glsl"
#include "lights/light_choice.glsl"
#include "@scene"


// Picks a light with u in [0, 1). The scene has at least one light when called.
LightChoice select_light(float u) {
    uint n = u_params.counts.x;
    if (kLightSelection != kLightSelectionUniform && n > 1u) {
        DiscreteSample s = sample_alias_table(0u, u);
        return LightChoice(s.index, s.pmf);
    }
    return LightChoice(min(uint(u * float(n)), n - 1u), 1.0 / float(n));
}

// Probability that select_light picks light `index`.
float light_selection_pmf(uint index) {
    return scene_light(index).selection_pmf;
}

#include "lights/light_tree.glsl"

// Where the light tree starts in the packed distributions: after the alias table of
// select_light (glrender/gpu/device_scene.py light_table).
uint light_tree_offset() {
    uint n = u_params.counts.x;
    return n > 1u ? 1u + 3u * n : 0u;
}

// A light for a light sample at point p with normal n (0 in a medium), u in [0, 1); a pmf
// of 0: no light can reach p.
LightChoice select_light_at(vec3 p, vec3 n, float u) {
    if (kLightSelection == kLightSelectionBvh) return light_tree_sample(light_tree_offset(), p, n, u);
    return select_light(u);
}

// Probability that select_light_at picks light `index` at p (normal n).
float light_selection_pmf_at(vec3 p, vec3 n, uint index) {
    if (kLightSelection == kLightSelectionBvh)
        return light_tree_pmf(light_tree_offset(), p, n, index, light_is_infinite(scene_light(index)));
    return light_selection_pmf(index);
}
