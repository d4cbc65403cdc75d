// A light chosen for a light sample and the probability of that choice
// (lights/light_selection.glsl, lights/light_tree.glsl).
struct LightChoice {
    uint index;
    float pmf;
};
