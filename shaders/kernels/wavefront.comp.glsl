#version 450
// The path tracer as stages over queues of paths (the wavefront executor,
// glrender/render/wavefront.py), for scenes whose rays spend their time in the BVH.
//
// In the render kernel a SIMD vector runs 8 pixels' paths in lock step, and a BVH
// traversal runs for the whole vector while only the lanes whose rays meet a mesh have
// work in it. Here every segment of every path in flight is a queue entry, and the
// queues are binned by whether the ray meets the meshes' box (scene_meets_meshes): those
// rays fill the queue from the front, the others from the back, so the vectors that
// traverse the BVH have a ray in every lane. A queue entry is the path's whole state,
// moved to its place in the next queue at every step (two buffers, in turn): reading
// state through an index costs a cache miss per path and step, about as much as the
// rest of a step. A wave holds a fixed set of samples (pixel, sample index), each one path:
//
// Each stage is its own program (kWaveStage):
//   kStageGenerate  camera rays of the wave's paths into the ray queue;
//   kStageExtend    the BVH's nearest hit of each ray at the queue's front, in a small
//                   kernel (traced inside the step instead, the bunny scene measured 0.67x
//                   the render kernel's speed against 0.84x);
//   kStageStep      one segment of each queued path (integrators/path.glsl path_step):
//                   the closest hit, emission, the light sample's shadow ray (traced
//                   here when it misses the meshes' box, else into the shadow queue), the
//                   BSDF sample's ray into the next ray queue; a path
//                   that ends adds its sample to the film (unless its shadow ray is
//                   pending: then it goes on in the queue's back, and the next step adds
//                   its sample);
//   kStageShadow    each queued shadow ray's any-hit query; what it brings joins its
//                   path's radiance.
//
// Each path draws the random numbers it would draw in the render kernel, in the same
// order, and its sample is added to the exact fixed-point sums by atomics
// (accumulate_atomic): the image is bitwise the render kernel's.
layout(local_size_x = 256) in;

#extension GL_ARB_shader_ballot : enable
#extension GL_ARB_gpu_shader_int64 : enable
#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "sampling/sampler.glsl"
#include "geometry/bvh.glsl"

// The extend stage's answer for the path being stepped (none for a ray that misses the
// meshes' box), which the scene code's closest hit takes in place of a traversal.
BvhHit g_wave_hit = BvhHit(0.0, kBvhNoHit, vec2(0.0));

bool wave_bvh_hit(float t_max, out BvhHit bh) {
    bh = g_wave_hit;
    return bh.prim != kBvhNoHit && bh.t < t_max;
}

#include "@integrator"

const uint kStageGenerate = 0u;
const uint kStageStep = 1u;
const uint kStageShadow = 2u;
const uint kStageExtend = 3u;

// A path between segments, 10 vec4 (160 bytes).
struct WavePath {
    vec4 o_tmax;       // ray origin, t_max
    vec4 d_time;       // ray direction, shutter time
    vec4 L_eta;        // radiance so far, eta product
    vec4 beta_pdf;     // throughput, pdf of the last BSDF sample
    vec4 prev_flags;   // last vertex, flags (uint bits): depth | prev_delta << 16 |
                       // aov_open << 17 | ended << 18
    uvec4 sampler;     // pixel hash, sample index, next dimension, accumulation index
    vec4 weight_aovw;  // pixel filter weight, product of delta weights for the AOVs
    vec4 albedo_depth;
    vec4 normal;
    vec4 emission;
};

// A shadow ray waiting for its any-hit query, 3 vec4 (48 bytes).
struct WaveShadow {
    vec4 o_tmax;
    vec4 d_slot;       // direction, the path's entry in the next queue (uint bits)
    vec4 value_ignore; // what it brings (times the throughput), the primitive it aims at
};

