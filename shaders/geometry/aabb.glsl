// Ray against the four child boxes of a BVH node (slab test, Kay & Kajiya 1986).
#include "common/constants.glsl"

// Per-ray constants of the slab test.
struct SlabRay {
    vec3 o;        // origin
    vec3 inv_d;    // 1 / direction; zero components replaced by a tiny signed value
    bvec3 neg;     // direction component negative: the near plane is the max plane
};

// Prepares the slab test for a ray o + t d (d need not be normalized).
// A zero direction component becomes +-1e-30 (sign kept, -0 as +), so 1/d stays
// finite: a plane the ray lies in yields t = 0 instead of 0 * inf = NaN.
SlabRay make_slab_ray(vec3 o, vec3 d) {
    const float kTiny = 1e-30;
    vec3 safe_d = mix(d, mix(vec3(kTiny), vec3(-kTiny), lessThan(d, vec3(0.0))),
                      lessThan(abs(d), vec3(kTiny)));
    vec3 inv_d = 1.0 / safe_d;
    return SlabRay(o, inv_d, lessThan(inv_d, vec3(0.0)));
}

// The entry distances into four boxes from the distances to their near and far planes
// per axis (components = boxes): per box, the entry t in [0, t_max] where the ray
// overlaps the box, else +inf. The far distance is grown by kRobustFar so that
// rounding never rejects a box the ray touches: rays aimed exactly at a vertex or edge
// reach the triangle test (watertightness).
vec4 slab_combine4(vec4 nx, vec4 fx, vec4 ny, vec4 fy, vec4 nz, vec4 fz, float t_max) {
    vec4 tn = max(max(nx, ny), max(nz, vec4(0.0)));
    vec4 tf = min(min(min(fx, fy), fz) * kRobustFar, vec4(t_max));
    return mix(vec4(kInfinity), tn, lessThanEqual(tn, tf));
}

// Entry distances of the ray into four boxes, given the near- and far-plane
// coordinates of the boxes per axis (components = children), as slab_combine4.
vec4 slab_entry4(SlabRay r, vec4 near_x, vec4 far_x, vec4 near_y, vec4 far_y,
                 vec4 near_z, vec4 far_z, float t_max) {
    return slab_combine4((near_x - r.o.x) * r.inv_d.x, (far_x - r.o.x) * r.inv_d.x,
                         (near_y - r.o.y) * r.inv_d.y, (far_y - r.o.y) * r.inv_d.y,
                         (near_z - r.o.z) * r.inv_d.z, (far_z - r.o.z) * r.inv_d.z, t_max);
}
