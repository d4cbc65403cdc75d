// Light transport at one surface vertex: emission found by a ray, next-event estimation, AOVs.
//
// Shared by the path and direct integrators. The MIS weights follow kStrategy:
// `light` counts emission only through light samples, `bsdf` only through BSDF hits,
// the mis-* settings weight both (Veach 1997, eq. 9.13 and 9.15).
#include "integrators/integrator_common.glsl"
#include "bsdf/bsdf.glsl"
#include "bsdf/material.glsl"
#include "lights/light.glsl"
#include "lights/light_selection.glsl"
#include "@scene"
#include "media/medium.glsl"

// Rays to lights stop this fraction short of the sampled point (pbrt's ShadowEpsilon).
const float kShadowEpsilon = 1e-4;

// Shading normals in light transport, every integrator's rule: a direction w (world) on the
// light side of a surface vertex must lie on the same side of the geometric surface (ng)
// and the shading surface (ns); the camera side is free. The path tracer ends a sampled
// direction that breaks it, and its light samples take none, and it takes any arriving
// camera ray, as Mitsuba's normalmap does; a light path's light side is its arrival.
bool light_side_valid(vec3 w, vec3 ng, vec3 ns) {
    return dot(w, ng) * dot(w, ns) > 0.0;
}

void record_aov(inout Aov aov, SurfaceHit hit) {
    if (!kAovs) return;
    aov.albedo = bsdf_albedo(bsdf_from_material(hit.material, hit.uv));
    aov.normal = hit.ns;
    aov.depth = hit.t;
}

// The AOVs of the path tracer, for a denoiser's auxiliary images: at the first hit
// (depth 0) as record_aov; where that surface is a mirror, glass or a null surface
// (a delta BSDF), the albedo and normal of the next hits replace them until the
// first non-delta one, its albedo scaled by `weight`, the product of the delta
// surfaces' sampled weights in front of it (the radiance scale 1/eta^2 of entering
// glass cancels on leaving it; the product is clamped to [0, 1]): OIDN's advice for
// its albedo and normal images. Depth stays the first hit's. Returns whether the
// hit is a delta surface (follow the path further).
bool record_aov_through(inout Aov aov, SurfaceHit hit, int depth, vec3 weight) {
    Bsdf b = bsdf_from_material(hit.material, hit.uv);
    if (depth == 0) aov.depth = hit.t;
    aov.albedo = clamp(weight * bsdf_albedo(b), 0.0, 1.0);
    aov.normal = hit.ns;
    return bsdf_is_delta(b);
}

// Emission of the area light at `hit`, seen along d, by a segment of `depth`
// previous segments whose BSDF sample had solid-angle pdf prev_pdf (n_bsdf samples
// against n_light light samples for the direct integrator's counts), from the vertex
// prev_p whose light samples chose lights for the normal prev_n (select_light_at: its
// shading normal, 0 in a medium).
vec3 emitter_hit_contribution_n(SurfaceHit hit, vec3 d, int depth, vec3 prev_p, vec3 prev_n, float prev_pdf,
                                bool prev_delta, float n_bsdf, float n_light) {
    uint index = hit.light - 1u;
    LightData l = scene_light(index);
    vec3 Le = area_light_radiance(l, hit.ng, -d, hit.uv);
    if (depth == 0) return kHideEmitters ? vec3(0.0) : Le;
    if (prev_delta || kStrategy == kStrategyBsdf) return Le;
    if (kStrategy == kStrategyLight) return vec3(0.0);
    float pdf_light = light_selection_pmf_at(prev_p, prev_n, index) * light_pdf_area_hit(l, prev_p, d, hit.t, hit.ng);
    return Le * mis_weight_n(n_bsdf, prev_pdf, n_light, pdf_light);
}

vec3 emitter_hit_contribution(SurfaceHit hit, vec3 d, int depth, vec3 prev_p, vec3 prev_n, float prev_pdf,
                              bool prev_delta) {
    return emitter_hit_contribution_n(hit, d, depth, prev_p, prev_n, prev_pdf, prev_delta, 1.0, 1.0);
}

