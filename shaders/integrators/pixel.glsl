// A pixel's samples: camera rays from the measurement equation and their accumulation.
//
// Every integrator file defines
//     void integrator_pixel(uvec2 pixel, uint pixel_hash, uint first, uint count, inout Accumulator acc);
// which renders samples [first, first + count) of the pixel in index order. Integrators
// whose samples cost about the same (direct, AO) loop over integrator_li with
// pixel_samples_in_order; the path tracer regenerates paths so that SIMD lanes whose
// paths end early start their next sample at once (integrators/path.glsl).
#include "common/loop_counter.glsl"
#include "common/params.glsl"
#include "camera/camera.glsl"
#include "camera/filter.glsl"
#include "integrators/integrator_common.glsl"
#include "sampling/sampler.glsl"
#include "film/accum.glsl"

// A pixel's statistics, exact fixed-point sums (film/accum.glsl): per channel the sum
// and the sum of squares of the finite samples, their count and the count of dropped
// samples (non-finite, or beyond kAccumLimit), and the sums of the AOVs. Samples whose
// values (squares included) are all below kAccumFast go into 64-bit partial sums first,
// added to the 128-bit sums every kAccumFlush of them and at the end (accumulator_flush).
struct Accumulator {
    uvec4 sum[3];
    uvec4 sq[3];
    uvec2 counts;    // x: finite samples, y: dropped samples
    uvec4 aov[kAovChannels];   // albedo rgb, normal xyz, depth, seen emission rgb
    uvec2 part[6];   // partial sums: r, g, b, their squares
    uvec2 aov_part[kAovChannels];
    uint pending;    // samples in the partial sums
};

// Clears the partial sums (constant indices only: an array indexed by a loop variable
// may be kept in memory and addressed lane by lane).
void accumulator_clear(inout Accumulator acc) {
    acc.part[0] = uvec2(0u);
    acc.part[1] = uvec2(0u);
    acc.part[2] = uvec2(0u);
    acc.part[3] = uvec2(0u);
    acc.part[4] = uvec2(0u);
    acc.part[5] = uvec2(0u);
    if (kAovs) {
        acc.aov_part[0] = uvec2(0u);
        acc.aov_part[1] = uvec2(0u);
        acc.aov_part[2] = uvec2(0u);
        acc.aov_part[3] = uvec2(0u);
        acc.aov_part[4] = uvec2(0u);
        acc.aov_part[5] = uvec2(0u);
        acc.aov_part[6] = uvec2(0u);
        acc.aov_part[7] = uvec2(0u);
        acc.aov_part[8] = uvec2(0u);
        acc.aov_part[9] = uvec2(0u);
    }
    acc.pending = 0u;
}

// Adds the partial sums to the 128-bit sums and clears them.
void accumulator_flush(inout Accumulator acc) {
    accum_add(acc.sum[0], accum_widen(acc.part[0]));
    accum_add(acc.sum[1], accum_widen(acc.part[1]));
    accum_add(acc.sum[2], accum_widen(acc.part[2]));
    accum_add(acc.sq[0], accum_widen(acc.part[3]));
    accum_add(acc.sq[1], accum_widen(acc.part[4]));
    accum_add(acc.sq[2], accum_widen(acc.part[5]));
    if (kAovs) {
        accum_add(acc.aov[0], accum_widen(acc.aov_part[0]));
        accum_add(acc.aov[1], accum_widen(acc.aov_part[1]));
        accum_add(acc.aov[2], accum_widen(acc.aov_part[2]));
        accum_add(acc.aov[3], accum_widen(acc.aov_part[3]));
        accum_add(acc.aov[4], accum_widen(acc.aov_part[4]));
        accum_add(acc.aov[5], accum_widen(acc.aov_part[5]));
        accum_add(acc.aov[6], accum_widen(acc.aov_part[6]));
        accum_add(acc.aov[7], accum_widen(acc.aov_part[7]));
        accum_add(acc.aov[8], accum_widen(acc.aov_part[8]));
        accum_add(acc.aov[9], accum_widen(acc.aov_part[9]));
    }
    accumulator_clear(acc);
}


