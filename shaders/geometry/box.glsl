// A conservative ray / box overlap test that lets whole SIMD vectors skip a BVH.
//
// The generated scene code asks it before traversing the BVH with the world box of
// the mesh triangles: when no lane's ray reaches the box before its current closest
// hit, the traversal (its setup, the root fetch, the loop) is skipped. Conservative:
// the far distance is grown as in the BVH's own test (Ize 2013) and NaN (a ray lying
// in a box plane, 0 * inf) counts as meeting the box.
#include "common/constants.glsl"

bool ray_meets_box(vec3 o, vec3 inv_d, vec3 lo, vec3 hi, float t_max) {
    vec3 t0 = (lo - o) * inv_d;
    vec3 t1 = (hi - o) * inv_d;
    vec3 near = min(t0, t1), far = max(t0, t1);
    float t_near = max(max(near.x, near.y), max(near.z, 0.0));
    float t_far = min(min(far.x, far.y), min(far.z, t_max)) * kRobustFar;
    bool undecided = any(isnan(t0)) || any(isnan(t1));
    return undecided || t_near <= t_far;
}