// Radiance of the environment along d for a ray that escaped, weighted as above.
vec3 environment_contribution_n(vec3 d, int depth, vec3 prev_p, vec3 prev_n, float prev_pdf,
                                bool prev_delta, float n_bsdf, float n_light) {
    uint env = u_params.counts.z;
    if (env == 0u) return vec3(0.0);
    float pdf_env;
    vec3 Le = environment_radiance(scene_light(env - 1u), d, pdf_env);
    if (depth == 0) return kHideEmitters ? vec3(0.0) : Le;
    if (prev_delta || kStrategy == kStrategyBsdf) return Le;
    if (kStrategy == kStrategyLight) return vec3(0.0);
    // its probability at the vertex the ray left, for the normal its light samples chose for
    // (the light BVH weighs the lights at infinity against the tree's root there)
    return Le * mis_weight_n(n_bsdf, prev_pdf, n_light, light_selection_pmf_at(prev_p, prev_n, env - 1u) * pdf_env);
}

// For rays that no light sample competes with (a camera ray, depth 0, or one a delta BSDF
// sampled, prev_delta): their weight needs no light probability, hence no normal.
vec3 environment_contribution(vec3 d, int depth, vec3 prev_p, float prev_pdf, bool prev_delta) {
    return environment_contribution_n(d, depth, prev_p, vec3(0.0), prev_pdf, prev_delta, 1.0, 1.0);
}

// A light sample's shadow ray and what it brings when nothing blocks it: f |cos| Le w / pdf,
// without the path throughput (valid false: no ray to trace, nothing brought).
struct ShadowRay {
    vec3 o;
    vec3 d;
    float t_max;
    uint ignore;   // the primitive the ray aims at (scene_occluded skips it)
    vec3 value;
    bool valid;
};

const ShadowRay kNoShadowRay = ShadowRay(vec3(0.0), vec3(0.0), 0.0, 0u, vec3(0.0), false);

// One light sample at the vertex p (with n_light light and n_bsdf BSDF samples taken
// there): choose a light with u_select (for the shading normal frame.z), sample it with
// u_light; the shadow ray to trace.
ShadowRay next_event_ray(vec3 p, SurfaceHit hit, Bsdf b, Frame frame, vec3 wo, float u_select,
                         vec2 u_light, bool use_mis, float n_light, float n_bsdf) {
    if (u_params.counts.x == 0u) return kNoShadowRay;
    LightChoice choice = select_light_at(p, frame.z, u_select);
    if (!(choice.pmf > 0.0)) return kNoShadowRay;
    LightData light = scene_light(choice.index);
    LightSample ls = sample_light(light, p, u_light);
    if (!(ls.pdf > 0.0) || max_component(ls.Le) <= 0.0) return kNoShadowRay;
    if (!light_side_valid(ls.wi, hit.ng, frame.z)) return kNoShadowRay;
    vec3 wi = frame_to_local(frame, ls.wi);
    float pdf_bsdf;
    vec3 f = bsdf_eval_pdf(b, wo, wi, false, pdf_bsdf);
    if (max_component(f) <= 0.0) return kNoShadowRay;
    vec3 o = offset_ray_origin(p, hit.ng, ls.wi);
    float t_max = isinf(ls.dist) ? kInfinity : ls.dist * (1.0 - kShadowEpsilon);
    float pdf_light = choice.pmf * ls.pdf;
    float w = (ls.delta || !use_mis) ? 1.0 : mis_weight_n(n_light, pdf_light, n_bsdf, pdf_bsdf);
    return ShadowRay(o, ls.wi, t_max, light.info.z, f * ls.Le * (w / pdf_light), true);
}

// The medium of the path at the vertex that takes a light sample (kMedia): its shadow ray
// starts in it, or across the vertex's surface where that bounds media.
int g_medium = kNoMedium;

// The same light sample with its shadow ray traced: f |cos| Le w / pdf, or zero (times the
// transmittance of the media along the ray, kMedia).
vec3 next_event_n(vec3 p, SurfaceHit hit, Bsdf b, Frame frame, vec3 wo, float time, float u_select,
                  vec2 u_light, bool use_mis, float n_light, float n_bsdf) {
    ShadowRay r = next_event_ray(p, hit, b, frame, wo, u_select, u_light, use_mis, n_light, n_bsdf);
    if (!r.valid) return vec3(0.0);
    if (kMedia)
        return r.value * scene_transmittance(r.o, r.d, r.t_max, time, r.ignore,
                                             medium_after(hit.material, hit.ng, r.d, g_medium));
    RAY_TICK();
    if (scene_occluded(r.o, r.d, r.t_max, time, r.ignore)) return vec3(0.0);
    return r.value;
}