layout(std430, binding = SSBO_WAVE_PATHS_IN) readonly buffer WavePathsIn { WavePath paths_in[]; };
layout(std430, binding = SSBO_WAVE_PATHS_OUT) buffer WavePathsOut { WavePath paths_out[]; };
layout(std430, binding = SSBO_WAVE_SHADOWS) buffer WaveShadows { WaveShadow wave_shadows[]; };
// [0], [1]: entries of the next ray queue from the front (meeting the meshes) and the
// back; [2], [3]: the same for the shadow queue
layout(std430, binding = SSBO_WAVE_COUNTERS) buffer WaveCounters { uint wave_counters[]; };
// the extend stage's BVH hit per entry of the input queue: t, triangle (uint bits), barycentrics
layout(std430, binding = SSBO_WAVE_HITS) buffer WaveHits { vec4 wave_hits[]; };

// x, y: entries of the input queue at its front and its back; z: the queues' capacity
// (paths in the wave); w: the wave's first path (generate)
uniform uvec4 u_wave;
// x: samples per pixel in the pass, y: the pass's first sample index, z: pixels of the
// slice's tile grid (tiles x 64)
uniform uvec4 u_pass;

const uint kFlagPrevDelta = 1u << 16u;
const uint kFlagAovOpen = 1u << 17u;
const uint kFlagEnded = 1u << 18u;

void wave_store(uint slot, PathState st, SamplerState s, uint idx, float weight, bool ended) {
    uint flags = uint(st.depth) | (st.prev_delta ? kFlagPrevDelta : 0u) |
                 (st.aov_open ? kFlagAovOpen : 0u) | (ended ? kFlagEnded : 0u);
    paths_out[slot].o_tmax = vec4(st.o, st.t_max);
    paths_out[slot].d_time = vec4(st.d, st.time);
    paths_out[slot].L_eta = vec4(st.L, st.eta_product);
    paths_out[slot].beta_pdf = vec4(st.beta, st.prev_pdf);
    paths_out[slot].prev_flags = vec4(st.prev_p, uintBitsToFloat(flags));
    paths_out[slot].sampler = uvec4(s.pixel_hash, s.index, s.dim, idx);
    paths_out[slot].weight_aovw = vec4(weight, st.aov_weight);
    if (kAovs) {
        paths_out[slot].albedo_depth = vec4(st.aov.albedo, st.aov.depth);
        paths_out[slot].normal = vec4(st.aov.normal, 0.0);
        paths_out[slot].emission = vec4(st.aov.emission, 0.0);
    }
}

PathState wave_load(uint slot, out SamplerState s, out uint idx, out float weight) {
    vec4 o_tmax = paths_in[slot].o_tmax;
    vec4 d_time = paths_in[slot].d_time;
    PathState st = path_start(o_tmax.xyz, d_time.xyz, o_tmax.w, d_time.w);
    vec4 L_eta = paths_in[slot].L_eta;
    vec4 beta_pdf = paths_in[slot].beta_pdf;
    vec4 prev_flags = paths_in[slot].prev_flags;
    uvec4 sampler = paths_in[slot].sampler;
    vec4 weight_aovw = paths_in[slot].weight_aovw;
    st.L = L_eta.xyz;
    st.eta_product = L_eta.w;
    st.beta = beta_pdf.xyz;
    st.prev_pdf = beta_pdf.w;
    st.prev_p = prev_flags.xyz;
    uint flags = floatBitsToUint(prev_flags.w);
    st.depth = int(flags & 0xFFFFu);
    st.prev_delta = (flags & kFlagPrevDelta) != 0u;
    st.aov_open = (flags & kFlagAovOpen) != 0u;
    st.aov_weight = weight_aovw.yzw;
    if (kAovs) {
        vec4 albedo_depth = paths_in[slot].albedo_depth;
        st.aov = Aov(albedo_depth.xyz, paths_in[slot].normal.xyz, albedo_depth.w,
                     paths_in[slot].emission.xyz);
    }
    s = sampler_start(sampler.x, sampler.y, u_params.samples.z, u_params.samples.w);
    s.dim = sampler.z;
    idx = sampler.w;
    weight = weight_aovw.x;
    return st;
}

