// Unidirectional path tracing with next-event estimation, MIS and Russian roulette.
//
// At every non-specular vertex one light is chosen (uniformly or by power) and
// sampled; the BSDF is sampled to continue the path, and an emitter found that way
// is weighted against the light-sampling pdf (Veach 1997, ch. 9; the heuristic is
// kStrategy: mis-power, the default as in Mitsuba, or mis-balance; `light` counts only
// light samples and `bsdf` only BSDF hits). Depth counts segments as in Mitsuba.
// Russian roulette from depth kRrDepth on, by the rule kRrRule (integrators/roulette.glsl;
// throughput by default: survive with q = min(max(beta) eta^2, 0.95), Mitsuba's rule).
// Splitting: kLightSamples light samples at every vertex (each weighted 1/n, and MIS
// counts them: Veach's heuristic with n_light = n), and kSplit BSDF branches at the
// camera ray's hit (the first vertex, when it is not specular), each carrying 1/kSplit
// of its throughput. Both are compile-time settings: with 1 and 1 the code and the
// random numbers are exactly those of the plain path tracer. RAY_TICK counts the rays.
// The albedo and normal AOVs are those of the first non-delta hit: through mirrors,
// glass and null surfaces the path is followed to the surface seen in them
// (record_aov_through in shading.glsl); depth is the first hit's. The emission AOV
// takes the emitters found along the same delta chain: the light seen directly, in a
// mirror or through glass, with the weights the radiance gives it.
//
// Participating media (kMedia, media/medium.glsl): the path knows the medium it is in
// (the camera's at first, then the one across each surface that bounds media), samples a
// free-flight distance in it before each surface, and scatters there by the phase
// function, with next-event estimation through the media's transmittance and MIS against
// phase sampling. Null surfaces (media boundaries) are passed through: they are not
// vertices and do not count toward the depth, and an emitter found beyond them is weighed
// from the last real vertex, as in Mitsuba's volpath.
//
// Path regeneration: llvmpipe runs 8 pixels in lock step, so a loop over whole paths
// waits for the longest of the 8 each time (measured: 72% of lane work useful on the
// Cornell box, 52% on the caustic scene). integrator_pixel instead advances every
// lane one segment per iteration and starts a lane's next sample as soon as its path
// ends; each sample still sees exactly the numbers and operations it would alone.
#include "integrators/integrator_common.glsl"
#include "integrators/roulette.glsl"
#include "integrators/shading.glsl"
#include "integrators/pixel.glsl"

// The state of one path between segments.
struct PathState {
    vec3 o;
    vec3 d;
    float t_max;
    float time;
    vec3 L;
    vec3 beta;
    float eta_product;
    float prev_pdf;      // solid-angle pdf of the BSDF sample that made this segment
    bool prev_delta;     // that sample was specular (or this is the camera ray)
    vec3 prev_p;
    vec3 prev_n;         // its shading normal, for which its light samples chose lights (0: in a medium)
    int depth;           // segments traced so far
    Aov aov;
    bool aov_open;       // the AOVs so far are a delta surface's: follow the path further
    vec3 aov_weight;     // product of the delta surfaces' sampled weights so far
    int split_left;      // BSDF branches still to start at the split vertex (kSplit > 1)
    SurfaceHit split_hit;  // the split vertex, the direction it was reached along, and the
    vec3 split_d;          // throughput (over kSplit) and eta product each branch starts from
    vec3 split_beta;
    float split_eta;
    ShadowRay shadow;      // kWavefront: this segment's light sample, value times throughput
    int medium;            // kMedia: the medium the segment runs in (kNoMedium: none)
    int hero;              // kMedia: the channel whose coefficients sample free flights
    vec3 chan;             // kMedia: the product of the medium events' densities per channel
};

