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

// Running per-pixel statistics (Welford): mean (rgb, finite samples), M2 (rgb,
// dropped non-finite samples), and the AOV means.
struct Accumulator {
    vec4 mean;
    vec4 m2;
    vec4 albedo;
    vec4 normal;   // xyz normal, w depth
    vec4 emission; // rgb seen emission, w unused
};

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
    c.time = u_params.shutter.y > u_params.shutter.x ? sample_shutter_time(sampler_1d(s)) : 0.0;
    float t_min;
    camera_ray(vec2(pixel) + 0.5 + offset, u_lens, c.time, c.o, c.d, t_min, c.t_max);
    c.o += t_min * c.d;
    c.t_max -= t_min;
    return c;
}

// Adds one sample's radiance L (and first-hit AOVs) to the pixel's statistics;
// non-finite samples are dropped and counted. With a clamp c > 0 (u_params.misc.z)
// a sample whose largest component exceeds c is scaled down to it (hue kept; biased).
void accumulate(inout Accumulator acc, vec3 L, Aov aov, uint index) {
    if (kDebugNonFinite != 0u && (index % 7u) == kDebugNonFinite - 1u) L = vec3(uintBitsToFloat(0x7fc00000u));
    float clamp_to = u_params.misc.z;
    float largest = max(L.r, max(L.g, L.b));
    if (clamp_to > 0.0 && largest > clamp_to) {
        L *= clamp_to / largest;
        aov.emission *= clamp_to / largest;
    }
    if (is_finite(L)) {
        acc.mean.w += 1.0;
        vec3 delta = L - acc.mean.rgb;
        acc.mean.rgb += delta / acc.mean.w;
        acc.m2.rgb += delta * (L - acc.mean.rgb);
        if (kAovs) {
            acc.albedo += (vec4(aov.albedo, 0.0) - acc.albedo) / acc.mean.w;
            acc.normal += (vec4(aov.normal, aov.depth) - acc.normal) / acc.mean.w;
            acc.emission += (vec4(aov.emission, 0.0) - acc.emission) / acc.mean.w;
        }
    } else {
        acc.m2.w += 1.0;
    }
}

SamplerState pixel_sampler(uint pixel_hash, uint index) {
    return sampler_start(pixel_hash, index, u_params.samples.z, u_params.samples.w);
}
