// Discrete distributions over n outcomes by inversion of a tabulated CDF (binary search).
//
// Table layout ("discrete CDF"): see glrender/sampling/distributions.py; built there by
// DistributionPacker.add_discrete_cdf. Cost O(log n) fetches per sample; the alias table
// (sampling/alias_table.glsl) takes O(1) but cannot be inverted.
#include "common/constants.glsl"
#include "sampling/discrete.glsl"
#include "sampling/distribution_data.glsl"

// Number of outcomes of the discrete CDF table at offset.
uint discrete_cdf_size(uint offset) {
    return distribution_fetch_uint(offset);
}

// Probability of outcome index of the table at offset (0 outside [0, n)).
float discrete_cdf_pmf(uint offset, uint index) {
    uint n = distribution_fetch_uint(offset);
    return index < n ? distribution_fetch(offset + n + 2u + index) : 0.0;
}

// Samples an outcome of the table at offset: u in [0, 1). Outcome i is chosen when
// cdf[i] <= u < cdf[i + 1] (lecture 13); returns it, its probability and the remainder
// (u - cdf[i]) / (cdf[i + 1] - cdf[i]) in [0, 1) (float32: log2(1 / pmf) fewer bits than u).
DiscreteSample sample_discrete_cdf(uint offset, float u) {
    uint n = distribution_fetch_uint(offset);
    uint cdf = offset + 1u;
    uint i = distribution_find_interval(cdf, n, u);
    float c0 = distribution_fetch(cdf + i);
    float c1 = distribution_fetch(cdf + i + 1u);
    DiscreteSample s;
    s.index = i;
    s.pmf = distribution_fetch(offset + n + 2u + i);
    s.u_remapped = c1 > c0 ? min((u - c0) / (c1 - c0), kOneMinusEpsilon) : 0.0;
    return s;
}

// The u in [0, 1) that sample_discrete_cdf maps to (index, u_remapped): the inverse of
// the pair (index, remainder), cdf[index] + u_remapped * (cdf[index + 1] - cdf[index]).
float invert_discrete_cdf_sample(uint offset, uint index, float u_remapped) {
    uint cdf = offset + 1u;
    float c0 = distribution_fetch(cdf + index);
    float c1 = distribution_fetch(cdf + index + 1u);
    return min(mix(c0, c1, u_remapped), kOneMinusEpsilon);
}
