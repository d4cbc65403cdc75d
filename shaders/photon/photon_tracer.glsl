// Photon tracing: paths that carry power from the lights through the scene
// (Jensen 2001, ch. 5; pbrt-v3's SPPMIntegrator photon pass).
//
// A photon starts like a light path (integrators/light_path.glsl: a light picked by
// select_light, a point and direction from sample_light_emission), so its power is
// beta = Le |cos| / (p_select p_pos p_dir): the mean of beta over photons is the
// scene's emitted power. It scatters by sampling the adjoint BSDF (with Veach's
// shading-normal correction) and Russian roulette survives with the probability
// q = min(max(weight), 1) of the scattering weight, dividing by q: a photon's power
// stays about the same while absorption thins the photons out (pbrt-v3 uses the
// luminance ratio the same way).
//
// Participating media (kMedia, media/medium.glsl): a photon knows the medium it travels in
// (light_start_medium at its light, then the one across each surface that bounds media),
// samples a free flight in it before each surface with its own hero channel and weighs the
// events by spectral MIS over the channels as the path tracer does (medium_event_weight),
// passes null surfaces without counting them, and at a scattering event goes on by sampling
// the phase function (weight 1) after Russian roulette by the event's weight (the albedo in
// a grey homogeneous medium).
#include "integrators/light_path.glsl"

struct Photon {
    vec3 o;          // ray origin of the next segment
    vec3 d;          // its unit direction
    vec3 beta;       // power carried (W for a photon of a pass of one photon)
    float time;      // normalized shutter time
    uint light;      // the light it left
    bool alive;
    int medium;      // kMedia: the medium the next segment runs in (kNoMedium: none)
    int hero;        // kMedia: the channel whose coefficients sample free flights
    vec3 chan;       // kMedia: the product of the medium events' densities per channel
};

// Starts a photon on a light; consumes light_path_start's sampler dimensions.
Photon photon_start(inout SamplerState s) {
    LightPathStart st = light_path_start(s);
    Photon ph = Photon(st.o, st.e.d, st.beta, st.time, st.light, st.valid, kNoMedium, 0, vec3(1.0));
    if (!st.valid) ph.beta = vec3(0.0);
    if (kMedia) {
        ph.hero = min(int(sampler_1d(s) * 3.0), 2);
        if (st.valid) ph.medium = light_start_medium(ph.o, ph.d, ph.time);
    }
    return ph;
}

// Continues photon ph from surface hit `hit` (BSDF b) with u_lobe in [0,1), u_dir in
// [0,1)^2 for the adjoint BSDF sample and u_rr in [0,1) for Russian roulette; sets
// ph.alive = false when it is absorbed or arrived on the wrong side of a surface.
void photon_scatter(inout Photon ph, SurfaceHit hit, Bsdf b, float u_lobe, vec2 u_dir, float u_rr) {
    Frame frame = frame_from_z(hit.ns);
    bsdf_normal_frame(b, hit.ns0, frame);
    vec3 wo = frame_to_local(frame, -ph.d);
    ph.alive = false;
    if (!light_side_valid(-ph.d, hit.ng, frame.z)) return;   // the arrival: the light side
    BsdfSample bs = bsdf_sample(b, wo, u_lobe, u_dir, true);
    if (!bs.valid) return;
    vec3 wi = frame_from_local(frame, bs.wi);
    vec3 weight = bs.weight * shading_normal_correction(-ph.d, wi, hit.ns, hit.ng);
    // Russian roulette by the scattering weight (the surface's albedo along wo)
    float q = min(max_component(weight), 1.0);
    if (!(u_rr < q)) return;
    ph.beta *= weight / q;
    if (!(max_component(ph.beta) > 0.0) || !is_finite(ph.beta)) return;
    ph.o = offset_ray_origin(hit.p, hit.ng, wi);
    ph.d = wi;
    ph.alive = true;
    if (kMedia) ph.medium = medium_after(hit.material, hit.ng, wi, ph.medium);
}

// The next surface a photon reaches, its BSDF and the numbers scattering there takes
// (the same sampler dimensions in every photon kernel).
struct PhotonHit {
    SurfaceHit hit;
    Bsdf b;
    vec2 u_choice;   // .y picks the BSDF lobe
    vec2 u_bsdf;
    float u_rr;
    vec2 u_lens;     // the photon-map view's camera connection
    vec3 beta_in;    // kMedia, a scattering event: the photon's power before the event's weight
};

