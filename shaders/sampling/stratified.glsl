// Jittered (stratified) samples in 1D and 2D with a hashed permutation of the strata per dimension.
//
// With n samples per pixel, sample i of a dimension falls in stratum
// permute(i, n, seed) (a different random permutation per pixel and dimension:
// the "padding" that decorrelates dimensions) and is jittered uniformly within it.
// 2D strata form an nx x ny grid with nx * ny = n. Sample indices past n start a
// new, independent randomization.
#include "common/hash.glsl"

// Kensler 2013 ("Correlated Multi-Jittered Sampling", listing 3): a hashed
// permutation of [0, l) evaluated at i, by cycle walking within the next power of
// two. Each walk step lands in range with probability > 1/2; the walk is capped
// at 32 steps (probability < 2^-32 of reaching the cap), then i is returned as is.
uint permute_index(uint i, uint l, uint p) {
    if (l <= 1u) return 0u;
    uint w = l - 1u;
    w |= w >> 1u;
    w |= w >> 2u;
    w |= w >> 4u;
    w |= w >> 8u;
    w |= w >> 16u;
    uint start = i;
    for (int step = 0; step < 32; ++step) {
        i ^= p;
        i *= 0xe170893du;
        i ^= p >> 16u;
        i ^= (i & w) >> 4u;
        i ^= p >> 8u;
        i *= 0x0929eb3fu;
        i ^= p >> 23u;
        i ^= (i & w) >> 1u;
        i *= 1u | p >> 27u;
        i *= 0x6935fa69u;
        i ^= (i & w) >> 11u;
        i *= 0x74dcb303u;
        i ^= (i & w) >> 2u;
        i *= 0x9e501cc3u;
        i ^= (i & w) >> 2u;
        i *= 0xc860a3dfu;
        i &= w;
        i ^= i >> 5u;
        if (i < l) return (i + p) % l;
    }
    return start % l;
}

// Stratified 1D sample i of n; seeds: (permutation, jitter, epoch) hashes of this dimension.
float stratified_1d(uint i, uint n, uvec3 seeds) {
    uint epoch = i / n;
    uint p = hash_combine(seeds.x, epoch);
    uint stratum = permute_index(i % n, n, p);
    float jitter = uint_to_unit_float(hash_combine(seeds.y, i));
    return min((float(stratum) + jitter) / float(n), 0.99999994);
}

// Stratified 2D sample i of n over an nx x (n / nx) grid (nx must divide n; the
// host picks the largest divisor of n not above sqrt(n)).
vec2 stratified_2d(uint i, uint n, uint nx, uvec3 seeds) {
    uint ny = n / nx;
    uint epoch = i / n;
    uint stratum = permute_index(i % n, n, hash_combine(seeds.x, epoch));
    uvec2 cell = uvec2(stratum % nx, stratum / nx);
    uvec3 h = pcg3d(uvec3(seeds.y, seeds.z, i));
    vec2 jitter = vec2(uint_to_unit_float(h.x), uint_to_unit_float(h.y));
    return min((vec2(cell) + jitter) / vec2(float(nx), float(ny)), vec2(0.99999994));
}
