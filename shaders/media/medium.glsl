// Participating media (homogeneous): free-flight sampling, transmittance and the phase
// function, on the records of scene/layout.glsl's media block (glrender/gpu/pack.py).
//
// Chromatic media (sigma_t differs per channel) are sampled by one-sample MIS over the
// three channels (the balance heuristic, as in Miller, Georgiev and Jarosz 2019's
// spectral tracking with hero channels): a channel c is drawn uniformly and the distance
// from its exponential, and every estimate divides by the density averaged over the
// channels, pdf(t) = (1/3) sum_c sigma_t,c exp(-sigma_t,c t), or for passing the surface at
// t_max, P = (1/3) sum_c exp(-sigma_t,c t_max). That stays unbiased (the average density is
// positive wherever any channel's is) and keeps the weights of every channel bounded.
//
// Media are entered and left through the surfaces that bound them: a shape's material
// record carries its interior and exterior medium (kMaterialInteriorShift), and a ray
// leaving a surface on the side its geometric normal faces is in the exterior medium,
// otherwise in the interior one, as Mitsuba's SurfaceInteraction::target_medium. Surfaces
// of the null material only bound media: paths and shadow rays pass through them.
#include "integrators/integrator_common.glsl"
#include "bsdf/material.glsl"
#include "sampling/phase.glsl"
#include "@scene"

const uint kMediumHomogeneous = 0u;   // glrender/gpu/layout.py MEDIUM_KINDS
const uint kMediumHeterogeneous = 1u;
const uint kPhaseIsotropic = 0u;      // PHASE_KINDS
const uint kPhaseHg = 1u;
const int kNoMedium = -1;
// Null surfaces a shadow ray passes through at most; one more blocks it.
const int kMaxNullCrossings = 32;

// The medium the camera's rays start in (kNoMedium: none).
int camera_medium() {
    return int(u_media.media_counts.y) - 1;
}

// The medium on the far side of surface `material` for a ray leaving it along w (ng its
// geometric normal), when the surface bounds media; `current` when it bounds none.
int medium_after(uint material, vec3 ng, vec3 w, int current) {
    uint bits = scene_material(material).info.y;
    uint inside = (bits >> kMaterialInteriorShift) & 0xffu;
    uint outside = (bits >> kMaterialExteriorShift) & 0xffu;
    if (inside == 0u && outside == 0u) return current;
    return int(dot(w, ng) > 0.0 ? outside : inside) - 1;
}

bool material_is_null(uint material) {
    return scene_material(material).info.x == kMaterialNull;
}

// exp(-sigma_t t) per channel, 1 where sigma_t is 0 (t may be infinite).
vec3 medium_transmittance(int m, float t) {
    vec3 st = u_media.media[m].sigma_t.xyz;
    return vec3(st.x > 0.0 ? exp(-st.x * t) : 1.0, st.y > 0.0 ? exp(-st.y * t) : 1.0,
                st.z > 0.0 ? exp(-st.z * t) : 1.0);
}

// A free-flight sample along a ray in medium m whose surface lies at t_max (kInfinity:
// none): a scattering event at distance t < t_max, or none. weight: what the throughput
// is multiplied by, sigma_s T(t) / pdf(t) at a scattering event, T(t_max) / P otherwise.
struct MediumEvent {
    bool scatter;
    float t;
    vec3 weight;
};

MediumEvent medium_sample(int m, float t_max, vec2 u) {
    vec3 st = u_media.media[m].sigma_t.xyz;
    int c = min(int(u.x * 3.0), 2);
    float sc = st[c];
    float t = sc > 0.0 ? -log(1.0 - u.y) / sc : kInfinity;
    if (t < t_max) {
        vec3 T = medium_transmittance(m, t);
        float pdf = dot(st * T, vec3(1.0 / 3.0));
        return MediumEvent(true, t, pdf > 0.0 ? u_media.media[m].sigma_s.xyz * T / pdf : vec3(0.0));
    }
    vec3 T = medium_transmittance(m, t_max);
    float p = dot(T, vec3(1.0 / 3.0));
    return MediumEvent(false, t_max, p > 0.0 ? T / p : vec3(0.0));
}

// The phase function of medium m for light arriving along d and leaving along wi (both
// unit, d the direction of travel): its value, which is also the density of sampling wi.
float medium_phase(int m, vec3 d, vec3 wi) {
    MediumData md = u_media.media[m];
    return md.info.y == kPhaseHg ? hg_phase(dot(d, wi), md.sigma_t.w) : isotropic_phase();
}

vec3 medium_sample_phase(int m, vec3 d, vec2 u) {
    MediumData md = u_media.media[m];
    return sample_hg_world(u, md.info.y == kPhaseHg ? md.sigma_t.w : 0.0, d);
}

bool medium_samples_emitters(int m) {
    return (u_media.media[m].info.z & kMediumFlagSampleEmitters) != 0u;
}

// The transmittance of a shadow ray from o along d over t_max that starts in medium m:
// the media's along its segments, through null surfaces (into the medium on their far
// side), 0 at any other surface (`ignore`: the primitive it aims at, not a blocker).
vec3 scene_transmittance(vec3 o, vec3 d, float t_max, float time, uint ignore, int m) {
    vec3 tr = vec3(1.0);
    for (int k = 0; k <= kMaxNullCrossings; ++k) {
        LOOP_TICK();
        SurfaceHit h;
        RAY_TICK();
        bool found = scene_intersect(o, d, t_max, time, h) && h.prim != ignore;
        if (m != kNoMedium) tr *= medium_transmittance(m, found ? h.t : t_max);
        if (!found) return tr;
        if (!material_is_null(h.material) || k == kMaxNullCrossings || max_component(tr) <= 0.0)
            return vec3(0.0);
        m = medium_after(h.material, h.ng, d, m);
        o = offset_ray_origin(h.p, h.ng, d);
        t_max -= h.t;
    }
    return vec3(0.0);
}
