// Direct illumination only, by light sampling, BSDF sampling or both with MIS (Veach's comparison).
//
// Mitsuba's `direct`: kEmitterSamples light samples and kBsdfSamples BSDF samples
// per camera ray, each estimate divided by its count and, under the mis-* strategies,
// weighted with the sample counts in the heuristic (Veach 1997, eq. 9.13 / 9.15).
// `light` uses light samples only (point lights work; glossy highlights of large
// lights are noisy), `bsdf` uses BSDF samples only (point lights stay black).
// The emission AOV is the first hit's emitted radiance (or the environment's on a miss).
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "integrators/pixel_loop.glsl"

vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    SurfaceHit hit;
    if (!scene_intersect(o, d, t_max, time, hit)) {
        vec3 Le = environment_contribution(d, 0, o, 0.0, true);
        if (kAovs) aov.emission = Le;
        return Le;
    }
    record_aov(aov, hit);
    vec3 L = vec3(0.0);
    if (hit.light != 0u) L += emitter_hit_contribution(hit, d, 0, o, 0.0, true);
    if (kAovs) aov.emission = L;
    if (kMaxDepth == 1) return L;

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
        vec3 o2 = offset_ray_origin(p, hit.ng, wi);
        SurfaceHit h2;
        vec3 Le = vec3(0.0);
        if (scene_intersect(o2, wi, kInfinity, time, h2)) {
            if (h2.light != 0u)
                Le = emitter_hit_contribution_n(h2, wi, 1, p, bs.pdf, bs.delta || delta, n, n_l);
        } else {
            Le = environment_contribution_n(wi, 1, p, bs.pdf, bs.delta || delta, n, n_l);
        }
        L += bs.weight * Le / n;
    }
    return L;
}
