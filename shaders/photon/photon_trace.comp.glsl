#version 450
#extension GL_NV_shader_atomic_float : require
// The photon pass: one photon per invocation, photons [first, first + count) of this
// iteration. Each photon is traced from a light (photon/photon_tracer.glsl) and, at
// every non-delta surface it reaches from its options.x-th segment on, deposited into
// the visible points around it (photon/sppm_deposit.glsl); in media (kMedia) also at every
// scattering event, into the visible points in media around it. Photon j of iteration t
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
#include "photon/photon_view.glsl"

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
        PhotonHit h;
        int event = photon_next_event(ph, s, h);
        if (event == kPhotonEscaped) break;
        if (kMedia && event == kPhotonMedium) {
            // a volume photon: into the visible points in media around it
            if (segments >= int(u_photon.options.x))
                sppm_deposit(h.hit.p, vec3(0.0), ph.medium, -ph.d,
                             medium_over_sigma_s(ph.medium, h.hit.p, ph.beta), segments, budget, visited);
            if (segments + 1 > max_segments) break;
            photon_scatter_medium(ph, h, h.u_bsdf, h.u_rr);
            continue;
        }
        if (!bsdf_is_delta(h.b) && segments >= int(u_photon.options.x)) {
            sppm_deposit(h.hit.p, h.hit.ng, kNoMedium, -ph.d, ph.beta, segments, budget, visited);
            if (u_photon.options.w != 0u) splat_photon_view(h.hit, ph, h.u_lens);
        }
        if (segments + 1 > max_segments) break;
        photon_scatter(ph, h.hit, h.b, h.u_choice.y, h.u_bsdf, h.u_rr);
    }
    if (visited > 0u) {
        atomicAdd(photon_records[1], visited);
        atomicMax(photon_records[2], visited);
    }
    if (kCountLoops) atomicMax(debug_counters[0], g_loop_count);
}
