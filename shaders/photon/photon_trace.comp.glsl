#version 450
#extension GL_NV_shader_atomic_float : require
// The photon pass: one photon per invocation, photons [first, first + count) of this
// iteration. Each photon is traced from a light (photon/photon_tracer.glsl) and, at
// every non-delta surface it reaches from its options.x-th segment on, deposited into
// the visible points around it (photon/sppm_deposit.glsl). Photon j of iteration t
// draws its numbers as sample j of a sequence scrambled by (seed, t), so an iteration's
// photons are one randomization of the sampler (stratified across the pass with
// Owen-scrambled Sobol'). Deposits are float atomics: their sums are independent of the
// dispatch split up to float rounding order (statistically the same image, not bitwise).
layout(local_size_x = 64) in;

#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "photon/layout.glsl"
#include "photon/photon_tracer.glsl"
#include "photon/sppm_deposit.glsl"
#include "integrators/splat.glsl"

// The photon-map view (options.w = 1): every photon hit at a non-delta surface seen by
// the camera adds the photon's power to the pixel it projects to (the splat image,
// storage block 7), so the picture shows where the photons are, coloured by power.
void splat_photon_view(SurfaceHit hit, Photon ph, vec2 u_lens) {
    CameraConnection c = camera_connect(hit.p, u_lens, ph.time);
    if (c.valid && camera_visible(hit.p, hit.ng, c, ph.time, kNoPrimitive)) splat_film(c.film, ph.beta);
}

void main() {
    uint j = u_photon.photons.x + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= u_photon.photons.y) return;
    uint hash = sampler_pixel_hash(uvec2(u_photon.photons.w, 0xffffffffu), u_params.dispatch.z);
    SamplerState s = sampler_start(hash, j, u_photon.photons.z, 1u);
    Photon ph = photon_start(s);
    if (u_photon.options.z != 0u) {
        uint r = 4u + 4u * j;
        photon_records[r] = floatBitsToUint(ph.beta.r);
        photon_records[r + 1u] = floatBitsToUint(ph.beta.g);
        photon_records[r + 2u] = floatBitsToUint(ph.beta.b);
        photon_records[r + 3u] = ph.alive ? ph.light : 0xffffffffu;
    }
    // a photon path of k segments meets a camera path of at least one
    int max_segments = int(u_photon.options.y) - 1;
    uint budget = kCandidateBudget, visited = 0u;
    for (int segments = 1; segments <= max_segments && ph.alive; ++segments) {
        LOOP_TICK();
        SurfaceHit hit;
        g_light_path_rays = true;     // a normal map's flip is for camera paths
        if (!scene_intersect(ph.o, ph.d, kInfinity, ph.time, hit)) break;
        vec2 u_choice = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        float u_rr = sampler_1d(s);
        vec2 u_lens = sampler_2d(s);
        Bsdf b = bsdf_from_material(hit.material, hit.uv);
        if (!bsdf_is_delta(b) && segments >= int(u_photon.options.x)) {
            sppm_deposit(hit.p, hit.ng, -ph.d, ph.beta, segments, budget, visited);
            if (u_photon.options.w != 0u) splat_photon_view(hit, ph, u_lens);
        }
        if (segments + 1 > max_segments) break;
        photon_scatter(ph, hit, b, u_choice.y, u_bsdf, u_rr);
    }
    if (visited > 0u) {
        atomicAdd(photon_records[1], visited);
        atomicMax(photon_records[2], visited);
    }
    if (kCountLoops) atomicMax(debug_counters[0], g_loop_count);
}