// The emission that a ray from vertex p (a surface point whose geometric normal is ng and
// shading normal n, or a point in a medium: both 0) along w finds, through null surfaces and
// the media on the way (their transmittance estimated, kMedia): an area light or the
// environment, weighed by MIS against light sampling as emitter_hit_contribution_n weighs
// it (pdf: the density w was sampled with, delta: a delta BSDF's; n_bsdf, n_light: the
// sample counts). m: the medium the ray starts in.
vec3 emission_through(vec3 p, vec3 ng, vec3 n, vec3 w, float time, int m, float pdf, bool delta,
                      float n_bsdf, float n_light) {
    vec3 tr = vec3(1.0);
    vec3 from = dot(ng, ng) > 0.0 ? offset_ray_origin(p, ng, w) : p;
    float lead = 0.0;
    for (int k = 0; k <= kMaxNullCrossings; ++k) {
        LOOP_TICK();
        SurfaceHit h;
        RAY_TICK();
        bool found = scene_intersect(from, w, kInfinity, time, h);
        if (m != kNoMedium)
            tr *= medium_segment_transmittance(m, from - lead * w, w, found ? lead + h.t : kInfinity);
        if (max_component(tr) <= 0.0) return vec3(0.0);
        if (!found) return tr * environment_contribution_n(w, 1, p, n, pdf, delta, n_bsdf, n_light);
        vec3 Le = vec3(0.0);
        if (h.light != 0u) {
            SurfaceHit at = h;
            at.t = distance(p, h.p);   // the light's density from p, across null surfaces
            Le = tr * emitter_hit_contribution_n(at, w, 1, p, n, pdf, delta, n_bsdf, n_light);
        }
        if (!material_is_null(h.material) || k == kMaxNullCrossings) return Le;
        m = medium_after(h.material, h.ng, w, m);
        from = offset_ray_origin(h.p, h.ng, w);
        lead = crossing_lead(from, h, w);
        if (max_component(Le) > 0.0) return Le;
    }
    return vec3(0.0);
}

// Next-event estimation at a point p of medium m reached along d: one light sample, its
// phase function value times Le over its density with the transmittance of the media on
// the way, weighted against phase sampling as surfaces weigh it against BSDF sampling
// (n_light light and n_phase phase samples taken there).
vec3 medium_next_event_n(vec3 p, vec3 d, int m, float time, float u_select, vec2 u_light, bool use_mis,
                         float n_light, float n_phase) {
    if (u_params.counts.x == 0u) return vec3(0.0);
    LightChoice choice = select_light_at(p, vec3(0.0), u_select);
    if (!(choice.pmf > 0.0)) return vec3(0.0);
    LightData light = scene_light(choice.index);
    LightSample ls = sample_light(light, p, u_light);
    if (!(ls.pdf > 0.0) || max_component(ls.Le) <= 0.0) return vec3(0.0);
    float f = medium_phase(m, d, ls.wi);
    float pdf_light = choice.pmf * ls.pdf;
    float w = (ls.delta || !use_mis) ? 1.0 : mis_weight_n(n_light, pdf_light, n_phase, f);
    float t_max = isinf(ls.dist) ? kInfinity : ls.dist * (1.0 - kShadowEpsilon);
    return scene_transmittance(p, ls.wi, t_max, time, light.info.z, m) * f * ls.Le * (w / pdf_light);
}

vec3 medium_next_event(vec3 p, vec3 d, int m, float time, float u_select, vec2 u_light, bool use_mis) {
    return medium_next_event_n(p, d, m, time, u_select, u_light, use_mis, 1.0, 1.0);
}

vec3 next_event(vec3 p, SurfaceHit hit, Bsdf b, Frame frame, vec3 wo, float time, float u_select,
                vec2 u_light, bool use_mis) {
    return next_event_n(p, hit, b, frame, wo, time, u_select, u_light, use_mis, 1.0, 1.0);
}
