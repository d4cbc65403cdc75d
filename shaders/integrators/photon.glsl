// Photon mapping's camera pass (Jensen 2001, ch. 9; the two-pass method): the camera
// ray follows delta surfaces (mirrors, glass) to its first non-delta surface x, picking
// up emission seen directly or through them; at x
//   - direct light by next-event estimation (light sampling, no MIS: photons carry none of it),
//   - caustics (L S+ D) from the caustic map,
//   - the rest of the indirect light from the global map: at x itself (its indirect
//     photons), or with --final-gather through one BSDF-sampled gather ray, followed
//     through delta surfaces to a non-delta surface x', where the global map's photons
//     of every type estimate the light leaving x' toward x (emission the gather ray
//     meets is not counted: direct light and caustics at x have their own terms).
// (mode.w = 1, tests: direct light from the global map's direct photons instead of NEE.)
// In media (kMedia) the camera ray samples free flights as the path tracer does and passes
// null surfaces without counting them; where it scatters in a medium before the surface,
// x is that point: direct light by next-event estimation through the media's
// transmittance (phase function, light sampling alone), the volume photons of the caustic
// map and the indirect ones of the global map for the rest (photon/photon_gather.glsl's
// volume estimate; no final gather from there). A gather ray samples free flights too and
// ends at a scattering event as at a non-delta surface.
// Depth counts segments as Mitsuba's max_depth: a photon counts only where the camera's
// and the photon's segments together stay within it.
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "photon/photon_gather.glsl"
#include "photon/camera_path.glsl"
#include "integrators/pixel_loop.glsl"

GatherPoint gather_point(SurfaceHit hit, Bsdf b, vec3 d) {
    Frame frame = shading_frame(hit);
    bsdf_normal_frame(b, hit.ns0, frame);
    return GatherPoint(hit.p, hit.ng, b, frame, frame_to_local(frame, -d), kNoMedium);
}

// A gather point at a scattering event at p in medium m reached along d (kMedia): its
// volume photons estimate the in-scattered radiance toward -d (no BSDF, no frame).
GatherPoint medium_gather_point(vec3 p, int m, vec3 d) {
    GatherPoint g;
    g.p = p;
    g.ng = vec3(0.0);
    g.wo_l = -d;
    g.medium = m;
    return g;
}

// One gather ray from g (camera segments to g: `segments`; cm: the camera path's media,
// kMedia): true when it reaches a non-delta surface or (kMedia) scatters in a medium
// before one, its gather point in `at`, the camera segments to it in `at_segments` and
// the path's weights from g to it in `weight` (the global map's estimate there, times
// `weight`, is the gather's contribution). Null surfaces it passes without counting.
bool final_gather(GatherPoint g, SurfaceHit hit, float time, int segments, int max_segments,
                  CameraMedia cm, inout SamplerState s, out GatherPoint at, out int at_segments,
                  out vec3 weight) {
    at = g;
    at_segments = 0;
    weight = vec3(0.0);
    vec2 u_lobe = sampler_2d(s);
    vec2 u_bsdf = sampler_2d(s);
    BsdfSample bs = bsdf_sample(g.b, g.wo_l, u_lobe.x, u_bsdf, false);
    if (!bs.valid) return false;
    vec3 d = frame_from_local(g.frame, bs.wi);
    if (dot(d, hit.ng) * bs.wi.z <= 0.0) return false;
    vec3 beta = bs.weight, o = offset_ray_origin(hit.p, hit.ng, d);
    if (kMedia) cm.medium = medium_after(hit.material, hit.ng, d, cm.medium);
    int k = segments + 1;
    for (int step = 0; step < kCameraPathSteps && k < max_segments; ++step) {
        LOOP_TICK();
        SurfaceHit h;
        bool found = scene_intersect(o, d, kInfinity, time, h);
        float t_event;
        if (kMedia && camera_free_flight(cm, s, o, d, found ? h.t : kInfinity, false, beta, t_event)) {
            at = medium_gather_point(o + t_event * d, cm.medium, d);
            at_segments = k;
            weight = beta;
            return true;
        }
        if (!found || (kMedia && !(max_component(beta) > 0.0))) break;
        if (kMedia && material_is_null(h.material)) {
            cm.medium = medium_after(h.material, h.ng, d, cm.medium);
            o = offset_ray_origin(h.p, h.ng, d);
            continue;
        }
        Bsdf b = bsdf_from_material(h.material, h.uv);
        if (!bsdf_is_delta(b)) {
            at = gather_point(h, b, d);
            at_segments = k;
            weight = beta;
            return true;
        }
        Frame frame = shading_frame(h);
        bsdf_normal_frame(b, h.ns0, frame);
        vec2 u_l = sampler_2d(s);
        vec2 u_d = sampler_2d(s);
        if (!continue_camera_path(h, b, frame, frame_to_local(frame, -d), u_l.x, u_d, beta, o, d)) break;
        if (kMedia) cm.medium = medium_after(h.material, h.ng, d, cm.medium);
        k += 1;
    }
    return false;
}

vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    int max_segments = kMaxDepth < 0 ? kUnboundedDepthCap : kMaxDepth;
    vec3 L = vec3(0.0), beta = vec3(1.0);
    CameraMedia cm = camera_media_start();
    int depth = 0;
    for (int step = 0; step < kCameraPathSteps && depth < max_segments; ++step) {
        LOOP_TICK();
        SurfaceHit hit;
        bool found = scene_intersect(o, d, t_max, time, hit);
        float t_event;
        bool scattered = kMedia && camera_free_flight(cm, s, o, d, found ? hit.t : t_max, step == 0,
                                                      beta, t_event);
        if (kMedia && !scattered && !(max_component(beta) > 0.0)) break;
        Bsdf b;
        GatherPoint g;
        if (!scattered) {
            if (!found) {
                vec3 Le = environment_contribution(d, depth, o, 1.0, true);
                L += beta * Le;
                if (kAovs && depth == 0) aov.emission = Le;   // the emission AOV: the first hit's
                break;
            }
            if (depth == 0) record_aov(aov, hit);
            if (hit.light != 0u) {
                vec3 Le = emitter_hit_contribution(hit, d, depth, o, vec3(0.0), 1.0, true);
                L += beta * Le;
                if (kAovs && depth == 0) aov.emission = Le;
            }
            if (kMedia && material_is_null(hit.material)) {   // passed: neither a vertex nor a bounce
                cm.medium = medium_after(hit.material, hit.ng, d, cm.medium);
                o = offset_ray_origin(hit.p, hit.ng, d);
                t_max = kInfinity;
                continue;
            }
            b = bsdf_from_material(hit.material, hit.uv);
            g = gather_point(hit, b, d);
        } else {
            g = medium_gather_point(o + t_event * d, cm.medium, d);
        }
        vec2 u_choice = sampler_2d(s);
        vec2 u_light = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        if (scattered || !bsdf_is_delta(b)) {
            int segments = depth + 1;     // camera segments to x
            if (segments + 1 > max_segments) break;
            // a point in a medium takes its volume photons at x itself (no final gather)
            bool gather = u_map.mode.z != 0u && !scattered;
            uint types = gather ? 0u : 1u << kPhotonIndirect;
            g_medium = cm.medium;
            if (u_map.mode.w != 0u)
                types |= 1u << kPhotonDirect;   // direct light from the photons too (tests)
            else if (scattered)
                L += beta * medium_next_event(g.p, d, cm.medium, time, u_choice.x, u_light, false);
            else
                L += beta * next_event(hit.p, hit, b, g.frame, g.wo_l, time, u_choice.x, u_light, false);
            GatherPoint g_gather;
            int gather_segments;
            vec3 gather_weight;
            bool gathered = gather && final_gather(g, hit, time, segments, max_segments, cm, s,
                                                   g_gather, gather_segments, gather_weight);
            // The lookups, in this order: caustics at x, the global map at x, the global map
            // where the gather ray ends (every photon type). One call of photon_estimate in
            // a loop: GLSL functions are inlined at each call, and each copy of the lookup
            // (its kNN heap, two BSDF evaluations) added ~15 s of llvmpipe code generation.
            uint all_types = (1u << kPhotonDirect) | (1u << kPhotonCaustic) | (1u << kPhotonIndirect);
            int lookups = gathered ? 3 : 2;
            for (int j = 0; j < lookups; ++j) {
                if (j == 1 && types == 0u) continue;
                bool at_gather = j == 2;
                vec3 est = photon_estimate(j == 0 ? kCausticMap : kGlobalMap,
                                           at_gather ? g_gather : g,
                                           j == 0 ? 1u << kPhotonCaustic : (at_gather ? all_types : types),
                                           max_segments - (at_gather ? gather_segments : segments));
                L += beta * (at_gather ? gather_weight * est : est);
            }
            break;
        }
        if (!continue_camera_path(hit, b, g.frame, g.wo_l, u_choice.y, u_bsdf, beta, o, d)) break;
        if (kMedia) cm.medium = medium_after(hit.material, hit.ng, d, cm.medium);
        t_max = kInfinity;
        depth += 1;
    }
    return L;
}
