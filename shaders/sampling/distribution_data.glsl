// Packed distribution tables: the fetch prototype and the binary search they share.
//
// Every tabulated distribution (discrete CDF, alias table, piecewise-constant 1D and
// 2D) lives in one packed float array; the layout of each table is documented in one
// place, glrender/sampling/distributions.py, which builds them. Integers in the array
// are stored bit-exact with uintBitsToFloat and read with floatBitsToUint.
//
// A shader that includes this file defines the body of distribution_fetch over its own
// buffer (a buffer texture in the renderer, an SSBO in tests), e.g.
//     layout(binding = 5) uniform samplerBuffer u_distributions;
//     float distribution_fetch(uint i) { return texelFetch(u_distributions, int(i)).r; }
// Mesa refuses to link a shader that calls an undefined prototype, even from a function
// main() never reaches: include the table files only where the data exists.

// Element i of the packed distribution array.
float distribution_fetch(uint i);

// Element i of the packed array read as an unsigned integer (bit-exact).
uint distribution_fetch_uint(uint i) {
    return floatBitsToUint(distribution_fetch(i));
}

// The interval of a non-decreasing table cdf[0..n] (n + 1 values at cdf_offset, cdf[0]
// = 0, cdf[n] = 1) that holds u: the largest i in [0, n - 1] with cdf[i] <= u, so that
// cdf[i] <= u < cdf[i + 1] for u in [0, 1) (bins of zero probability are never returned).
// Binary search after pbrt-v4's FindInterval: at most ceil(log2(n + 1)) <= 32 iterations.
uint distribution_find_interval(uint cdf_offset, uint n, float u) {
    uint size = n - 1u;  // candidates 1 .. n - 1; cdf[0] <= u always holds
    uint first = 1u;
    while (size > 0u) {
        uint half_size = size >> 1u;
        uint middle = first + half_size;
        bool below = distribution_fetch(cdf_offset + middle) <= u;
        first = below ? middle + 1u : first;
        size = below ? size - (half_size + 1u) : half_size;
    }
    return min(first - 1u, n - 1u);
}
