// Direct illumination only, by light sampling, BSDF sampling or both with MIS (Veach's comparison).
//
// Mitsuba's `direct`: kEmitterSamples light samples and kBsdfSamples BSDF samples
// per camera ray, each estimate divided by its count and, under the mis-* strategies,
// weighted with the sample counts in the heuristic (Veach 1997, eq. 9.13 / 9.15).
// `light` uses light samples only (point lights work; glossy highlights of large
// lights are noisy), `bsdf` uses BSDF samples only (point lights stay black).
// The emission AOV is the first hit's emitted radiance (or the environment's on a miss).
// With participating media (kMedia) it estimates single scattering (direct_li_media).
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "integrators/pixel_loop.glsl"

// Direct lighting at the surface `hit` reached along d (its light and BSDF samples) added
// to L; m: the medium the camera ray arrived in (kMedia: shadow rays and BSDF samples see
// the media's transmittance, and BSDF samples find emitters beyond null surfaces).
vec3 direct_at_surface(SurfaceHit hit, vec3 d, float time, inout SamplerState s, int m, vec3 L) {
    vec3 p = hit.p;
    Bsdf b = bsdf_from_material(hit.material, hit.uv);
    Frame frame = shading_frame(hit);
    bsdf_normal_frame(b, hit.ns0, frame);
    vec3 wo = frame_to_local(frame, -d);
    bool use_light = kStrategy != kStrategyBsdf;
    bool use_bsdf = kStrategy != kStrategyLight;
    float n_light = use_light ? float(kEmitterSamples) : 0.0;
    float n_bsdf = use_bsdf ? float(kBsdfSamples) : 0.0;
    bool delta = bsdf_is_delta(b);
    g_medium = m;

    for (int k = 0; k < kEmitterSamples; ++k) {
        vec2 u_select = sampler_2d(s);
        vec2 u_light = sampler_2d(s);
        if (use_light && !delta)
            L += next_event_n(p, hit, b, frame, wo, time, u_select.x, u_light, use_bsdf, n_light, n_bsdf) / n_light;
    }
    for (int k = 0; k < kBsdfSamples; ++k) {
        vec2 u_lobe = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        if (!use_bsdf && !delta) continue;
        BsdfSample bs = bsdf_sample(b, wo, u_lobe.x, u_bsdf, false);
        if (!bs.valid) continue;
        vec3 wi = frame_from_local(frame, bs.wi);
        if (!light_side_valid(wi, hit.ng, frame.z)) continue;
        // a delta BSDF is sampled by its BSDF samples alone (no light sample can find it)
        float n = use_bsdf ? n_bsdf : float(kBsdfSamples);
        float n_l = delta ? 0.0 : n_light;
        vec3 Le = vec3(0.0);
        if (kMedia) {
            Le = emission_through(p, hit.ng, frame.z, wi, time, medium_after(hit.material, hit.ng, wi, m), bs.pdf,
                                  bs.delta || delta, n, n_l);
        } else {
            vec3 o2 = offset_ray_origin(p, hit.ng, wi);
            SurfaceHit h2;
            if (scene_intersect(o2, wi, kInfinity, time, h2)) {
                if (h2.light != 0u)
                    Le = emitter_hit_contribution_n(h2, wi, 1, p, frame.z, bs.pdf, bs.delta || delta, n, n_l);
            } else {
                Le = environment_contribution_n(wi, 1, p, frame.z, bs.pdf, bs.delta || delta, n, n_l);
            }
        }
        L += bs.weight * Le / n;
    }
    return L;
}

// Single scattering in media (kMedia): the camera ray passes null surfaces and samples
// free flights in the media it crosses (spectral MIS over a hero channel, as the path
// tracer's, integrators/path.glsl); at a scattering event in a medium, light samples by the
// phase function and phase samples that find emitters (through the media's transmittance),
// MIS-weighted as at surfaces; at a surface, its direct lighting. The path tracer at max
// depth 2 estimates the same.
vec3 direct_li_media(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    int m = camera_medium();
    vec2 u_medium = sampler_2d(s);
    g_medium_rng = pcg_hash(floatBitsToUint(u_medium.y));
    int hero = min(int(medium_random() * 3.0), 2);
    vec3 beta = vec3(1.0), chan = vec3(1.0), L = vec3(0.0);
    vec3 from = o;
    float reach = t_max;
    bool use_light = kStrategy != kStrategyBsdf;
    bool use_phase = kStrategy != kStrategyLight;
    for (int k = 0; k <= kMaxNullCrossings; ++k) {
        LOOP_TICK();
        SurfaceHit hit;
        bool found = scene_intersect(from, d, reach, time, hit);
        if (m != kNoMedium) {
            MediumEvent ev = medium_sample(m, from, d, found ? hit.t : reach, u_medium.x, hero);
            medium_event_weight(beta, chan, ev.f, ev.p);
            if (max_component(beta) <= 0.0) return L;
            if (ev.scatter) {
                if (kMaxDepth == 1) return L;
                vec3 p = from + ev.t * d;
                bool nee = use_light && medium_samples_emitters(m);
                float n_light = nee ? float(kEmitterSamples) : 0.0;
                float n_phase = use_phase ? float(kBsdfSamples) : 0.0;
                for (int j = 0; j < kEmitterSamples; ++j) {
                    vec2 u_select = sampler_2d(s);
                    vec2 u_light = sampler_2d(s);
                    if (nee)
                        L += beta * medium_next_event_n(p, d, m, time, u_select.x, u_light, use_phase,
                                                        n_light, n_phase) / n_light;
                }
                for (int j = 0; j < kBsdfSamples; ++j) {
                    vec2 u_lobe = sampler_2d(s);
                    vec2 u_dir = sampler_2d(s);
                    if (!use_phase && nee) continue;
                    // without light samples here, the phase samples count whole
                    float n = use_phase ? n_phase : float(kBsdfSamples);
                    vec3 wi = medium_sample_phase(m, d, u_dir);
                    L += beta * emission_through(p, vec3(0.0), vec3(0.0), wi, time, m, medium_phase(m, d, wi),
                                                 !nee, n, n_light) / n;
                }
                return L;
            }
        }
        if (!found) {
            vec3 Le = beta * environment_contribution(d, 0, o, 0.0, true);
            if (kAovs && k == 0) aov.emission = Le;
            return L + Le;
        }
        if (k == 0) record_aov(aov, hit);
        if (hit.light != 0u) L += beta * emitter_hit_contribution(hit, d, 0, o, vec3(0.0), 0.0, true);
        if (kAovs) aov.emission = L;
        if (material_is_null(hit.material)) {   // a medium's boundary: on through it
            m = medium_after(hit.material, hit.ng, d, m);
            from = offset_ray_origin(hit.p, hit.ng, d);
            reach = kInfinity;
            continue;
        }
        if (kMaxDepth == 1) return L;
        return L + beta * direct_at_surface(hit, d, time, s, m, vec3(0.0));
    }
    return L;
}

vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    if (kMedia) return direct_li_media(o, d, t_max, time, s, aov);
    SurfaceHit hit;
    if (!scene_intersect(o, d, t_max, time, hit)) {
        vec3 Le = environment_contribution(d, 0, o, 0.0, true);
        if (kAovs) aov.emission = Le;
        return Le;
    }
    record_aov(aov, hit);
    vec3 L = vec3(0.0);
    if (hit.light != 0u) L += emitter_hit_contribution(hit, d, 0, o, vec3(0.0), 0.0, true);
    if (kAovs) aov.emission = L;
    if (kMaxDepth == 1) return L;
    return direct_at_surface(hit, d, time, s, kNoMedium, L);
}