// Appends to a binned queue: from the front when `front`, else from the back; kNone when
// not `want`. Every invocation that reaches the call takes part: with subgroup ballots,
// the lanes of a subgroup that append to one end take their places with one atomic add
// (the counter's cache line is fought over by every thread: one add per lane cost more
// than the rest of a step).
#if defined(GL_ARB_shader_ballot) && defined(GL_ARB_gpu_shader_int64)
uint bits64(uvec2 m) { return uint(bitCount(m.x) + bitCount(m.y)); }
uint lsb64(uvec2 m) { return m.x != 0u ? uint(findLSB(m.x)) : 32u + uint(findLSB(m.y)); }

uint wave_append(uint counter, bool want, bool front) {
    uvec2 below = unpackUint2x32(gl_SubGroupLtMaskARB);
    uvec2 mf = unpackUint2x32(ballotARB(want && front));
    uvec2 mb = unpackUint2x32(ballotARB(want && !front));
    uint lane = gl_SubGroupInvocationARB;
    uint base = 0u;
    uint index = 0xFFFFFFFFu;
    if ((mf.x | mf.y) != 0u) {
        uint leader = lsb64(mf);
        if (lane == leader) base = atomicAdd(wave_counters[counter], bits64(mf));
        base = readInvocationARB(base, leader);
        if (want && front) index = base + bits64(mf & below);
    }
    if ((mb.x | mb.y) != 0u) {
        uint leader = lsb64(mb);
        if (lane == leader) base = atomicAdd(wave_counters[counter + 1u], bits64(mb));
        base = readInvocationARB(base, leader);
        if (want && !front) index = u_wave.z - 1u - (base + bits64(mb & below));
    }
    return index;
}
#else
uint wave_append(uint counter, bool want, bool front) {
    if (!want) return 0xFFFFFFFFu;
    uint k = atomicAdd(wave_counters[counter + (front ? 0u : 1u)], 1u);
    return front ? k : u_wave.z - 1u - k;
}
#endif

// The entry of the binned input queue that invocation i takes (kNone beyond the queue).
uint wave_entry(uint i) {
    if (i < u_wave.x) return i;
    i -= u_wave.x;
    return i < u_wave.y ? u_wave.z - 1u - i : 0xFFFFFFFFu;
}

void wave_finish(uint idx, PathState st, SamplerState s, float weight) {
    accumulate_atomic(idx, weight * st.L, aov_scaled(st.aov, weight), s.index);
}

void wave_counts(uint idx) {
    if (g_truncated_paths > 0u) atomicAdd(accum_sum[4u * idx + 3u].z, g_truncated_paths);
    if (kCountLoops) atomicMax(debug_counters[idx], g_loop_count);
    if (kCountRays) atomicAdd(debug_counters[idx], g_ray_count);
}

void stage_generate() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_wave.y) return;
    uint g = u_wave.w + i;
    uint p = g / u_pass.x;                      // the pixel in the slice's tile order
    uint sample_index = u_pass.y + g % u_pass.x;
    uint tile = p / 64u, within = p % 64u;
    uint first_row = u_params.counts.w;
    uvec2 pixel = uvec2(tile % u_params.image.z, tile / u_params.image.z + first_row) * 8u +
                  uvec2(within % 8u, within / 8u);
    // a wave slot whose pixel lies beyond the image holds an ended path
    bool inside = all(lessThan(pixel, u_params.image.xy)) && p < u_pass.z;
    uint idx = (pixel.y - 8u * first_row) * u_params.image.x + pixel.x;
    uint pixel_hash = sampler_pixel_hash(pixel, u_params.dispatch.z);
    SamplerState s = pixel_sampler(pixel_hash, sample_index);
    PathState st;
    float weight = 0.0;
    if (inside) {
        CameraSample c = camera_sample(pixel, s);
        st = path_start(c.o, c.d, c.t_max, c.time);
        weight = c.weight;
    } else {
        st = path_start(vec3(0.0), vec3(0.0, 0.0, 1.0), 0.0, 0.0);
    }
    uint k = wave_append(0u, inside, scene_meets_meshes(st.o, st.d, st.t_max));
    if (inside) wave_store(k, st, s, idx, weight, false);
}