// The numbers a photon's vertex takes (the same sampler dimensions in every photon kernel).
void photon_vertex_numbers(inout SamplerState s, inout PhotonHit h) {
    h.u_choice = sampler_2d(s);
    h.u_bsdf = sampler_2d(s);
    h.u_rr = sampler_1d(s);
    h.u_lens = sampler_2d(s);
}

// Follows photon ph to its next surface: false when it leaves the scene.
bool photon_next_hit(Photon ph, inout SamplerState s, out PhotonHit h) {
    g_light_path_rays = true;     // a normal map's flip is for camera paths
    if (!scene_intersect(ph.o, ph.d, kInfinity, ph.time, h.hit)) return false;
    photon_vertex_numbers(s, h);
    h.b = bsdf_from_material(h.hit.material, h.hit.uv);
    return true;
}

const int kPhotonEscaped = 0;   // it left the scene (or was absorbed in a medium)
const int kPhotonSurface = 1;   // it reached a surface (not a null one)
const int kPhotonMedium = 2;    // it scatters in its medium (kMedia)

// Follows photon ph to its next vertex (photon_next_hit without media): a surface, or
// (kMedia) a scattering event in the medium it travels in, at h.hit.p (h.hit.ng 0), the
// free flight's weight applied to ph.beta. Null surfaces are passed (up to
// kMaxNullCrossings in a row), into the medium across them; each part of the way between
// them samples its own free flight with two numbers, as the path tracer's segments do.
int photon_next_event(inout Photon ph, inout SamplerState s, out PhotonHit h) {
    if (!kMedia) return photon_next_hit(ph, s, h) ? kPhotonSurface : kPhotonEscaped;
    g_light_path_rays = true;
    for (int k = 0; k <= kMaxNullCrossings; ++k) {
        LOOP_TICK();
        vec2 u_medium = sampler_2d(s);
        g_medium_rng = pcg_hash(floatBitsToUint(u_medium.y) ^ uint(k));
        RAY_TICK();
        bool found = scene_intersect(ph.o, ph.d, kInfinity, ph.time, h.hit);
        if (ph.medium != kNoMedium) {
            MediumEvent ev = medium_sample(ph.medium, ph.o, ph.d, found ? h.hit.t : kInfinity,
                                           u_medium.x, ph.hero);
            h.beta_in = ph.beta;
            medium_event_weight(ph.beta, ph.chan, ev.f, ev.p);
            if (!(max_component(ph.beta) > 0.0) || !is_finite(ph.beta)) return kPhotonEscaped;
            if (ev.scatter) {
                h.hit.p = ph.o + ev.t * ph.d;
                h.hit.ng = vec3(0.0);
                h.hit.t = ev.t;
                photon_vertex_numbers(s, h);
                return kPhotonMedium;
            }
        }
        if (!found) return kPhotonEscaped;
        if (!material_is_null(h.hit.material)) {
            photon_vertex_numbers(s, h);
            h.b = bsdf_from_material(h.hit.material, h.hit.uv);
            return kPhotonSurface;
        }
        ph.medium = medium_after(h.hit.material, h.hit.ng, ph.d, ph.medium);
        ph.o = offset_ray_origin(h.hit.p, h.hit.ng, ph.d);
    }
    return kPhotonEscaped;
}

// Continues photon ph from its scattering event h in its medium (kMedia): Russian roulette
// survives with the event's weight q (the power after it over the power before, at most 1:
// the albedo in a grey homogeneous medium), dividing by q, and the phase function gives
// the new direction (u_dir; its weight is 1).
void photon_scatter_medium(inout Photon ph, PhotonHit h, vec2 u_dir, float u_rr) {
    float before = max_component(h.beta_in);
    float q = before > 0.0 ? min(max_component(ph.beta) / before, 1.0) : 0.0;
    ph.alive = false;
    if (!(u_rr < q)) return;
    ph.beta /= q;
    if (!(max_component(ph.beta) > 0.0) || !is_finite(ph.beta)) return;
    ph.o = h.hit.p;
    ph.d = medium_sample_phase(ph.medium, ph.d, u_dir);
    ph.alive = true;
}