// A camera ray for sample `index` of the pixel: pixel filter, lens and shutter time,
// with the near clip applied (o starts on it, t_max ends at the far clip).
struct CameraSample {
    vec3 o;
    vec3 d;
    float t_max;
    float time;     // normalized shutter time in [0, 1]
    float weight;   // pixel filter weight
};

CameraSample camera_sample(uvec2 pixel, inout SamplerState s) {
    CameraSample c;
    vec2 offset = sample_pixel_filter(sampler_2d(s), u_params.filter_params, c.weight);
    vec2 u_lens = sampler_2d(s);
    c.time = u_params.shutter.y > u_params.shutter.x
           ? sample_shutter_time(kSharedTime ? u_params.shutter.w : sampler_1d(s)) : 0.0;
    float t_min;
    camera_ray(vec2(pixel) + 0.5 + offset, u_lens, c.time, c.o, c.d, t_min, c.t_max);
    c.o += t_min * c.d;
    c.t_max -= t_min;
    return c;
}

// Adds one sample's radiance L (and first-hit AOVs) to the pixel's statistics;
// non-finite samples, and those with a component of kAccumLimit or more, are dropped
// and counted. With a clamp c > 0 (u_params.sample_clamp) a sample whose largest component
// exceeds c is scaled down to it (hue kept; biased).
float max_abs(vec3 v) {
    return max(abs(v.x), max(abs(v.y), abs(v.z)));
}

// The clamp and the debug poison applied to sample `index`; whether it counts (finite and
// below kAccumLimit). Every accumulation of camera samples goes through it.
bool accumulation_admits(inout vec3 L, inout Aov aov, uint index) {
    if (kDebugNonFinite != 0u && (index % 7u) == kDebugNonFinite - 1u) L = vec3(uintBitsToFloat(0x7fc00000u));
    float clamp_to = u_params.sample_clamp;
    float largest = max(L.r, max(L.g, L.b));
    if (clamp_to > 0.0 && largest > clamp_to) {
        L *= clamp_to / largest;
        aov.emission *= clamp_to / largest;
    }
    return is_finite(L) && max(abs(L.r), max(abs(L.g), abs(L.b))) < kAccumLimit;
}

void accumulate(inout Accumulator acc, vec3 L, Aov aov, uint index) {
    if (accumulation_admits(L, aov, index)) {
        // constant indices only: an array indexed by a loop variable may be kept in
        // memory and addressed lane by lane
        acc.counts.x += 1u;
        vec3 sq = L * L;
        bool fast = max(sq.r, max(sq.g, sq.b)) < kAccumFast;
        if (kAovs) {
            fast = fast && max(max_abs(aov.albedo), max(max_abs(aov.normal), max(abs(aov.depth),
                                                                       max_abs(aov.emission)))) < kAccumFast;
        }
        if (fast) {
            if (acc.pending == kAccumFlush) accumulator_flush(acc);
            acc.pending += 1u;
            accum_add64(acc.part[0], L.r);
            accum_add64(acc.part[1], L.g);
            accum_add64(acc.part[2], L.b);
            accum_add64(acc.part[3], sq.r);
            accum_add64(acc.part[4], sq.g);
            accum_add64(acc.part[5], sq.b);
            if (kAovs) {
                accum_add64(acc.aov_part[0], aov.albedo.r);
                accum_add64(acc.aov_part[1], aov.albedo.g);
                accum_add64(acc.aov_part[2], aov.albedo.b);
                accum_add64(acc.aov_part[3], aov.normal.x);
                accum_add64(acc.aov_part[4], aov.normal.y);
                accum_add64(acc.aov_part[5], aov.normal.z);
                accum_add64(acc.aov_part[6], aov.depth);
                accum_add64(acc.aov_part[7], aov.emission.r);
                accum_add64(acc.aov_part[8], aov.emission.g);
                accum_add64(acc.aov_part[9], aov.emission.b);
            }
        } else {
            accum_add(acc.sum[0], accum_fixed(L.r));
            accum_add(acc.sum[1], accum_fixed(L.g));
            accum_add(acc.sum[2], accum_fixed(L.b));
            accum_add(acc.sq[0], accum_fixed_abs(sq.r));
            accum_add(acc.sq[1], accum_fixed_abs(sq.g));
            accum_add(acc.sq[2], accum_fixed_abs(sq.b));
            if (kAovs) {
                accum_add(acc.aov[0], accum_fixed(aov.albedo.r));
                accum_add(acc.aov[1], accum_fixed(aov.albedo.g));
                accum_add(acc.aov[2], accum_fixed(aov.albedo.b));
                accum_add(acc.aov[3], accum_fixed(aov.normal.x));
                accum_add(acc.aov[4], accum_fixed(aov.normal.y));
                accum_add(acc.aov[5], accum_fixed(aov.normal.z));
                accum_add(acc.aov[6], accum_fixed(aov.depth));
                accum_add(acc.aov[7], accum_fixed(aov.emission.r));
                accum_add(acc.aov[8], accum_fixed(aov.emission.g));
                accum_add(acc.aov[9], accum_fixed(aov.emission.b));
            }
        }
    } else {
        acc.counts.y += 1u;
    }
}