PathState path_start(vec3 o, vec3 d, float t_max, float time) {
    PathState st;
    st.o = o;
    st.d = d;
    st.t_max = t_max;
    st.time = time;
    st.L = vec3(0.0);
    st.beta = vec3(1.0);
    st.eta_product = 1.0;
    st.prev_pdf = 0.0;
    st.prev_delta = true;
    st.prev_p = o;
    st.prev_n = vec3(0.0);
    st.depth = 0;
    st.aov = kNoAov;
    st.aov_open = true;
    st.aov_weight = vec3(1.0);
    st.split_left = 0;
    st.shadow = kNoShadowRay;
    st.medium = kMedia ? camera_medium() : kNoMedium;
    st.hero = -1;   // drawn at the first segment, kept for the whole path
    st.chan = vec3(1.0);
    return st;
}

// Continues the path from the vertex `hit` (reached after `depth` segments) by sampling
// its BSDF, then plays Russian roulette; false when the path ends there.
bool path_continue(inout PathState st, SurfaceHit hit, Bsdf b, Frame frame, vec3 wo, int depth,
                   float u_lobe, vec2 u_bsdf, float u_rr) {
    BsdfSample bs = bsdf_sample(b, wo, u_lobe, u_bsdf, false);
    if (!bs.valid) return false;
    vec3 wi = frame_from_local(frame, bs.wi);
    // a direction on the wrong side of the geometric surface leaks light: end the path
    if (!light_side_valid(wi, hit.ng, frame.z)) return false;
    st.beta *= bs.weight;
    if (kAovs && st.aov_open) st.aov_weight *= bs.weight;
    st.eta_product *= bs.eta;
    st.prev_pdf = bs.pdf;
    st.prev_delta = bs.delta;
    st.prev_p = hit.p;
    st.prev_n = frame.z;

    // Possibly terminate the path with Russian roulette
    if (roulette_applies(depth + 1)) {
        float q = roulette_survival(max_component(st.beta) * st.eta_product * st.eta_product);
        if (!(u_rr < q)) return false;
        st.beta /= q;
    }
    if (max_component(st.beta) <= 0.0) return false;
    st.o = offset_ray_origin(hit.p, hit.ng, wi);
    st.d = wi;
    st.t_max = kInfinity;
    if (kMedia) st.medium = medium_after(hit.material, hit.ng, wi, st.medium);
    return true;
}

// A scattering event at p in the path's medium, reached after `depth` segments: next-event
// estimation by the phase function (where the medium samples emitters), phase sampling to
// go on (its weight is 1), and Russian roulette as at surfaces; false when the path ends.
bool path_medium_vertex(inout PathState st, inout SamplerState s, vec3 p, int depth, int max_segments) {
    if (kAovs && st.aov_open) {   // a denoiser's albedo and normal: none in a medium
        st.aov.albedo = vec3(0.0);
        st.aov.normal = vec3(0.0);
        st.aov_open = false;
    }
    if (depth + 1 >= max_segments) {
        if (kMaxDepth < 0) g_truncated_paths += 1u;
        return false;
    }
    if (kEmissionOnly) return false;
    vec2 u_choice = sampler_2d(s);
    vec2 u_light = sampler_2d(s);
    vec2 u_phase = sampler_2d(s);
    float u_rr = sampler_1d(s);
    int m = st.medium;
    bool nee = kStrategy != kStrategyBsdf && medium_samples_emitters(m);
    if (nee)
        st.L += st.beta * medium_next_event(p, st.d, m, st.time, u_choice.x, u_light,
                                            kStrategy != kStrategyLight);
    vec3 wi = medium_sample_phase(m, st.d, u_phase);
    st.prev_pdf = medium_phase(m, st.d, wi);
    st.prev_delta = !nee;    // without light samples here, emitters found count whole
    st.prev_p = p;
    st.prev_n = vec3(0.0);
    if (roulette_applies(depth + 1)) {
        float q = roulette_survival(max_component(st.beta) * st.eta_product * st.eta_product);
        if (!(u_rr < q)) return false;
        st.beta /= q;
    }
    if (max_component(st.beta) <= 0.0) return false;
    st.o = p;
    st.d = wi;
    st.t_max = kInfinity;
    return true;
}

