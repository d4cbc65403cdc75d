// Starting light paths and carrying importance through surfaces: what light tracing
// and bidirectional path tracing share.
//
// A light path starts at a point chosen by sample_light_emission on a light picked by
// select_light; its throughput beta is Le |cos| / (p_select p_pos p_dir) and is carried
// with adjoint BSDFs (bsdf_sample(..., adjoint = true)). With shading normals the
// adjoint BSDF is not symmetric: every scattering and every connection of an
// importance-carrying path is multiplied by |wo.ns| |wi.ng| / (|wo.ng| |wi.ns|)
// (Veach 1997, eq. 5.19; wo toward the light side, wi the new direction).
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "camera/camera.glsl"
#include "camera/importance.glsl"

// Veach's shading-normal correction of the adjoint BSDF (world directions, unit).
float shading_normal_correction(vec3 wo, vec3 wi, vec3 ns, vec3 ng) {
    float denom = abs(dot(wo, ng) * dot(wi, ns));
    return denom > 0.0 ? abs(dot(wo, ns) * dot(wi, ng)) / denom : 0.0;
}

// The first vertex of a light path.
struct LightPathStart {
    LightEmission e;
    uint light;      // index of the light
    float pmf;       // its selection probability
    vec3 beta;       // Le |cos| / (pmf pdf_pos pdf_dir): the throughput leaving the light
    vec3 o;          // ray origin (offset off the light's surface)
    float time;      // normalized shutter time
    bool valid;
};

// Picks a light and a point and direction on it; consumes 1 + 2 + 2 (+ 1 with a
// shutter) sampler dimensions.
LightPathStart light_path_start(inout SamplerState s) {
    LightPathStart st;
    float u_select = sampler_1d(s);
    vec2 u_pos = sampler_2d(s);
    vec2 u_dir = sampler_2d(s);
    st.time = u_params.shutter.y > u_params.shutter.x ? sample_shutter_time(sampler_1d(s)) : 0.0;
    st.valid = false;
    if (u_params.counts.x == 0u) return st;
    LightChoice choice = select_light(u_select);
    LightData l = scene_light(choice.index);
    st.light = choice.index;
    st.pmf = choice.pmf;
    st.e = sample_light_emission(l, u_pos, u_dir, u_params.scene_sphere);
    float pdf = choice.pmf * st.e.pdf_pos * st.e.pdf_dir;
    if (!(pdf > 0.0) || max_component(st.e.Le) <= 0.0) return st;
    st.beta = st.e.Le * abs(dot(st.e.n, st.e.d)) / pdf;
    st.o = light_is_area(l) ? offset_ray_origin(st.e.p, st.e.n, st.e.d) : st.e.p;
    st.valid = true;
    return st;
}

// Radiance (area lights) or intensity (point, spot) that light `l` sends from its point
// of emission e toward the unit direction w, times |cos| at the light for area lights.
vec3 light_emitted_toward(LightData l, LightEmission e, vec3 w) {
    if (light_is_area(l)) return area_light_radiance(l, e.n, w, e.uv) * abs(dot(e.n, w));
    if (l.info.x == kLightSpot) return l.radiance.rgb * spot_falloff(l, dot(w, l.n.xyz));
    return l.radiance.rgb;
}

// Whether the segment from x (geometric normal ng, 0 for points off surfaces) to the
// lens point of c is unoccluded.
bool camera_visible(vec3 x, vec3 ng, CameraConnection c, float time, uint ignore) {
    vec3 o = dot(ng, ng) > 0.0 ? offset_ray_origin(x, ng, c.wi) : x;
    return !scene_occluded(o, c.wi, c.dist * (1.0 - kShadowEpsilon), time, ignore);
}

// The transmittance of that segment: 1 or 0 without media, with media (kMedia) theirs
// along it through null surfaces, starting in medium m.
vec3 camera_transmittance(vec3 x, vec3 ng, CameraConnection c, float time, uint ignore, int m) {
    vec3 o = dot(ng, ng) > 0.0 ? offset_ray_origin(x, ng, c.wi) : x;
    float unused;
    return ray_transmittance(o, c.wi, c.dist * (1.0 - kShadowEpsilon), time, ignore, m, unused);
}