// a += v (modulo 2^128) for the 128-bit word quadruple BUF[i], with integer atomics: each
// word's carry goes to the next word in a further atomic add, so samples of one pixel may
// arrive from several invocations at once and the sum is the same bits as accum_add's.
#define ACCUM_ATOMIC_ADD(NAME, BUF) \
void NAME(uint i, uvec4 v) { \
    uint old = atomicAdd(BUF[i].x, v.x); \
    uint carry = old + v.x < old ? 1u : 0u; \
    uint add = v.y + carry; \
    carry = add < carry ? 1u : 0u; \
    if (add != 0u) { old = atomicAdd(BUF[i].y, add); carry += old + add < old ? 1u : 0u; } \
    add = v.z + carry; \
    carry = add < carry ? 1u : 0u; \
    if (add != 0u) { old = atomicAdd(BUF[i].z, add); carry += old + add < old ? 1u : 0u; } \
    add = v.w + carry; \
    if (add != 0u) atomicAdd(BUF[i].w, add); \
}
ACCUM_ATOMIC_ADD(accum_atomic_sum, accum_sum)
ACCUM_ATOMIC_ADD(accum_atomic_sq, accum_sq)
ACCUM_ATOMIC_ADD(accum_atomic_aov, accum_aov)

// accumulate() for one sample straight into the film's pixel `idx` (the accumulation's
// index), by atomics: the same sums as accumulate() and the render kernel's write-back.
void accumulate_atomic(uint idx, vec3 L, Aov aov, uint index) {
    if (accumulation_admits(L, aov, index)) {
        atomicAdd(accum_sum[4u * idx + 3u].x, 1u);
        vec3 sq = L * L;
        accum_atomic_sum(4u * idx, accum_fixed(L.r));
        accum_atomic_sum(4u * idx + 1u, accum_fixed(L.g));
        accum_atomic_sum(4u * idx + 2u, accum_fixed(L.b));
        accum_atomic_sq(3u * idx, accum_fixed_abs(sq.r));
        accum_atomic_sq(3u * idx + 1u, accum_fixed_abs(sq.g));
        accum_atomic_sq(3u * idx + 2u, accum_fixed_abs(sq.b));
        if (kAovs) {
            uint a = kAovChannels * idx;
            accum_atomic_aov(a, accum_fixed(aov.albedo.r));
            accum_atomic_aov(a + 1u, accum_fixed(aov.albedo.g));
            accum_atomic_aov(a + 2u, accum_fixed(aov.albedo.b));
            accum_atomic_aov(a + 3u, accum_fixed(aov.normal.x));
            accum_atomic_aov(a + 4u, accum_fixed(aov.normal.y));
            accum_atomic_aov(a + 5u, accum_fixed(aov.normal.z));
            accum_atomic_aov(a + 6u, accum_fixed(aov.depth));
            accum_atomic_aov(a + 7u, accum_fixed(aov.emission.r));
            accum_atomic_aov(a + 8u, accum_fixed(aov.emission.g));
            accum_atomic_aov(a + 9u, accum_fixed(aov.emission.b));
        }
    } else {
        atomicAdd(accum_sum[4u * idx + 3u].y, 1u);
    }
}

SamplerState pixel_sampler(uint pixel_hash, uint index) {
    return sampler_start(pixel_hash, index, u_params.samples.z, u_params.samples.w);
}
