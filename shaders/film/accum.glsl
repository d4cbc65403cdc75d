// Exact per-pixel accumulation: every sample value is added as a 128-bit two's-complement
// fixed-point number with kAccumFraction fractional bits (four 32-bit words, low first).
// Integer addition is associative, so a pixel's sums are the same bits whatever order or
// grouping its samples are added in: one dispatch or many, one process or sample ranges
// rendered on different machines and added afterwards (glrender.distributed).
//
// Range and precision (48 fractional bits, 79 integer bits with the sign):
// - a float32 value with |x| >= 2^-25 converts exactly (its 24-bit mantissa lies above
//   2^-48); smaller values round to the nearest multiple of 2^-48 (3.6e-15);
// - samples with a component of magnitude kAccumLimit (2^30) or more are dropped and
//   counted with the non-finite ones, so a square stays below 2^60 and a pixel's sum of
//   squares cannot overflow 2^79 before 2^19 such extreme samples (sums: before 2^49);
// - the host reads a sum as float64 (glrender/render/accum.py) and divides by the count.
const int kAccumFraction = 48;
const float kAccumLimit = 1073741824.0;   // 2^30

// |x| (x finite, |x| < 2^64) as a 128-bit fixed-point number, rounded to nearest (ties
// away from zero): its 24-bit significand shifted into place.
uvec4 accum_fixed_abs(float x) {
    uint b = floatBitsToUint(x);
    int e = int((b >> 23) & 0xFFu);
    uint m = e == 0 ? 0u : (b & 0x7FFFFFu) | 0x800000u;   // float32 subnormals: below 2^-126
    int s = e - 150 + kAccumFraction;                    // |x| = m 2^(e - 150): q = m 2^s
    if (s < 0) {
        int r = min(-s, 25);                             // r = 25 rounds every m to 0
        return uvec4((m + (1u << (r - 1))) >> r, 0u, 0u, 0u);
    }
    int bit = s & 31;
    uint lo = m << bit;
    uint hi = bit == 0 ? 0u : m >> (32 - bit);
    int w = s >> 5;
    return w == 0 ? uvec4(lo, hi, 0u, 0u) : (w == 1 ? uvec4(0u, lo, hi, 0u) : uvec4(0u, 0u, lo, hi));
}

// x (finite, |x| < 2^64) as a 128-bit fixed-point number (two's complement).
uvec4 accum_fixed(float x) {
    uvec4 q = accum_fixed_abs(x);
    if (x < 0.0) {
        q = ~q;
        uint c0, c1, c2;
        q.x = uaddCarry(q.x, 1u, c0);
        q.y = uaddCarry(q.y, c0, c1);
        q.z = uaddCarry(q.z, c1, c2);
        q.w += c2;
    }
    return q;
}

// a += v, modulo 2^128.
void accum_add(inout uvec4 a, uvec4 v) {
    uint c0, c1, d1, c2, d2;
    a.x = uaddCarry(a.x, v.x, c0);
    uint y = uaddCarry(a.y, v.y, c1);
    a.y = uaddCarry(y, c0, d1);
    uint z = uaddCarry(a.z, v.z, c2);
    a.z = uaddCarry(z, c1 + d1, d2);
    a.w += v.w + c2 + d2;
}

// Partial sums of a few samples in 64 bits (two words, low first, two's complement): a
// sample of magnitude below kAccumFast converts with float arithmetic and adds with one
// carry, and kAccumFlush such samples stay below 2^63 (2^4 x 2^(11 + 48)); the partial
// is then added to the 128-bit sum (accum_add(a, accum_widen(p))). Integer sums, so the
// result is the same bits as adding every sample to the 128-bit sum.
const float kAccumFast = 2048.0;   // 2^11
const uint kAccumFlush = 16u;

// |x| (|x| < 2^15) as a 64-bit fixed-point number (low, high), rounded as accum_fixed_abs:
// the significand m rounded to s < 0 places, or shifted left by s (at most 39) places.
uvec2 accum_fixed64_abs(float x) {
    uint b = floatBitsToUint(x);
    int e = int((b >> 23) & 0xFFu);
    uint m = e == 0 ? 0u : (b & 0x7FFFFFu) | 0x800000u;
    int s = e - 150 + kAccumFraction;
    uint r = uint(clamp(-s, 0, 25));
    m = (m + ((1u << r) >> 1u)) >> r;
    uint t = uint(clamp(s, 0, 31));
    return s < 32 ? uvec2(m << t, (m >> 1u) >> (31u - t)) : uvec2(0u, m << uint(s - 32));
}

// p += x (|x| < kAccumFast) in 64-bit fixed point, modulo 2^64.
void accum_add64(inout uvec2 p, float x) {
    uvec2 v = accum_fixed64_abs(x);
    uint c, b;
    uint add = uaddCarry(p.x, v.x, c);
    uint sub = usubBorrow(p.x, v.x, b);
    p = x < 0.0 ? uvec2(sub, p.y - v.y - b) : uvec2(add, p.y + v.y + c);
}

// A 64-bit partial sum sign-extended to 128 bits.
uvec4 accum_widen(uvec2 p) {
    uint s = uint(int(p.y) >> 31);
    return uvec4(p, s, s);
}

// A 128-bit fixed-point sum as a double (the preview's display; the host reads sums
// exactly). Doubles keep the variance Q - S^2 / n of a bright pixel with a small spread.
double accum_value(uvec4 a) {
    return double(int(a.w)) * 281474976710656.0LF + double(a.z) * 65536.0LF
        + double(a.y) * (1.0LF / 65536.0LF) + double(a.x) * (1.0LF / 281474976710656.0LF);
}