// Traces one segment of the path and shades its end; false when the path has ended.
bool path_segment(inout PathState st, inout SamplerState s) {
    int max_segments = kMaxDepth < 0 ? kUnboundedDepthCap : kMaxDepth;
    int depth = st.depth;
    st.depth += 1;
    SurfaceHit hit;
    RAY_TICK();
    bool found = scene_intersect(st.o, st.d, st.t_max, st.time, hit);
    if (kMedia) {
        vec2 u_medium = sampler_2d(s);
        g_medium_rng = pcg_hash(floatBitsToUint(u_medium.y) ^ uint(depth));
        // the hero channel: once per path (segments after null crossings keep depth 0 and
        // draw the number again, but keep the channel that st.chan weighs)
        if (depth == 0) {
            int hero = min(int(medium_random() * 3.0), 2);
            if (st.hero < 0) st.hero = hero;
        }
        if (st.medium != kNoMedium) {
            MediumEvent ev = medium_sample(st.medium, st.o, st.d, found ? hit.t : st.t_max,
                                           u_medium.x, st.hero);
            medium_event_weight(st.beta, st.chan, ev.f, ev.p);
            if (ev.scatter) return path_medium_vertex(st, s, st.o + ev.t * st.d, depth, max_segments);
            if (max_component(st.beta) <= 0.0) return false;
        }
    }
    if (!found) {
        vec3 Le = environment_contribution_n(st.d, depth, st.prev_p, st.prev_n, st.prev_pdf,
                                             st.prev_delta, 1.0, float(kLightSamples));
        st.L += st.beta * Le;
        // seen through a delta surface, the environment is what a camera ray that misses
        // records: no albedo, no normal, its radiance as emission
        if (kAovs && st.aov_open) {
            st.aov.albedo = vec3(0.0);
            st.aov.normal = vec3(0.0);
            st.aov.emission += st.beta * Le;
        }
        return false;
    }
    vec3 p = hit.p;
    bool seen = st.aov_open;     // the camera sees this surface, directly or through delta ones
    if (kAovs && st.aov_open) st.aov_open = record_aov_through(st.aov, hit, depth, st.aov_weight);

    // Emission of an area light found by the camera ray or by BSDF sampling
    if (hit.light != 0u) {
        SurfaceHit at = hit;
        // weighed from the last vertex, across any null surfaces since (kMedia)
        if (kMedia) at.t = distance(st.prev_p, hit.p);
        vec3 Le = emitter_hit_contribution_n(at, st.d, depth, st.prev_p, st.prev_n, st.prev_pdf,
                                             st.prev_delta, 1.0, float(kLightSamples));
        st.L += st.beta * Le;
        if (kAovs && seen) st.aov.emission += st.beta * Le;
    }

    // A null surface only bounds media: the path goes on through it, neither a vertex nor
    // a bounce (the depth and the last vertex stay)
    if (kMedia && material_is_null(hit.material)) {
        st.medium = medium_after(hit.material, hit.ng, st.d, st.medium);
        st.o = offset_ray_origin(hit.p, hit.ng, st.d);
        st.t_max = kInfinity;
        st.depth = depth;
        return true;
    }

    // Possibly stop: the next segment would exceed the maximum depth
    if (depth + 1 >= max_segments) {
        if (kMaxDepth < 0) g_truncated_paths += 1u;   // the cap, not the scene's depth
        return false;
    }

    Bsdf b = bsdf_from_material(hit.material, hit.uv);
    // only the emission seen directly or through delta surfaces
    if (kEmissionOnly && !bsdf_is_delta(b)) return false;
    Frame frame = shading_frame(hit);
    bsdf_normal_frame(b, hit.ns0, frame);
    vec3 wo = frame_to_local(frame, -st.d);

    // Next-event estimation (its numbers are drawn even when unused, so that later
    // dimensions keep their meaning and their stratification)
    vec2 u_choice = sampler_2d(s);   // x: light selection, y: BSDF lobe
    vec2 u_light = sampler_2d(s);
    vec2 u_bsdf = sampler_2d(s);
    float u_rr = sampler_1d(s);
    bool delta = bsdf_is_delta(b);
    bool use_light = kStrategy != kStrategyBsdf && !delta;
    if (kWavefront) {   // one light sample, traced by the shadow stage
        if (use_light) {
            st.shadow = next_event_ray(p, hit, b, frame, wo, u_choice.x, u_light,
                                       kStrategy != kStrategyLight, 1.0, 1.0);
            st.shadow.value = st.beta * st.shadow.value;
        }
    } else if (kLightSamples == 1) {
        g_medium = st.medium;
        if (use_light)
            st.L += st.beta * next_event(p, hit, b, frame, wo, st.time, u_choice.x, u_light,
                                         kStrategy != kStrategyLight);
    } else {
        float n = float(kLightSamples);
        vec3 Ld = use_light ? next_event_n(p, hit, b, frame, wo, st.time, u_choice.x, u_light,
                                           kStrategy != kStrategyLight, n, 1.0) : vec3(0.0);
        for (int k = 1; k < kLightSamples; ++k) {
            vec2 u_select = sampler_2d(s);
            vec2 u_more = sampler_2d(s);
            if (use_light)
                Ld += next_event_n(p, hit, b, frame, wo, st.time, u_select.x, u_more,
                                   kStrategy != kStrategyLight, n, 1.0);
        }
        st.L += st.beta * Ld / n;
    }

    // Split into kSplit branches at the first vertex: this sample starts the first
    if (kSplit > 1 && depth == 0 && !delta) {
        st.beta /= float(kSplit);
        st.split_left = kSplit - 1;
        st.split_hit = hit;
        st.split_d = st.d;
        st.split_beta = st.beta;
        st.split_eta = st.eta_product;
    }
    // Sample the BSDF to continue the path
    return path_continue(st, hit, b, frame, wo, depth, u_choice.y, u_bsdf, u_rr);
}

