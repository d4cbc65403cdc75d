// Piecewise-constant 1D distributions on [min, max] by inversion of their tabulated CDF.
//
// The density is proportional to n tabulated values f_i over equal bins of [min, max]
// (pbrt-v4 PiecewiseConstant1D): P(x) is piecewise linear, so x = P^{-1}(u) is a binary
// search for the bin and a linear step inside it. Table layout ("piecewise-constant
// 1D"): see glrender/sampling/distributions.py (DistributionPacker.add_distribution_1d).
#include "common/constants.glsl"
#include "sampling/distribution_data.glsl"

// Offsets inside a 1D table, relative to its start.
const uint kDistribution1DMin = 1u;
const uint kDistribution1DMax = 2u;
const uint kDistribution1DIntegral = 3u;
const uint kDistribution1DFunc = 4u;  // f_0 .. f_{n-1}, then cdf_0 .. cdf_n

// Number of bins of the 1D table at offset.
uint distribution_1d_size(uint offset) {
    return distribution_fetch_uint(offset);
}

// The bin of x in [min, max] (n bins), as every function of this file computes it.
uint distribution_1d_bin(float x, float x_min, float x_max, uint n) {
    return min(uint(max((x - x_min) / (x_max - x_min) * float(n), 0.0)), n - 1u);
}

// The float next to x toward -infinity: one bit pattern away (down for x > 0, up for
// x < 0; below 0, a tiny negative number).
float float_step_down(float x) {
    uint b = floatBitsToUint(x);
    return x > 0.0 ? uintBitsToFloat(b - 1u) : (x < 0.0 ? uintBitsToFloat(b + 1u) : -1e-38);
}

// The float next to x toward +infinity.
float float_step_up(float x) {
    return -float_step_down(-x);
}

// Integral of f over [min, max] (the normalisation of the density).
float distribution_1d_integral(uint offset) {
    return distribution_fetch(offset + kDistribution1DIntegral);
}

// Samples x in [min, max): u in [0, 1). pdf: density per unit length of x,
// f_bin / integral; bin: the bin index of x. A table whose f are all zero (never built by
// the packer at the top level) gives pdf 0.
float sample_distribution_1d(uint offset, float u, out float pdf, out uint bin) {
    uint n = distribution_fetch_uint(offset);
    float x_min = distribution_fetch(offset + kDistribution1DMin);
    float x_max = distribution_fetch(offset + kDistribution1DMax);
    float integral = distribution_fetch(offset + kDistribution1DIntegral);
    uint cdf = offset + kDistribution1DFunc + n;
    bin = distribution_find_interval(cdf, n, u);
    float c0 = distribution_fetch(cdf + bin);
    float c1 = distribution_fetch(cdf + bin + 1u);
    // Position of u inside the bin's CDF step; rounding may give exactly 1: clamp.
    float du = c1 > c0 ? min((u - c0) / (c1 - c0), kOneMinusEpsilon) : 0.0;
    float f = distribution_fetch(offset + kDistribution1DFunc + bin);
    pdf = integral > 0.0 ? f / integral : 0.0;
    float t = (float(bin) + du) / float(n);
    float x = min(mix(x_min, x_max, t), x_max);
    // Rounding can carry x over a bin edge as distribution_1d_pdf computes bins (about one
    // sample in 10^6): step it back by ulps so that the pdf function agrees with pdf here.
    for (int k = 0; k < 8 && distribution_1d_bin(x, x_min, x_max, n) > bin; ++k) {
        x = float_step_down(x);
    }
    for (int k = 0; k < 8 && distribution_1d_bin(x, x_min, x_max, n) < bin; ++k) {
        x = float_step_up(x);
    }
    return x;
}

// Density per unit length at x (f of x's bin / integral); 0 outside [min, max].
float distribution_1d_pdf(uint offset, float x) {
    uint n = distribution_fetch_uint(offset);
    float x_min = distribution_fetch(offset + kDistribution1DMin);
    float x_max = distribution_fetch(offset + kDistribution1DMax);
    float integral = distribution_fetch(offset + kDistribution1DIntegral);
    if (!(x >= x_min && x <= x_max) || !(integral > 0.0)) return 0.0;
    uint bin = distribution_1d_bin(x, x_min, x_max, n);
    return distribution_fetch(offset + kDistribution1DFunc + bin) / integral;
}

// The u that sample_distribution_1d maps to x in [min, max] (pbrt-v4's Invert): the CDF
// P(x), linear inside x's bin. Returns -1 outside [min, max].
float invert_distribution_1d_sample(uint offset, float x) {
    uint n = distribution_fetch_uint(offset);
    float x_min = distribution_fetch(offset + kDistribution1DMin);
    float x_max = distribution_fetch(offset + kDistribution1DMax);
    if (!(x >= x_min && x <= x_max)) return -1.0;
    float c = (x - x_min) / (x_max - x_min) * float(n);
    uint bin = distribution_1d_bin(x, x_min, x_max, n);
    uint cdf = offset + kDistribution1DFunc + n;
    float c0 = distribution_fetch(cdf + bin);
    float c1 = distribution_fetch(cdf + bin + 1u);
    return min(mix(c0, c1, clamp(c - float(bin), 0.0, 1.0)), kOneMinusEpsilon);
}
