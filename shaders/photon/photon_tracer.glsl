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
#include "integrators/light_path.glsl"

struct Photon {
    vec3 o;          // ray origin of the next segment
    vec3 d;          // its unit direction
    vec3 beta;       // power carried (W for a photon of a pass of one photon)
    float time;      // normalized shutter time
    uint light;      // the light it left
    bool alive;
};

// Starts a photon on a light; consumes light_path_start's sampler dimensions.
Photon photon_start(inout SamplerState s) {
    LightPathStart st = light_path_start(s);
    Photon ph = Photon(st.o, st.e.d, st.beta, st.time, st.light, st.valid);
    if (!st.valid) ph.beta = vec3(0.0);
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
};

// Follows photon ph to its next surface: false when it leaves the scene.
bool photon_next_hit(Photon ph, inout SamplerState s, out PhotonHit h) {
    g_light_path_rays = true;     // a normal map's flip is for camera paths
    if (!scene_intersect(ph.o, ph.d, kInfinity, ph.time, h.hit)) return false;
    h.u_choice = sampler_2d(s);
    h.u_bsdf = sampler_2d(s);
    h.u_rr = sampler_1d(s);
    h.u_lens = sampler_2d(s);
    h.b = bsdf_from_material(h.hit.material, h.hit.uv);
    return true;
}
