// Discrete distributions over n outcomes by Walker's alias method (Vose's construction).
//
// Walker 1977; Vose, "A linear algorithm for generating random numbers with a given
// distribution", IEEE TSE 17(9), 1991; pbrt-v4 AliasTable. u picks one of n equally
// likely bins; the bin keeps its own outcome with probability q and otherwise gives its
// alias. O(1) per sample, two fetches. Table layout ("alias table"): see
// glrender/sampling/distributions.py (DistributionPacker.add_alias_table).
#include "common/constants.glsl"
#include "sampling/discrete.glsl"
#include "sampling/distribution_data.glsl"

// Number of outcomes of the alias table at offset.
uint alias_table_size(uint offset) {
    return distribution_fetch_uint(offset);
}

// Probability of outcome index of the alias table at offset (0 outside [0, n)).
float alias_table_pmf(uint offset, uint index) {
    uint n = distribution_fetch_uint(offset);
    return index < n ? distribution_fetch(offset + 3u * index + 3u) : 0.0;
}

// Samples an outcome of the alias table at offset: u in [0, 1). Returns the outcome, its
// probability and the remainder of u, uniform on [0, 1) (float32: about log2(n / q) bits
// fewer than u).
DiscreteSample sample_alias_table(uint offset, float u) {
    uint n = distribution_fetch_uint(offset);
    float un = u * float(n);
    uint bin = min(uint(un), n - 1u);
    float up = min(un - float(bin), kOneMinusEpsilon);
    uint record = offset + 1u + 3u * bin;
    float q = distribution_fetch(record);
    DiscreteSample s;
    if (up < q) {
        s.index = bin;
        s.u_remapped = min(up / q, kOneMinusEpsilon);
    } else {
        s.index = distribution_fetch_uint(record + 1u);
        s.u_remapped = min((up - q) / (1.0 - q), kOneMinusEpsilon);
    }
    s.pmf = distribution_fetch(offset + 3u * s.index + 3u);
    return s;
}

// Chooses a light with probability proportional to its power, p_i = Phi_i / sum_j Phi_j
// (lecture 13, "Sampling a set of point light sources"), from the alias table that
// glrender.sampling.distributions.light_power_table built over the lights' powers.
// u in [0, 1); returns the light index, its probability and the remainder of u.
DiscreteSample sample_light_by_power(uint offset, float u) {
    return sample_alias_table(offset, u);
}
