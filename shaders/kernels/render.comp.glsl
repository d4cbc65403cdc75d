#version 450
// The render kernel: one invocation per pixel of an 8x8 tile, a few samples per pass.
//
// Each dispatch covers tiles [first, first + count) of a hashed permutation of the
// image's tiles (llvmpipe hands each thread a contiguous run of work groups: the
// permutation spreads expensive regions across threads). The integrator renders the
// pixel's samples of this pass (integrators/pixel.glsl) in index order into Welford's
// running mean and M2, so the image is bitwise the same however passes are split into
// dispatches. Non-finite samples are dropped and counted in accum_m2[].w. The
// accumulation may hold a band of tile rows only (a unit of a distributed render).
layout(local_size_x = 8, local_size_y = 8) in;

#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "sampling/sampler.glsl"
#include "sampling/stratified.glsl"
#include "@integrator"

void main() {
    if (gl_WorkGroupID.x >= u_params.dispatch.y) return;
    uint tiles = u_params.image.z * u_params.image.w;
    uint tile = permute_index(u_params.dispatch.x + gl_WorkGroupID.x, tiles, u_params.dispatch.w);
    uint first_row = u_params.counts.w;   // the accumulation holds tile rows [first_row, first_row + image.w)
    uvec2 pixel = uvec2(tile % u_params.image.z, tile / u_params.image.z + first_row) * 8u + gl_LocalInvocationID.xy;
    if (any(greaterThanEqual(pixel, u_params.image.xy))) return;
    uint idx = (pixel.y - 8u * first_row) * u_params.image.x + pixel.x;
    uint pixel_hash = sampler_pixel_hash(pixel, u_params.dispatch.z);

    Accumulator acc = Accumulator(accum_mean[idx], accum_m2[idx], vec4(0.0), vec4(0.0), vec4(0.0));
    if (kAovs) {
        acc.albedo = accum_aov[kAovVec4s * idx];
        acc.normal = accum_aov[kAovVec4s * idx + 1u];
        acc.emission = accum_aov[kAovVec4s * idx + 2u];
    }
    integrator_pixel(pixel, pixel_hash, u_params.samples.x, u_params.samples.y, acc);
    accum_mean[idx] = acc.mean;
    accum_m2[idx] = acc.m2;
    if (kAovs) {
        accum_aov[kAovVec4s * idx] = acc.albedo;
        accum_aov[kAovVec4s * idx + 1u] = acc.normal;
        accum_aov[kAovVec4s * idx + 2u] = acc.emission;
    }
    if (kCountLoops) debug_counters[idx] = max(debug_counters[idx], g_loop_count);
    if (kCountRays) debug_counters[idx] += g_ray_count;
}
