#version 450
// The render kernel: one invocation per pixel of an 8x8 tile, a few samples per pass.
//
// Each dispatch covers tiles [first, first + count) of a hashed permutation of the
// image's tiles (llvmpipe hands each thread a contiguous run of work groups: the
// permutation spreads expensive regions across threads). The integrator renders the
// pixel's samples of this pass (integrators/pixel.glsl) into exact fixed-point sums
// (film/accum.glsl), so the image is bitwise the same however the samples are split into
// passes, dispatches or sample ranges added elsewhere. Non-finite samples are dropped and
// counted, and so are paths a depth cap cut short (counts.z). The accumulation may hold a band of tile rows only (a unit of a distributed
// render).
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

    Accumulator acc;
    for (int c = 0; c < 3; ++c) {
        acc.sum[c] = accum_sum[4u * idx + c];
        acc.sq[c] = accum_sq[3u * idx + c];
    }
    acc.counts = accum_sum[4u * idx + 3u].xy;
    uint truncated = accum_sum[4u * idx + 3u].z;   // paths cut short by a depth cap
    for (int c = 0; c < int(kAovChannels); ++c) acc.aov[c] = kAovs ? accum_aov[kAovChannels * idx + c] : uvec4(0u);
    accumulator_clear(acc);
    integrator_pixel(pixel, pixel_hash, u_params.samples.x, u_params.samples.y, acc);
    accumulator_flush(acc);
    for (int c = 0; c < 3; ++c) {
        accum_sum[4u * idx + c] = acc.sum[c];
        accum_sq[3u * idx + c] = acc.sq[c];
    }
    accum_sum[4u * idx + 3u] = uvec4(acc.counts, truncated + g_truncated_paths, 0u);
    if (kAovs) {
        for (int c = 0; c < int(kAovChannels); ++c) accum_aov[kAovChannels * idx + c] = acc.aov[c];
    }
    if (kCountLoops) debug_counters[idx] = max(debug_counters[idx], g_loop_count);
    if (kCountRays) debug_counters[idx] += g_ray_count;
}
