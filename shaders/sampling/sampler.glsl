// The per-pixel sample generator: independent, stratified or Owen-scrambled Sobol' numbers.
//
// A SamplerState is (pixel hash, sample index, next dimension). Every call to
// sampler_1d or sampler_2d consumes one dimension; its numbers are a pure function
// of (seed, pixel, sample index, dimension), so images never depend on how work
// is split. Which generator runs is the compile-time constant kSampler
// (common/params.glsl). Only kernels and integrators own a SamplerState; sampling
// routines take their uniform numbers as arguments.
#include "common/hash.glsl"
#include "common/params.glsl"
#include "sampling/sobol.glsl"
#include "sampling/stratified.glsl"

struct SamplerState {
    uint pixel_hash;  // hash of (seed, pixel)
    uint index;       // sample index within the pixel
    uint dim;         // next dimension
    uint count;       // samples per pixel of one randomization (stratified only)
    uint columns;     // columns of the 2D stratum grid, a divisor of count (stratified only)
};

// Starts sample `index` of the pixel with hash `pixel_hash` (see sampler_pixel_hash);
// `count` and `columns` matter to the stratified sampler only.
SamplerState sampler_start(uint pixel_hash, uint index, uint count, uint columns) {
    return SamplerState(pixel_hash, index, 0u, max(count, 1u), max(columns, 1u));
}

// Hash of (seed, pixel): the pixel's identity for every generator.
uint sampler_pixel_hash(uvec2 pixel, uint seed) {
    return hash_combine(hash_combine(pcg_hash(seed), pixel.x), pixel.y);
}

// Per-dimension seeds: three independent words for this pixel and dimension.
uvec3 sampler_dimension_seeds(SamplerState s) {
    return pcg3d(uvec3(s.pixel_hash, s.dim, 0x5bd1e995u));
}

// The next two uniform numbers in [0, 1)^2 (one dimension slot).
vec2 sampler_2d(inout SamplerState s) {
    vec2 u;
    if (kSampler == kSamplerSobol) {
        u = owen_sobol_2d(s.index, sampler_dimension_seeds(s));
    } else if (kSampler == kSamplerStratified) {
        u = stratified_2d(s.index, s.count, s.columns, sampler_dimension_seeds(s));
    } else {
        uvec3 h = pcg3d(uvec3(s.pixel_hash, s.index, s.dim));
        u = vec2(uint_to_unit_float(h.x), uint_to_unit_float(h.y));
    }
    s.dim += 1u;
    return u;
}

// The next uniform number in [0, 1) (one dimension slot).
float sampler_1d(inout SamplerState s) {
    float u;
    if (kSampler == kSamplerSobol) {
        u = owen_sobol_2d(s.index, sampler_dimension_seeds(s)).x;
    } else if (kSampler == kSamplerStratified) {
        u = stratified_1d(s.index, s.count, sampler_dimension_seeds(s));
    } else {
        u = uint_to_unit_float(pcg3d(uvec3(s.pixel_hash, s.index, s.dim)).x);
    }
    s.dim += 1u;
    return u;
}
