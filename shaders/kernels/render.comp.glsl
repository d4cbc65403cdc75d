#version 450
// The render kernel: one invocation per pixel of an 8x8 tile, a few samples per pass.
//
// Each dispatch covers tiles [first, first + count) of a hashed permutation of the
// image's tiles (llvmpipe hands each thread a contiguous run of work groups: the
// permutation spreads expensive regions across threads). Every pixel accumulates
// its samples in order into Welford's running mean and M2, so the image is bitwise
// the same however passes are split into dispatches. Non-finite samples are dropped
// and counted in accum_m2[].w.
layout(local_size_x = 8, local_size_y = 8) in;

#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "sampling/sampler.glsl"
#include "sampling/stratified.glsl"
#include "camera/camera.glsl"
#include "camera/filter.glsl"
#include "@integrator"

void main() {
    if (gl_WorkGroupID.x >= u_params.dispatch.y) return;
    uint tiles = u_params.image.z * u_params.image.w;
    uint tile = permute_index(u_params.dispatch.x + gl_WorkGroupID.x, tiles, u_params.dispatch.w);
    uvec2 pixel = uvec2(tile % u_params.image.z, tile / u_params.image.z) * 8u + gl_LocalInvocationID.xy;
    if (any(greaterThanEqual(pixel, u_params.image.xy))) return;
    uint idx = pixel.y * u_params.image.x + pixel.x;
    uint pixel_hash = sampler_pixel_hash(pixel, u_params.dispatch.z);

    vec4 mean = accum_mean[idx];
    vec4 m2 = accum_m2[idx];
    vec4 aov_albedo = vec4(0.0), aov_normal = vec4(0.0);
    if (kAovs) {
        aov_albedo = accum_aov[2u * idx];
        aov_normal = accum_aov[2u * idx + 1u];
    }
    for (uint k = 0u; k < u_params.samples.y; ++k) {
        LOOP_TICK();
        SamplerState s = sampler_start(pixel_hash, u_params.samples.x + k, u_params.samples.z,
                                       u_params.samples.w);
        // The measurement equation: pixel filter, lens, time
        float filter_weight;
        vec2 offset = sample_pixel_filter(sampler_2d(s), u_params.filter_params, filter_weight);
        vec2 u_lens = sampler_2d(s);
        float tau = u_params.shutter.y > u_params.shutter.x ? sample_shutter_time(sampler_1d(s)) : 0.0;
        vec3 o, d;
        float t_min, t_max;
        camera_ray(vec2(pixel) + 0.5 + offset, u_lens, tau, o, d, t_min, t_max);
        Aov aov = Aov(vec3(0.0), vec3(0.0), 0.0);
        vec3 L = filter_weight * integrator_li(o + t_min * d, d, t_max - t_min, tau, s, aov);
        if (kDebugNonFinite != 0u && (s.index % 7u) == kDebugNonFinite - 1u) L = vec3(uintBitsToFloat(0x7fc00000u));
        if (is_finite(L)) {
            mean.w += 1.0;
            vec3 delta = L - mean.rgb;
            mean.rgb += delta / mean.w;
            m2.rgb += delta * (L - mean.rgb);
            if (kAovs) {
                aov_albedo += (vec4(aov.albedo, 0.0) - aov_albedo) / mean.w;
                aov_normal += (vec4(aov.normal, aov.depth) - aov_normal) / mean.w;
            }
        } else {
            m2.w += 1.0;
        }
    }
    accum_mean[idx] = mean;
    accum_m2[idx] = m2;
    if (kAovs) {
        accum_aov[2u * idx] = aov_albedo;
        accum_aov[2u * idx + 1u] = aov_normal;
    }
    if (kCountLoops) debug_counters[idx] = max(debug_counters[idx], g_loop_count);
}
