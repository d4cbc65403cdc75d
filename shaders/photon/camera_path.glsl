// Camera paths of the photon integrators (SPPM's camera pass, the photon integrator's
// camera and gather rays) through delta surfaces to their first non-delta surface.
#include "integrators/integrator_common.glsl"

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
