// Piecewise-constant 2D distributions (images) by a marginal and a conditional inverse CDF.
//
// The density over the rectangle [u0, u1] x [v0, v1] is proportional to an nv x nu
// image f (row j = v bin, column i = u bin), as for environment maps and textured area
// lights (pbrt-v4 PiecewiseConstant2D): v from the marginal density of the rows, p(v) =
// integral of f over u / integral of f, then u from the chosen row's conditional density
// p(u | v). pdf(u, v) = p(v) p(u | v) = f(u, v) / integral of f, per unit area of the
// rectangle (an environment map converts it to solid angle itself). Table layout
// ("piecewise-constant 2D"): see glrender/sampling/distributions.py
// (DistributionPacker.add_distribution_2d).
#include "sampling/distribution1d.glsl"

// Offset of row j's conditional 1D table inside the 2D table at offset.
uint distribution_2d_row(uint offset, uint j) {
    uint nu = distribution_fetch_uint(offset);
    uint nv = distribution_fetch_uint(offset + 1u);
    return offset + 2u + (5u + 2u * nv) + j * (5u + 2u * nu);
}

// Samples a point (u, v) of the rectangle: u_rand in [0, 1)^2, u_rand.y picks the row
// (v), u_rand.x the column (u), as in pbrt-v4. pdf: density per unit area of (u, v).
vec2 sample_distribution_2d(uint offset, vec2 u_rand, out float pdf) {
    uint marginal = offset + 2u;
    float pdf_v, pdf_u;
    uint row, column;
    float v = sample_distribution_1d(marginal, u_rand.y, pdf_v, row);
    float u = sample_distribution_1d(distribution_2d_row(offset, row), u_rand.x, pdf_u, column);
    pdf = pdf_v * pdf_u;
    return vec2(u, v);
}

// Density per unit area at p = (u, v): f of p's pixel / integral of f; 0 outside.
float distribution_2d_pdf(uint offset, vec2 p) {
    uint nu = distribution_fetch_uint(offset);
    uint nv = distribution_fetch_uint(offset + 1u);
    uint marginal = offset + 2u;
    uint row0 = distribution_2d_row(offset, 0u);
    float v0 = distribution_fetch(marginal + kDistribution1DMin);
    float v1 = distribution_fetch(marginal + kDistribution1DMax);
    float u0 = distribution_fetch(row0 + kDistribution1DMin);
    float u1 = distribution_fetch(row0 + kDistribution1DMax);
    float integral = distribution_fetch(marginal + kDistribution1DIntegral);
    if (!(p.x >= u0 && p.x <= u1 && p.y >= v0 && p.y <= v1) || !(integral > 0.0)) return 0.0;
    uint i = distribution_1d_bin(p.x, u0, u1, nu);
    uint j = distribution_1d_bin(p.y, v0, v1, nv);
    return distribution_fetch(distribution_2d_row(offset, j) + kDistribution1DFunc + i) / integral;
}

// The u_rand that sample_distribution_2d maps to p (pbrt-v4's Invert); (-1, -1) outside.
vec2 invert_distribution_2d_sample(uint offset, vec2 p) {
    uint nv = distribution_fetch_uint(offset + 1u);
    uint marginal = offset + 2u;
    float v0 = distribution_fetch(marginal + kDistribution1DMin);
    float v1 = distribution_fetch(marginal + kDistribution1DMax);
    float uv = invert_distribution_1d_sample(marginal, p.y);
    if (uv < 0.0) return vec2(-1.0);
    uint j = distribution_1d_bin(p.y, v0, v1, nv);
    float uu = invert_distribution_1d_sample(distribution_2d_row(offset, j), p.x);
    return uu < 0.0 ? vec2(-1.0) : vec2(uu, uv);
}
