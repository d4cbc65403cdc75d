// Light tracing (particle tracing): paths start on the lights and every vertex is
// connected to the lens, its contribution splatted onto the film.
//
// These are the t = 1 strategies of bidirectional path tracing alone (Veach 1997,
// sec. 10.2): s = 1 sees area lights directly, s > 1 connects surface vertices of the
// light path. Delta surfaces (mirrors, smooth glass) cannot be connected, so what the
// camera sees through them stays black, as do lights at infinity seen directly.
// Every camera sample of every pixel traces one light path; the camera-side image gets
// a zero for it (keeping its sample counts) and the splats, divided by the number of
// light paths, make the image (Renderer.film). max_depth counts the segments of the
// whole path, the one to the lens included; Russian roulette from kRrDepth segments on by
// the rule kRrRule (integrators/roulette.glsl; the throughput rule on the adjoint BSDF
// throughput: importance needs no eta^2 rescaling).
// The emission AOV stays 0 (lights seen directly arrive as splats, s = 1).
#include "integrators/integrator_common.glsl"
#include "integrators/roulette.glsl"
#include "integrators/shading.glsl"
#include "integrators/pixel.glsl"
#include "integrators/light_path.glsl"
#include "integrators/splat.glsl"

void light_trace(inout SamplerState s) {
    int max_segments = kMaxDepth < 0 ? kUnboundedDepthCap : kMaxDepth;
    LightPathStart st = light_path_start(s);
    vec2 u_lens = sampler_2d(s);
    if (!st.valid) return;
    LightData l = scene_light(st.light);

    // s = 1: the light's own point seen by the camera (area lights: a camera ray can
    // hit those; point and spot lights stay invisible, as in the path tracer)
    if (!kHideEmitters && light_is_area(l)) {
        CameraConnection c = camera_connect(st.e.p, u_lens, st.time);
        if (c.valid) {
            vec3 Le = light_emitted_toward(l, st.e, c.wi);
            vec3 ng = light_is_area(l) ? st.e.n : vec3(0.0);
            if (max_component(Le) > 0.0 && camera_visible(st.e.p, ng, c, st.time, l.info.z))
                splat_film(c.film, Le * c.importance / (st.pmf * st.e.pdf_pos));
        }
    }

    vec3 beta = st.beta;
    vec3 beta_bsdf = vec3(1.0);   // the BSDF part of beta, for Russian roulette
    vec3 o = st.o, d = st.e.d;
    // segments: light to the vertex; connecting it to the lens adds one
    for (int segments = 1; segments + 1 <= max_segments; ++segments) {
        LOOP_TICK();
        SurfaceHit hit;
        g_light_path_rays = true;     // a normal map's flip is for camera paths
        if (!scene_intersect(o, d, kInfinity, st.time, hit)) break;
        vec2 u_lens = sampler_2d(s);
        vec2 u_choice = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        float u_rr = sampler_1d(s);
        Bsdf b = bsdf_from_material(hit.material, hit.uv);
        Frame frame = shading_frame(hit);
        bsdf_normal_frame(b, hit.ns0, frame);
        vec3 wo = frame_to_local(frame, -d);
        if (!light_side_valid(-d, hit.ng, frame.z)) break;      // the arrival: the light side

        // Connect the vertex to the lens
        if (!bsdf_is_delta(b)) {
            CameraConnection c = camera_connect(hit.p, u_lens, st.time);
            if (c.valid) {
                vec3 wi = frame_to_local(frame, c.wi);
                vec3 f = bsdf_eval(b, wo, wi, true) * shading_normal_correction(-d, c.wi, hit.ns, hit.ng);
                if (max_component(f) > 0.0 &&
                    camera_visible(hit.p, hit.ng, c, st.time, kNoPrimitive))
                    splat_film(c.film, beta * f * c.importance);
            }
        }
        if (segments + 2 > max_segments) {
            if (kMaxDepth < 0) g_truncated_paths += 1u;   // the cap, not the scene's depth
            break;
        }

        // Sample the adjoint BSDF to continue the path
        BsdfSample bs = bsdf_sample(b, wo, u_choice.y, u_bsdf, true);
        if (!bs.valid) break;
        vec3 wi = frame_from_local(frame, bs.wi);    // the camera side: free
        vec3 weight = bs.weight * shading_normal_correction(-d, wi, hit.ns, hit.ng);
        beta *= weight;
        beta_bsdf *= weight;

        // Possibly terminate the path with Russian roulette
        if (roulette_applies(segments + 1)) {
            float q = roulette_survival(max_component(beta_bsdf));
            if (!(u_rr < q)) break;
            beta /= q;
            beta_bsdf /= q;
        }
        if (max_component(beta) <= 0.0) break;
        o = offset_ray_origin(hit.p, hit.ng, wi);
        d = wi;
    }
}

// Samples [first, first + count) of a pixel: one light path each.
void integrator_pixel(uvec2 pixel, uint pixel_hash, uint first, uint count, inout Accumulator acc) {
    Aov none = kNoAov;
    for (uint k = 0u; k < count; ++k) {
        LOOP_TICK();
        SamplerState s = pixel_sampler(pixel_hash, first + k);
        light_trace(s);
        accumulate(acc, vec3(0.0), none, first + k);
    }
}
