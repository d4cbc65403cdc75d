// Strategy images (glrender render --strategy-images): every strategy (s, t) of the path
// lengths 1 .. kStrategyDepth adds its MIS-weighted and its unweighted contribution to an
// image of its own (Veach 1997, fig. 10.3), beside the normal accumulation.
//
// Only kernels compiled with kStrategyDepth > 0 (common/params.glsl) have
// this code and storage block 8; otherwise the functions below are empty and bdpt pays
// nothing. Block 8 is this kernel's own (the photon kernels number theirs from 8 too;
// the two never meet in one kernel); glrender/render/strategies.py reads it back.
//
// Strategy j = (k - 1)(k + 2) / 2 + s for path length k = s + t - 1 (s = 0 .. k); each
// has 12 words per pixel of the whole image. Camera-side strategies (t >= 2) keep float
// sums in words 0-2 (weighted rgb) and 3-5 (unweighted), added by the invocation that
// owns the pixel, in sample order. The t = 1 strategies land anywhere on the film: six
// 64-bit fixed-point sums (weighted rgb, unweighted rgb) as word pairs, added with
// integer atomics through the pixel filter as integrators/splat.glsl does. vcm's merges
// (kVcmMode 1, 2) follow the connections of every length: merge (q, t), q light subpath
// segments and t camera vertices, of length k = q + t - 1 >= 2 is number
// kStrategyDepth (kStrategyDepth + 3) / 2 + (k - 2)(k - 1) / 2 + q - 1, camera-side sums.
#include "common/params.glsl"
#include "integrators/splat.glsl"

#if GLRENDER_STRATEGY_DEPTH
layout(std430, binding = SSBO_STRATEGY_IMAGES) buffer StrategyImages { uint strategy_data[]; };

uint g_strategy_pixel;   // the camera sample's pixel (index into the whole image)

void strategy_begin(uvec2 pixel) {
    g_strategy_pixel = pixel.y * u_params.image.x + pixel.x;
}

// The first word of strategy (s, t) at pixel i, or ~0u beyond the imaged depth.
uint strategy_word(int s, int t, uint i) {
    int k = s + t - 1;
    if (k < 1 || k > kStrategyDepth) return ~0u;
    uint j = uint((k - 1) * (k + 2) / 2 + s);
    return 12u * (j * u_params.image.x * u_params.image.y + i);
}

// A camera-side strategy's unweighted contribution L and MIS weight w.
void strategy_record(int s, int t, vec3 L, float w) {
    uint b = strategy_word(s, t, g_strategy_pixel);
    if (b == ~0u || !is_finite(L * w) || !is_finite(L)) return;
    for (int c = 0; c < 3; ++c) {
        strategy_data[b + c] = floatBitsToUint(uintBitsToFloat(strategy_data[b + c]) + L[c] * w);
        strategy_data[b + 3 + c] = floatBitsToUint(uintBitsToFloat(strategy_data[b + 3 + c]) + L[c]);
    }
}

// A merge's (q light segments, t camera vertices) unweighted contribution L and weight w.
void strategy_merge(int q, int t, vec3 L, float w) {
    int k = q + t - 1;
    if (k < 2 || k > kStrategyDepth || !is_finite(L * w) || !is_finite(L)) return;
    uint j = uint(kStrategyDepth * (kStrategyDepth + 3) / 2 + (k - 2) * (k - 1) / 2 + q - 1);
    uint b = 12u * (j * u_params.image.x * u_params.image.y + g_strategy_pixel);
    for (int c = 0; c < 3; ++c) {
        strategy_data[b + c] = floatBitsToUint(uintBitsToFloat(strategy_data[b + c]) + L[c] * w);
        strategy_data[b + 3 + c] = floatBitsToUint(uintBitsToFloat(strategy_data[b + 3 + c]) + L[c]);
    }
}

void strategy_add_fixed(uint word, float v) {
    uint lo, hi;
    if (!splat_fixed(v, lo, hi)) return;
    uint old = atomicAdd(strategy_data[word], lo);
    uint carry = old + lo < old ? 1u : 0u;
    if (hi + carry != 0u) atomicAdd(strategy_data[word + 1u], hi + carry);
}

// A t = 1 strategy's unweighted contribution L at film position `film`, MIS weight w.
void strategy_splat(int s, vec2 film, vec3 L, float w) {
    if (strategy_word(s, 1, 0u) == ~0u || !is_finite(L * w) || !is_finite(L)) return;
    ivec2 lo, hi;
    splat_footprint(film, lo, hi);
    for (int y = lo.y; y <= hi.y; ++y) {
        for (int x = lo.x; x <= hi.x; ++x) {
            LOOP_TICK();
            float h = pixel_filter_density(film - (vec2(x, y) + 0.5), u_params.filter_params);
            if (h == 0.0) continue;
            uint b = strategy_word(s, 1, uint(y) * u_params.image.x + uint(x));
            for (int c = 0; c < 3; ++c) {
                strategy_add_fixed(b + 2u * uint(c), L[c] * w * h);
                strategy_add_fixed(b + 6u + 2u * uint(c), L[c] * h);
            }
        }
    }
}
#else
void strategy_begin(uvec2 pixel) {}
void strategy_record(int s, int t, vec3 L, float w) {}
void strategy_merge(int q, int t, vec3 L, float w) {}
void strategy_splat(int s, vec2 film, vec3 L, float w) {}
#endif
