// Ambient occlusion: the cosine-weighted fraction of the hemisphere left open within a distance.
//
// AO(p) = (1/pi) ∫ V(p, w, r) cos theta dw, estimated with one cosine-sampled
// direction per camera sample (a zero-variance choice for an unoccluded point).
// Rays that miss the scene return 0. r = u_params.ao_distance (infinite by default).
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "sampling/hemisphere.glsl"
#include "integrators/pixel_loop.glsl"

vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov) {
    SurfaceHit hit;
    if (!scene_intersect(o, d, t_max, time, hit)) return vec3(0.0);
    record_aov(aov, hit);
    vec3 n = dot(hit.ns, d) < 0.0 ? hit.ns : -hit.ns;   // the side the camera sees
    Frame frame = frame_from_z(n);
    vec3 wi = frame_from_local(frame, sample_cosine_hemisphere(sampler_2d(s)));
    if (dot(wi, hit.ng) * dot(n, hit.ng) <= 0.0) return vec3(0.0);
    vec3 p = hit.p;
    vec3 o2 = offset_ray_origin(p, hit.ng, wi);
    return scene_occluded(o2, wi, u_params.ao_distance, time, kNoPrimitive) ? vec3(0.0) : vec3(1.0);
}
