// Splatting onto the film: contributions of light paths connected to the lens (light
// tracing, BDPT's t = 1 strategies) land on whatever pixels the filter covers.
//
// Each pixel and channel holds a signed 64-bit fixed-point sum (kSplatScale units per
// unit of radiance times light paths) in two words updated with integer atomics: the
// low word's carry goes to the high word. Integer addition is associative, so the
// image is bitwise the same whatever order the splats arrive in (dispatch sizes,
// thread counts), which float atomics would not give. The host divides the sum by
// kSplatScale and by the number of light paths (one per camera sample of every pixel).
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "camera/importance.glsl"
#include "common/loop_counter.glsl"

// 2^16: a splat's resolution is 1.5e-5 while sums reach 2^47 (kSplatLimit bounds one splat).
const float kSplatScale = 65536.0;
const float kSplatLimit = 4.0e18;

// v (one channel of a splat) in fixed point: the 64-bit two's complement word pair
// (lo, hi) of round(v kSplatScale); false when it rounds to zero.
bool splat_fixed(float v, out uint lo, out uint hi) {
    float x = clamp(v * kSplatScale, -kSplatLimit, kSplatLimit);
    float a = floor(abs(x) + 0.5);
    hi = uint(floor(a * (1.0 / 4294967296.0)));
    lo = uint(a - float(hi) * 4294967296.0);
    if (x < 0.0) {   // two's complement of (hi, lo)
        lo = ~lo + 1u;
        hi = ~hi + (lo == 0u ? 1u : 0u);
    }
    return lo != 0u || hi != 0u;
}

// Adds v (one channel) to the 64-bit word pair at accum_splat[2 i], [2 i + 1].
void splat_add_channel(uint i, float v) {
    uint lo, hi;
    if (!splat_fixed(v, lo, hi)) return;
    uint old = atomicAdd(accum_splat[2u * i], lo);
    uint carry = old + lo < old ? 1u : 0u;
    if (hi + carry != 0u) atomicAdd(accum_splat[2u * i + 1u], hi + carry);
}

// The pixels [lo, hi] (inclusive) whose filter covers the film position `film`.
void splat_footprint(vec2 film, out ivec2 lo, out ivec2 hi) {
    float r = u_params.filter_params.x;
    lo = max(ivec2(ceil(film - 0.5 - r)), ivec2(0));
    hi = min(ivec2(floor(film - 0.5 + r)), ivec2(u_params.image.xy) - 1);
}

// Adds the contribution `value` of a film position (pixels, origin top-left) to every
// pixel the filter covers, weighted by the normalized filter density there.
void splat_film(vec2 film, vec3 value) {
    if (any(isnan(value)) || any(isinf(value)) || max(abs(value.r), max(abs(value.g), abs(value.b))) == 0.0)
        return;
    vec4 fp = u_params.filter_params;
    ivec2 size = ivec2(u_params.image.xy);
    ivec2 lo, hi;
    splat_footprint(film, lo, hi);
    for (int y = lo.y; y <= hi.y; ++y) {
        for (int x = lo.x; x <= hi.x; ++x) {
            LOOP_TICK();
            float h = pixel_filter_density(film - (vec2(x, y) + 0.5), fp);
            if (h == 0.0) continue;
            uint i = 3u * uint(y * size.x + x);
            vec3 v = value * h;
            splat_add_channel(i, v.r);
            splat_add_channel(i + 1u, v.g);
            splat_add_channel(i + 2u, v.b);
        }
    }
}
