// Owen-scrambled Sobol' points in 2D with shuffled indices (Burley 2020), padded per dimension pair.
//
// The first two Sobol' dimensions form a (0,2)-sequence: every block of 2^m
// consecutive points is a (0,m,2)-net. Burley, "Practical Hash-based Owen
// Scrambling" (JCGT 9(4), 2020): shuffle the sample index with a nested uniform
// scramble (a different seed for every dimension pair, which decorrelates the
// pairs, i.e. "padding"), then Owen-scramble each coordinate. The hash-based
// scramble is pbrt-v4's FastOwenScrambler (after Vegdahl 2021).
#include "common/hash.glsl"

// Hash-based Owen scramble of the bits of v read as a binary fraction (MSB first),
// without the final bit reversal: returns the scrambled value bit-reversed.
uint owen_mix_reversed(uint v_reversed, uint seed) {
    uint v = v_reversed;
    v ^= v * 0x3d20adeau;
    v += seed;
    v *= (seed >> 16u) | 1u;
    v ^= v * 0x05526c56u;
    v ^= v * 0x53a22864u;
    return v;
}

// Owen scramble of a binary fraction v (nested uniform scramble, Owen 1995).
uint owen_scramble(uint v, uint seed) {
    return bitfieldReverse(owen_mix_reversed(bitfieldReverse(v), seed));
}

// Second Sobol' dimension, bit-reversed: its generator matrix is the Pascal matrix
// mod 2, so digit r of the point is the XOR of the index bits b that are supersets
// of r (Lucas' theorem); a 5-step superset transform computes all 32 digits.
uint sobol_dim1_reversed(uint index) {
    uint x = index;
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    return x;
}

// Unscrambled Sobol' point of dimensions 0 and 1 as 32-bit fractions.
uvec2 sobol_2d_bits(uint index) {
    return uvec2(bitfieldReverse(index), bitfieldReverse(sobol_dim1_reversed(index)));
}

// Shuffled, Owen-scrambled Sobol' point (dimensions 0 and 1) as 32-bit fractions.
// seeds: (index shuffle, x scramble, y scramble).
uvec2 owen_sobol_2d_bits(uint index, uvec3 seeds) {
    uint i = owen_scramble(index, seeds.x);
    return uvec2(bitfieldReverse(owen_mix_reversed(i, seeds.y)),
                 bitfieldReverse(owen_mix_reversed(sobol_dim1_reversed(i), seeds.z)));
}

// The same as a point of [0, 1)^2.
vec2 owen_sobol_2d(uint index, uvec3 seeds) {
    uvec2 bits = owen_sobol_2d_bits(index, seeds);
    return vec2(uint_to_unit_float(bits.x), uint_to_unit_float(bits.y));
}
