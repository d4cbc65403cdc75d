// Camera paths of the photon integrators (SPPM's camera pass, the photon integrator's
// camera and gather rays) through delta surfaces to their first non-delta surface, or
// (kMedia) to a scattering event in a medium before it; null surfaces they pass, into the
// medium across them, without counting them toward the depth.
#include "integrators/integrator_common.glsl"
#include "media/medium.glsl"

// The segments and null-surface crossings a camera path of the photon integrators takes at
// most (a bound on its loop: null surfaces do not count toward the depth).
const int kCameraPathSteps = kUnboundedDepthCap + kMaxNullCrossings;

// A camera path in media (kMedia; path.glsl's PathState.medium, hero and chan): the medium it
// runs in, the channel whose coefficients sample its free flights and the product of its
// medium events' densities per channel.
struct CameraMedia {
    int medium;
    int hero;
    vec3 chan;
};

CameraMedia camera_media_start() {
    return CameraMedia(kMedia ? camera_medium() : kNoMedium, 0, vec3(1.0));
}

// The free flight of a camera path's segment o + t d whose surface lies at t_hit (kMedia),
// as the path tracer samples it: two numbers of s (the hero channel drawn at the path's
// first segment, `first`), the event's weight into beta by spectral MIS. True when the path
// scatters in its medium, at o + t d; false when it goes on to the surface (beta 0: ends).
bool camera_free_flight(inout CameraMedia cm, inout SamplerState s, vec3 o, vec3 d, float t_hit,
                        bool first, inout vec3 beta, out float t) {
    t = t_hit;
    if (!kMedia) return false;
    vec2 u_medium = sampler_2d(s);
    g_medium_rng = pcg_hash(floatBitsToUint(u_medium.y));
    if (first) cm.hero = min(int(medium_random() * 3.0), 2);
    if (cm.medium == kNoMedium) return false;
    MediumEvent ev = medium_sample(cm.medium, o, d, t_hit, u_medium.x, cm.hero);
    medium_event_weight(beta, cm.chan, ev.f, ev.p);
    t = ev.t;
    if (!is_finite(beta)) beta = vec3(0.0);
    return ev.scatter && max_component(beta) > 0.0;
}

// Continues a path at surface `hit` (BSDF b, shading frame `frame`, wo_l the direction
// back along the path in it) by sampling the BSDF with u_lobe, u_dir: beta, o and d
// become the next segment's; false where the path ends.
bool continue_camera_path(SurfaceHit hit, Bsdf b, Frame frame, vec3 wo_l, float u_lobe, vec2 u_dir,
                          inout vec3 beta, inout vec3 o, inout vec3 d) {
    BsdfSample bs = bsdf_sample(b, wo_l, u_lobe, u_dir, false);
    if (!bs.valid) return false;
    vec3 wi = frame_from_local(frame, bs.wi);
    if (dot(wi, hit.ng) * bs.wi.z <= 0.0) return false;
    beta *= bs.weight;
    if (!(max_component(beta) > 0.0)) return false;
    o = offset_ray_origin(hit.p, hit.ng, wi);
    d = wi;
    return true;
}
