// Unidirectional path tracing with next-event estimation, MIS and Russian roulette.
//
// At every non-specular vertex one light is chosen (uniformly or by power) and
// sampled; the BSDF is sampled to continue the path, and an emitter found that way
// is weighted against the light-sampling pdf (Veach 1997, ch. 9; the heuristic is
// kStrategy: mis-power, the default as in Mitsuba, or mis-balance; `light` counts only
// light samples and `bsdf` only BSDF hits). Depth counts segments as in Mitsuba.
// Russian roulette from depth kRrDepth on: survive with q = min(max(beta) eta^2, 0.95)
// (Mitsuba's rule; eta^2 keeps paths alive inside refractive media) and divide by q.
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"

vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    vec3 L = vec3(0.0);
    vec3 beta = vec3(1.0);
    float eta_product = 1.0;
    float prev_pdf = 0.0;      // solid-angle pdf of the BSDF sample that made this segment
    bool prev_delta = true;    // that sample was specular (or this is the camera ray)
    vec3 prev_p = o;
    int max_segments = kMaxDepth < 0 ? kUnboundedDepthCap : kMaxDepth;
    for (int depth = 0; depth < max_segments; ++depth) {
        LOOP_TICK();
        SurfaceHit hit;
        if (!scene_intersect(o, d, t_max, time, hit)) {
            L += beta * environment_contribution(d, depth, prev_p, prev_pdf, prev_delta);
            break;
        }
        vec3 p = o + hit.t * d;
        if (depth == 0) record_aov(aov, hit);

        // Emission of an area light found by the camera ray or by BSDF sampling
        if (hit.light != 0u)
            L += beta * emitter_hit_contribution(hit, d, depth, prev_p, prev_pdf, prev_delta);

        // Possibly stop: the next segment would exceed the maximum depth
        if (depth + 1 >= max_segments) break;

        Bsdf b = bsdf_from_material(hit.material, hit.uv);
        Frame frame = frame_from_z(hit.ns);
        vec3 wo = frame_to_local(frame, -d);

        // Next-event estimation (its numbers are drawn even when unused, so that
        // later dimensions keep their meaning and their stratification)
        vec2 u_choice = sampler_2d(s);   // x: light selection, y: BSDF lobe
        vec2 u_light = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        float u_rr = sampler_1d(s);
        if (kStrategy != kStrategyBsdf && !bsdf_is_delta(b))
            L += beta * next_event(p, hit, b, frame, wo, time, u_choice.x, u_light, kStrategy != kStrategyLight);

        // Sample the BSDF to continue the path
        BsdfSample bs = bsdf_sample(b, wo, u_choice.y, u_bsdf, false);
        if (!bs.valid) break;
        vec3 wi = frame_from_local(frame, bs.wi);
        // a direction on the wrong side of the geometric surface leaks light: end the path
        if (dot(wi, hit.ng) * bs.wi.z <= 0.0) break;
        beta *= bs.weight;
        eta_product *= bs.eta;
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        prev_p = p;

        // Possibly terminate the path with Russian roulette
        if (depth + 1 >= kRrDepth) {
            float q = min(max_component(beta) * eta_product * eta_product, 0.95);
            if (!(u_rr < q)) break;
            beta /= q;
        }
        if (max_component(beta) <= 0.0) break;
        o = offset_ray_origin(p, hit.ng, wi);
        d = wi;
        t_max = kInfinity;
    }
    return L;
}
