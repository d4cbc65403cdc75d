// Discrete choices by inversion of a two-outcome CDF; the result type of every discrete sampler.
//
// Lecture 13 (Hanrahan, "Discrete probability distributions"): select X_i when
// p_1 + ... + p_{i-1} <= u < p_1 + ... + p_i. The position of u inside the chosen
// interval is again uniform on [0, 1): it is returned rescaled so one number can drive
// both the choice and the next sampling step (pbrt-v4's SampleDiscrete, uRemapped).
// Tables of many outcomes: sampling/discrete_cdf.glsl, sampling/alias_table.glsl.
#include "common/constants.glsl"

// One outcome of a discrete sampler.
struct DiscreteSample {
    uint index;        // the chosen outcome
    float pmf;         // its probability
    float u_remapped;  // the reused remainder of u, uniform on [0, 1) given index
};

// Chooses reflection (index 0) with probability F, transmission (index 1) with 1 - F,
// as for a dielectric interface with Fresnel reflectance F (lecture 13: p_r = F_r /
// (F_r + F_t) with F_t = 1 - F_r). u in [0, 1); F is clamped to [0, 1].
// Returns which (0 reflect, 1 transmit), its probability, and u rescaled to [0, 1).
DiscreteSample choose_reflect_transmit(float F, float u) {
    float p_r = clamp(F, 0.0, 1.0);
    DiscreteSample s;
    if (u < p_r) {
        s.index = 0u;
        s.pmf = p_r;
        s.u_remapped = min(u / p_r, kOneMinusEpsilon);
    } else {
        s.index = 1u;
        s.pmf = 1.0 - p_r;
        s.u_remapped = min((u - p_r) / (1.0 - p_r), kOneMinusEpsilon);
    }
    return s;
}
