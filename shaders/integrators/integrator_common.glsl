// What every integrator shares: the AOV record, the shading frame, and MIS weights by strategy.
//
// Every integrator file defines
//     vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov);
// the radiance arriving at o from direction -d (the camera ray), with `time` the
// normalized shutter time. Only kernels and integrators own a SamplerState.
#include "common/constants.glsl"
#include "common/frame.glsl"
#include "common/loop_counter.glsl"
#include "common/params.glsl"
#include "common/ray.glsl"
#include "geometry/surface.glsl"
#include "sampling/mis.glsl"
#include "sampling/sampler.glsl"

// Hard cap on path segments when max_depth is unbounded (-1): Russian roulette ends
// paths long before (survival <= 0.95 per bounce: 0.95^256 < 2e-6).
const int kUnboundedDepthCap = 256;

// Paths this invocation cut short at a depth cap (kUnboundedDepthCap when max_depth is
// unbounded; bdpt's kBdptDepthCap) where they would have gone on. The render kernel adds
// it to the pixel's counts word, which --stats reports as truncated_paths.
uint g_truncated_paths = 0u;

// First-hit arbitrary outputs, averaged over the pixel's samples by the kernel.
// `emission` is the part of the sample's radiance emitted by what the camera ray
// sees (an area light or the environment, through delta surfaces for the path
// tracer), by the same weights as the radiance: the beauty minus it is the light
// reflected by surfaces (what a denoiser is given).
struct Aov {
    vec3 albedo;
    vec3 normal;
    float depth;
    vec3 emission;
};

const Aov kNoAov = Aov(vec3(0.0), vec3(0.0), 0.0, vec3(0.0));

// The AOVs of a sample whose radiance the kernel scales by `weight` (the pixel filter's).
Aov aov_scaled(Aov aov, float weight) {
    aov.emission *= weight;
    return aov;
}

// MIS weight of a technique with pdf pdf_a against one with pdf pdf_b, one sample each,
// by the configured heuristic (balance or power; the single-strategy settings never
// combine, so their weight is 1 for the strategy in use).
// The same with n_a and n_b samples per technique (the direct integrator's counts).
float mis_weight_n(float n_a, float pdf_a, float n_b, float pdf_b) {
    if (kStrategy == kStrategyMisBalance) return mis_balance(n_a, pdf_a, n_b, pdf_b);
    return mis_power(n_a, pdf_a, n_b, pdf_b);
}

float mis_weight(float pdf_a, float pdf_b) {
    return mis_weight_n(1.0, pdf_a, 1.0, pdf_b);
}

float max_component(vec3 v) {
    return max(v.x, max(v.y, v.z));
}

bool is_finite(vec3 v) {
    return !any(isnan(v)) && !any(isinf(v));
}