void stage_step() {
    uint e = wave_entry(gl_GlobalInvocationID.x);
    if (e == 0xFFFFFFFFu) return;
    SamplerState s;
    uint idx;
    float weight;
    PathState st = wave_load(e, s, idx, weight);
    if ((floatBitsToUint(paths_in[e].prev_flags.w) & kFlagEnded) != 0u) {
        wave_finish(idx, st, s, weight);   // ended last step; its shadow ray is in
        return;
    }
    if (e < u_wave.x) {   // a ray of the front: the extend stage traced it
        vec4 h = wave_hits[e];
        g_wave_hit = BvhHit(h.x, floatBitsToUint(h.y), h.zw);
    }
    bool alive = path_step(st, s);
    // a shadow ray that misses the meshes' box meets compiled primitives only: cheap and
    // alike in every lane, it is traced here (added after this segment's emission, as the
    // render kernel does); the others go to the shadow stage
    ShadowRay r = st.shadow;
    bool shadow = r.valid && scene_meets_meshes(r.o, r.d, r.t_max);
    if (r.valid && !shadow) {
        RAY_TICK();
        if (!scene_occluded(r.o, r.d, r.t_max, st.time, r.ignore)) st.L += r.value;
    }
    bool carry = !alive && shadow;   // ended, waiting for its shadow ray
    uint k = wave_append(0u, alive || carry, alive && scene_meets_meshes(st.o, st.d, st.t_max));
    uint j = wave_append(2u, shadow, true);
    if (shadow) {
        wave_shadows[j] = WaveShadow(vec4(r.o, r.t_max), vec4(r.d, uintBitsToFloat(k)),
                                     vec4(r.value, uintBitsToFloat(r.ignore)));
    }
    if (alive || carry) {
        wave_store(k, st, s, idx, weight, carry);
    } else {
        wave_finish(idx, st, s, weight);
    }
    wave_counts(idx);
}

void stage_shadow() {
    uint e = wave_entry(gl_GlobalInvocationID.x);
    if (e == 0xFFFFFFFFu) return;
    WaveShadow r = wave_shadows[e];
    uint k = floatBitsToUint(r.d_slot.w);
    RAY_TICK();
    if (!scene_occluded(r.o_tmax.xyz, r.d_slot.xyz, r.o_tmax.w, paths_out[k].d_time.w,
                        floatBitsToUint(r.value_ignore.w))) {
        paths_out[k].L_eta.xyz += r.value_ignore.xyz;
    }
    if (kCountLoops || kCountRays) wave_counts(paths_out[k].sampler.w);
}

// The BVH's nearest hit of each queued ray at the queue's front (those meeting the meshes'
// box): a small kernel, so the traversal loop keeps its state in registers.
void stage_extend() {
    uint e = gl_GlobalInvocationID.x;
    if (e >= u_wave.x) return;
    vec4 o = paths_in[e].o_tmax;
    vec4 d = paths_in[e].d_time;
    BvhHit h;
    scene_bvh_closest(o.xyz, d.xyz, o.w, d.w, h);
    wave_hits[e] = vec4(h.t, uintBitsToFloat(h.prim), h.bary);
}

void main() {
    if (kWaveStage == kStageExtend) {
        stage_extend();
    } else if (kWaveStage == kStageGenerate) {
        stage_generate();
    } else if (kWaveStage == kStageStep) {
        stage_step();
    } else {
        stage_shadow();
    }
}
