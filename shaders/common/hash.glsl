// Integer hashes: the counter-based random number generator of every kernel.
//
// Why counter-based: a sample's random numbers are a pure function of
// (seed, pixel, sample index, dimension), so an image does not depend on how the
// work is split into dispatches, tiles or machines, and any sample can be
// regenerated alone. The hashes are PCG-family permutations of uint32 (Jarzynski
// & Olano 2020, "Hash Functions for GPU Rendering", JCGT 9(3)): pcg_hash has full
// avalanche for one word; pcg3d mixes three words in one round trip.

// One-word PCG hash (RXS-M-XS output of one LCG step): a permutation of uint32.
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Three-word PCG hash (Jarzynski & Olano 2020): all three outputs depend on all inputs.
uvec3 pcg3d(uvec3 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    return v;
}

// Combines a hash with another word (boost::hash_combine's mixing, then PCG).
uint hash_combine(uint seed, uint v) {
    return pcg_hash(seed ^ (v + 0x9e3779b9u + (seed << 6u) + (seed >> 2u)));
}

// Maps a uint32 to [0, 1): the top 24 bits, exactly representable, never 1.0.
float uint_to_unit_float(uint x) {
    return float(x >> 8u) * 5.9604644775390625e-8;  // 2^-24
}

// Spatial hash of integer grid cell coordinates (Teschner et al. 2003), wrapping in 32
// bits: the photon and merge grids' (glrender/photon/grid.py grid_hash is its host twin).
uint grid_hash(uvec3 cell) {
    return (cell.x * 73856093u) ^ (cell.y * 19349663u) ^ (cell.z * 83492791u);
}
