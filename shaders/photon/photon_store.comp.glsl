#version 450
// The photon integrator's photon pass: one photon per invocation, photons [first, first +
// count) of the pass. Each photon is traced from a light (photon/photon_tracer.glsl:
// lights chosen by power, Russian roulette by albedo) and stored at every non-delta
// surface it reaches (photon/map_layout.glsl): its position, geometric normal, the
// direction it came from, its power and type (direct: the first surface; caustic:
// reached through delta surfaces only, L S+ D; indirect: the rest) and the segments it
// took. The caustic map's pass (trace.w = 1) keeps caustic photons only and ends each
// photon at its first non-delta surface. In media (kMedia) a photon is stored at each
// scattering event too, as a volume photon of the same types (a caustic one: reached
// through delta surfaces only, light focused into fog; the caustic pass ends there too). Photons beyond the buffer's capacity are
// counted and not stored (the host keeps what earlier dispatches stored and traces the
// dispatch again into an emptied buffer, splatting none of its photons twice).
// Photon j draws its numbers as sample j of a sequence scrambled by (seed, map).
layout(local_size_x = 64) in;

#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "photon/map_layout.glsl"
#include "photon/photon_tracer.glsl"
#include "photon/photon_view.glsl"

void store_photon(SurfaceHit hit, Photon ph, uint type, int segments) {
    uint k = atomicAdd(map_counters[0], 1u);
    if (k >= u_map.store.x) return;
    traced_photons[3u * k] = vec4(hit.p, uintBitsToFloat(type));
    traced_photons[3u * k + 1u] = vec4(-ph.d, uintBitsToFloat(packSnorm4x8(vec4(hit.ng, 0.0))));
    traced_photons[3u * k + 2u] = vec4(ph.beta, float(segments));
}

// A volume photon (kMedia): at its scattering event at p in its medium, before it scatters.
void store_volume_photon(vec3 p, Photon ph, uint type, int segments) {
    uint k = atomicAdd(map_counters[0], 1u);
    if (k >= u_map.store.x) return;
    traced_photons[3u * k] = vec4(p, uintBitsToFloat(kPhotonVolume + type));
    traced_photons[3u * k + 1u] = vec4(-ph.d, intBitsToFloat(ph.medium));
    traced_photons[3u * k + 2u] = vec4(medium_over_sigma_s(ph.medium, p, ph.beta), float(segments));
}

void main() {
    if (gl_GlobalInvocationID.x >= u_map.trace.y) return;
    uint j = u_map.trace.x + gl_GlobalInvocationID.x;
    uint hash = sampler_pixel_hash(uvec2(u_map.trace.w, 0xfffffffeu), u_params.dispatch.z);
    SamplerState s = sampler_start(hash, j, u_map.trace.z, 1u);
    Photon ph = photon_start(s);
    bool caustic_map = u_map.trace.w == 1u;
    // a photon path of k segments meets a camera path of at least one
    int max_segments = int(u_map.store.y) - 1;
    bool delta_only = true;
    for (int segments = 1; segments <= max_segments && ph.alive; ++segments) {
        LOOP_TICK();
        PhotonHit h;
        int event = photon_next_event(ph, s, h);
        if (event == kPhotonEscaped) break;
        if (kMedia && event == kPhotonMedium) {
            // a scattering event in a medium: a volume photon, typed as a surface photon
            uint type = segments == 1 ? kPhotonDirect : (delta_only ? kPhotonCaustic : kPhotonIndirect);
            if (!caustic_map || type == kPhotonCaustic) store_volume_photon(h.hit.p, ph, type, segments);
            if (caustic_map) break;
            delta_only = false;
            if (segments + 1 > max_segments) break;
            photon_scatter_medium(ph, h, h.u_bsdf, h.u_rr);
            continue;
        }
        if (!bsdf_is_delta(h.b)) {
            uint type = segments == 1 ? kPhotonDirect : (delta_only ? kPhotonCaustic : kPhotonIndirect);
            if (!caustic_map || type == kPhotonCaustic) {
                store_photon(h.hit, ph, type, segments);
                if (u_map.store.z != 0u && j >= u_map.store.w) splat_photon_view(h.hit, ph, h.u_lens);
            }
            if (caustic_map) break;
            delta_only = false;
        }
        if (segments + 1 > max_segments) break;
        photon_scatter(ph, h.hit, h.b, h.u_choice.y, h.u_bsdf, h.u_rr);
    }
    if (kCountLoops) atomicMax(debug_counters[0], g_loop_count);
}
