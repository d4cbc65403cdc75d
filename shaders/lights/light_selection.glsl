// Choosing one light for next-event estimation: uniformly, or by power with an alias table.
//
// Lecture 13: p_i = Phi_i / sum_j Phi_j. The host writes each light's selection
// probability into LightData.selection_pmf (used by MIS to evaluate the pdf of a light hit
// by BSDF sampling) and, for power selection, the alias table at offset 0 of the
// packed distributions.
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "sampling/alias_table.glsl"
#include "@scene"

struct LightChoice {
    uint index;
    float pmf;
};

// Picks a light with u in [0, 1). The scene has at least one light when called.
LightChoice select_light(float u) {
    uint n = u_params.counts.x;
    if (kLightSelection == kLightSelectionPower && n > 1u) {
        DiscreteSample s = sample_alias_table(0u, u);
        return LightChoice(s.index, s.pmf);
    }
    return LightChoice(min(uint(u * float(n)), n - 1u), 1.0 / float(n));
}

// Probability that select_light picks light `index`.
float light_selection_pmf(uint index) {
    return scene_light(index).selection_pmf;
}
