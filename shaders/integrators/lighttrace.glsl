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
    int medium = kMedia ? light_start_medium(st.o, st.e.d, st.time) : kNoMedium;

    // s = 1: the light's own point seen by the camera (area lights: a camera ray can
    // hit those; point and spot lights stay invisible, as in the path tracer)
    if (!kHideEmitters && light_is_area(l)) {
        CameraConnection c = camera_connect(st.e.p, u_lens, st.time);
        if (c.valid) {
            vec3 Le = light_emitted_toward(l, st.e, c.wi);
            vec3 ng = light_is_area(l) ? st.e.n : vec3(0.0);
            // the medium toward the lens (a two-sided light's other side may have another)
            int m = kMedia ? light_start_medium(offset_ray_origin(st.e.p, ng, c.wi), c.wi, st.time) : kNoMedium;
            if (max_component(Le) > 0.0)
                splat_film(c.film, Le * c.importance / (st.pmf * st.e.pdf_pos) *
                                   camera_transmittance(st.e.p, ng, c, st.time, l.info.z, m));
        }
    }

    vec3 beta = st.beta;
    vec3 beta_bsdf = vec3(1.0);   // the BSDF part of beta, for Russian roulette
    vec3 o = st.o, d = st.e.d;
    vec3 chan = vec3(1.0);        // kMedia: spectral MIS over hero channels (media/medium.glsl)
    int hero = 0;
    int crossings = 0;            // null surfaces passed since the last vertex
    // light sources at infinity across an unbounded homogeneous medium: only its clear channels
    if (kMedia && light_is_infinite(l) && medium != kNoMedium && !medium_is_grid(medium))
        beta *= vec3(equal(u_media.media[medium].sigma_t.xyz, vec3(0.0)));
    // segments: light to the vertex; connecting it to the lens adds one. In media a free
    // flight is sampled before each surface: a scattering event is a vertex as a surface is,
    // connected to the lens through the media by its phase function; null surfaces are
    // passed and count no segment.
    int segments = 1;
    while (segments + 1 <= max_segments) {
        LOOP_TICK();
        SurfaceHit hit;
        g_light_path_rays = true;     // a normal map's flip is for camera paths
        bool found = scene_intersect(o, d, kInfinity, st.time, hit);
        bool in_medium = false;
        vec3 p = hit.p;
        if (kMedia) {
            vec2 u_medium = sampler_2d(s);
            g_medium_rng = pcg_hash(floatBitsToUint(u_medium.y) ^ uint(segments + 32 * crossings));
            if (segments == 1 && crossings == 0) hero = min(int(medium_random() * 3.0), 2);
            if (medium != kNoMedium) {
                MediumEvent ev = medium_sample(medium, o, d, found ? hit.t : kInfinity, u_medium.x, hero);
                vec3 w = vec3(1.0);
                medium_event_weight(w, chan, ev.f, ev.p);
                beta *= w;
                beta_bsdf *= w;
                if (max_component(beta) <= 0.0) break;
                in_medium = ev.scatter;
                if (in_medium) p = o + ev.t * d;
            }
            if (!in_medium && found && material_is_null(hit.material)) {
                if (!medium_cross_null(hit, d, medium, o, crossings)) break;
                continue;
            }
        }
        if (!in_medium && !found) break;
        vec2 u_lens = sampler_2d(s);
        vec2 u_choice = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        float u_rr = sampler_1d(s);
        vec3 wi;
        if (in_medium) {
            // Connect the medium vertex to the lens by the phase function
            CameraConnection c = camera_connect(p, u_lens, st.time);
            if (c.valid)
                splat_film(c.film, beta * medium_phase(medium, d, c.wi) * c.importance *
                                   camera_transmittance(p, vec3(0.0), c, st.time, kNoPrimitive, medium));
            if (segments + 2 > max_segments) {
                if (kMaxDepth < 0) g_truncated_paths += 1u;
                break;
            }
            // Sample the phase function (its weight is 1) to continue the path
            wi = medium_sample_phase(medium, d, u_bsdf);
            o = p;
        } else {
            Bsdf b = bsdf_from_material(hit.material, hit.uv);
            Frame frame = shading_frame(hit);
            bsdf_normal_frame(b, hit.ns0, frame);
            vec3 wo = frame_to_local(frame, -d);
            if (!light_side_valid(-d, hit.ng, frame.z)) break;      // the arrival: the light side

            // Connect the vertex to the lens
            if (!bsdf_is_delta(b)) {
                CameraConnection c = camera_connect(hit.p, u_lens, st.time);
                if (c.valid) {
                    vec3 wl = frame_to_local(frame, c.wi);
                    vec3 f = bsdf_eval(b, wo, wl, true) * shading_normal_correction(-d, c.wi, hit.ns, hit.ng);
                    if (max_component(f) > 0.0)
                        splat_film(c.film, beta * f * c.importance *
                                           camera_transmittance(hit.p, hit.ng, c, st.time, kNoPrimitive,
                                                                kMedia ? medium_after(hit.material, hit.ng, c.wi, medium)
                                                                       : kNoMedium));
                }
            }
            if (segments + 2 > max_segments) {
                if (kMaxDepth < 0) g_truncated_paths += 1u;   // the cap, not the scene's depth
                break;
            }

            // Sample the adjoint BSDF to continue the path
            BsdfSample bs = bsdf_sample(b, wo, u_choice.y, u_bsdf, true);
            if (!bs.valid) break;
            wi = frame_from_local(frame, bs.wi);    // the camera side: free
            vec3 weight = bs.weight * shading_normal_correction(-d, wi, hit.ns, hit.ng);
            beta *= weight;
            beta_bsdf *= weight;
            o = offset_ray_origin(hit.p, hit.ng, wi);
            if (kMedia) medium = medium_after(hit.material, hit.ng, wi, medium);
        }

        // Possibly terminate the path with Russian roulette
        if (roulette_applies(segments + 1)) {
            float q = roulette_survival(max_component(beta_bsdf));
            if (!(u_rr < q)) break;
            beta /= q;
            beta_bsdf /= q;
        }
        if (max_component(beta) <= 0.0) break;
        d = wi;
        segments += 1;
        crossings = 0;
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
