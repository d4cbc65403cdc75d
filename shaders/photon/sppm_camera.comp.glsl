#version 450
// SPPM's camera pass: one camera sample per pixel and iteration (sample index = the
// iteration), followed through delta surfaces (mirrors, glass, null) to its first
// non-delta surface, the visible point, or (kMedia) to a scattering event in a medium
// before it (photon/camera_path.glsl), a visible point in the medium: its position's w is
// then minus the camera segments, and its records hold (wo, the medium) and beta. On the way it collects what the photons do
// not carry: emission seen directly or through delta surfaces, and direct light at
// the visible point by next-event estimation (light sampling alone: photons that
// reach a surface straight from a light are not deposited, pbrt-v3's SPPM split;
// with options.x = 1 the photons carry direct light too and the camera pass skips it).
// Path depth counts segments as Mitsuba's max_depth: the visible point records how
// many camera segments led to it so the photon pass can respect the total.
layout(local_size_x = 8, local_size_y = 8) in;

#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "photon/layout.glsl"
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "integrators/pixel.glsl"
#include "photon/camera_path.glsl"

void main() {
    // a slice of pixel rows [estimate.y, estimate.y + estimate.z): the visible-point
    // buffers hold the slice alone (glrender/photon/sppm.py, SppmRenderer.slices)
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= u_params.image.x || local.y >= u_photon.estimate.z) return;
    uvec2 pixel = local + uvec2(0u, u_photon.estimate.y);
    if (pixel.y >= u_params.image.y) return;
    uint i = local.y * u_params.image.x + local.x;
    int max_segments = kMaxDepth < 0 ? kUnboundedDepthCap : kMaxDepth;
    SamplerState s = pixel_sampler(sampler_pixel_hash(pixel, u_params.dispatch.z), u_photon.photons.w);
    CameraSample c = camera_sample(pixel, s);
    vec3 L = vec3(0.0), beta = vec3(c.weight);
    vec3 o = c.o, d = c.d;
    float t_max = c.t_max;
    vec4 position = vec4(0.0);
    CameraMedia cm = camera_media_start();
    int depth = 0;
    for (int k = 0; k < kCameraPathSteps && depth < max_segments; ++k) {
        LOOP_TICK();
        SurfaceHit hit;
        bool found = scene_intersect(o, d, t_max, c.time, hit);
        float t_event;
        if (kMedia && camera_free_flight(cm, s, o, d, found ? hit.t : t_max, k == 0, beta, t_event)) {
            // a visible point in a medium: direct light here, volume photons for the rest
            vec3 p = o + t_event * d;
            vec2 u_choice = sampler_2d(s);
            vec2 u_light = sampler_2d(s);
            if (depth + 2 <= max_segments && u_photon.options.x >= 2u)
                L += beta * medium_next_event(p, d, cm.medium, c.time, u_choice.x, u_light, false);
            position = vec4(p, -float(depth + 1));
            vp_shading[2u * i] = vec4(-d, intBitsToFloat(cm.medium));
            vp_shading[2u * i + 1u] = vec4(0.0);
            vp_extra[2u * i] = vec4(0.0);
            vp_extra[2u * i + 1u] = vec4(beta, 0.0);
            break;
        }
        if (kMedia && !(max_component(beta) > 0.0)) break;
        if (!found) {
            L += beta * environment_contribution(d, depth, o, 1.0, true);
            break;
        }
        if (hit.light != 0u) L += beta * emitter_hit_contribution(hit, d, depth, o, vec3(0.0), 1.0, true);
        if (kMedia && material_is_null(hit.material)) {   // passed: neither a vertex nor a bounce
            cm.medium = medium_after(hit.material, hit.ng, d, cm.medium);
            o = offset_ray_origin(hit.p, hit.ng, d);
            t_max = kInfinity;
            continue;
        }
        Bsdf b = bsdf_from_material(hit.material, hit.uv);
        Frame frame = frame_from_z(hit.ns);
        bsdf_normal_frame(b, hit.ns0, frame);
        vec3 wo = frame_to_local(frame, -d);
        vec2 u_choice = sampler_2d(s);
        vec2 u_light = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        if (!bsdf_is_delta(b)) {
            // the visible point: direct light here, photons for the rest
            g_medium = cm.medium;
            if (depth + 2 <= max_segments && u_photon.options.x >= 2u)
                L += beta * next_event(hit.p, hit, b, frame, wo, c.time, u_choice.x, u_light, false);
            position = vec4(hit.p, float(depth + 1));
            vp_shading[2u * i] = vec4(-d, uintBitsToFloat(hit.material));
            vp_shading[2u * i + 1u] = vec4(hit.ns, hit.uv.x);
            vp_extra[2u * i] = vec4(hit.ng, hit.uv.y);
            vp_extra[2u * i + 1u] = vec4(beta, vp_pack_unit(b.n0));
            break;
        }
        if (!continue_camera_path(hit, b, frame, wo, u_choice.y, u_bsdf, beta, o, d)) break;
        if (kMedia) cm.medium = medium_after(hit.material, hit.ng, d, cm.medium);
        t_max = kInfinity;
        depth += 1;
    }
    if (!is_finite(L) || !is_finite(beta)) {
        L = vec3(0.0);
        position = vec4(0.0);
    }
    vp_position[i] = position;
    vp_radiance[i] = vec4(L, 0.0);
    uint p = (pixel.y - 8u * u_params.counts.w) * u_params.image.x + pixel.x;   // in the band
    if (kCountLoops) debug_counters[p] = max(debug_counters[p], g_loop_count);
}