// Starts the next BSDF branch at the split vertex (fresh numbers for it); false when that
// branch ends at once (path_step then tries the next one).
bool path_branch(inout PathState st, inout SamplerState s) {
    st.split_left -= 1;
    vec2 u_lobe = sampler_2d(s);
    vec2 u_bsdf = sampler_2d(s);
    float u_rr = sampler_1d(s);
    SurfaceHit hit = st.split_hit;
    st.beta = st.split_beta;
    st.eta_product = st.split_eta;
    st.depth = 1;
    Bsdf b = bsdf_from_material(hit.material, hit.uv);
    Frame frame = shading_frame(hit);
    vec3 wo = frame_to_local(frame, -st.split_d);
    return path_continue(st, hit, b, frame, wo, 0, u_lobe.x, u_bsdf, u_rr);
}

// One segment of the sample; when its current branch ends, the next branch starts.
// False when the whole sample (every branch) has ended.
bool path_step(inout PathState st, inout SamplerState s) {
    if (path_segment(st, s)) return true;
    while (kSplit > 1 && st.split_left > 0) {
        LOOP_TICK();
        if (path_branch(st, s)) return true;
    }
    return false;
}

// The radiance of one camera ray, segment by segment.
vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    PathState st = path_start(o, d, t_max, time);
    while (path_step(st, s)) {
        LOOP_TICK();
    }
    aov = st.aov;
    return st.L;
}

// Samples [first, first + count) of a pixel with path regeneration.
void integrator_pixel(uvec2 pixel, uint pixel_hash, uint first, uint count, inout Accumulator acc) {
    if (count == 0u) return;
    uint k = 0u;
    SamplerState s = pixel_sampler(pixel_hash, first);
    CameraSample c = camera_sample(pixel, s);
    PathState st = path_start(c.o, c.d, c.t_max, c.time);
    while (true) {
        LOOP_TICK();
        if (!path_step(st, s)) {
            accumulate(acc, c.weight * st.L, aov_scaled(st.aov, c.weight), first + k);
            k += 1u;
            if (k >= count) break;
            s = pixel_sampler(pixel_hash, first + k);
            c = camera_sample(pixel, s);
            st = path_start(c.o, c.d, c.t_max, c.time);
        }
    }
}
