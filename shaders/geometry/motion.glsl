// Ray queries at a time in the shutter interval: the static BVH plus the rigid
// motion instances (glrender/accel/instances.py explains the model).
//
// u_bvh_instances: texel 0 = (instance count, static triangle count, 0, 0) as
// uint bits; then 12 texels per instance k at 1 + 12 k:
//   0: world box min (xyz), root node (w, uint bits)
//   1: world box max (xyz), first triangle (w, uint bits)
//   2: translation at open (xyz), end of its triangles (w, uint bits)
//   3: rotation quaternion at open (x, y, z, w)
//   4-6: rows of the symmetric scale/shear S at open
//   7: translation at close; 8: quaternion at close; 9-11: S at close
// The quaternions lie on one hemisphere (the host flips the second if needed).
#include "geometry/bvh.glsl"

// Number of motion instances (the list is short: each is tested by every ray).
int motion_instance_count() {
    return int(floatBitsToUint(texelFetch(u_bvh_instances, 0).x));
}

// Spherical interpolation of unit quaternions at t in [0, 1]; normalised lerp
// below 1.8 degrees apart, as on the host (glrender/accel/instances.py, slerp).
vec4 motion_slerp(vec4 q0, vec4 q1, float t) {
    float c = clamp(dot(q0, q1), -1.0, 1.0);
    vec4 q;
    if (c > 0.9995) {
        q = mix(q0, q1, t);
    } else {
        float phi = acos(c);
        q = (sin((1.0 - t) * phi) * q0 + sin(t * phi) * q1) / sin(phi);
    }
    return normalize(q);
}

// Rotation matrix of a unit quaternion (x, y, z, w); columns are GLSL's major order.
mat3 motion_rotation(vec4 q) {
    float x = q.x, y = q.y, z = q.z, w = q.w;
    return mat3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + z * w), 2.0 * (x * z - y * w),
                2.0 * (x * y - z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + x * w),
                2.0 * (x * z + y * w), 2.0 * (y * z - x * w), 1.0 - 2.0 * (x * x + y * y));
}

// Translation, rotation and scale/shear of instance k at time in [0, 1]:
// world = translation + rotation * scale * object.
void motion_transform(int k, float time, out vec3 translation, out mat3 rotation, out mat3 scale) {
    int base = 1 + k * kTexelsPerMotionInstance;
    float t = clamp(time, 0.0, 1.0);
    translation = mix(texelFetch(u_bvh_instances, base + 2).xyz,
                      texelFetch(u_bvh_instances, base + 7).xyz, t);
    rotation = motion_rotation(motion_slerp(texelFetch(u_bvh_instances, base + 3),
                                            texelFetch(u_bvh_instances, base + 8), t));
    // S is symmetric: its rows are its columns.
    scale = mat3(mix(texelFetch(u_bvh_instances, base + 4).xyz, texelFetch(u_bvh_instances, base + 9).xyz, t),
                 mix(texelFetch(u_bvh_instances, base + 5).xyz, texelFetch(u_bvh_instances, base + 10).xyz, t),
                 mix(texelFetch(u_bvh_instances, base + 6).xyz, texelFetch(u_bvh_instances, base + 11).xyz, t));
}

// The part of the static BVH and of every motion instance that the ray o + t d,
// t in (0, t_max), meets at the given time (in [0, 1]). Distances are in units of
// d in world space; an instance's triangles are tested in its object space,
// which an affine map leaves the ray parameter t unchanged in.
bool bvh_traverse_t(vec3 o, vec3 d, float t_max, float time, const bool any_hit, out BvhHit hit) {
    bool found = bvh_traverse(0u, o, d, t_max, any_hit, hit);
    if (hit.prim == kBvhStackOverflow || (any_hit && found)) {
        return found;
    }
    SlabRay slab = make_slab_ray(o, d);
    int count = motion_instance_count();
    for (int k = 0; k < count; k++) {
        LOOP_TICK();
        int base = 1 + k * kTexelsPerMotionInstance;
        vec4 lo = texelFetch(u_bvh_instances, base);
        vec4 hi = texelFetch(u_bvh_instances, base + 1);
        vec3 near = mix(lo.xyz, hi.xyz, slab.neg);
        vec3 far = mix(hi.xyz, lo.xyz, slab.neg);
        float entry = slab_entry4(slab, vec4(near.x), vec4(far.x), vec4(near.y), vec4(far.y),
                                  vec4(near.z), vec4(far.z), hit.t).x;
        if (!(entry < kInfinity)) {
            continue;
        }
        vec3 translation;
        mat3 rotation, scale;
        motion_transform(k, time, translation, rotation, scale);
        mat3 object_from_world = inverse(scale) * transpose(rotation);
        if (bvh_traverse_closer(floatBitsToUint(lo.w), object_from_world * (o - translation),
                                object_from_world * d, any_hit, hit)) {
            found = true;
            if (any_hit) {
                return true;
            }
        } else if (hit.prim == kBvhStackOverflow) {
            return false;
        }
    }
    return found;
}

// Nearest hit at the given time (see bvh_traverse_t).
bool bvh_intersect_closest_t(vec3 o, vec3 d, float t_max, float time, out BvhHit hit) {
    return bvh_traverse_t(o, d, t_max, time, false, hit);
}

// Whether anything blocks o + t d, t in (0, t_max), at the given time.
bool bvh_intersect_any_t(vec3 o, vec3 d, float t_max, float time) {
    BvhHit hit;
    return bvh_traverse_t(o, d, t_max, time, true, hit);
}

// The motion instance whose triangles include prim (BVH-order id), or -1 for a static one.
int motion_instance_of(uint prim) {
    int count = motion_instance_count();
    for (int i = 0; i < count; i++) {
        LOOP_TICK();
        int base = 1 + i * kTexelsPerMotionInstance;
        uint begin = floatBitsToUint(texelFetch(u_bvh_instances, base + 1).w);
        uint end = floatBitsToUint(texelFetch(u_bvh_instances, base + 2).w);
        if (prim >= begin && prim < end) return i;
    }
    return -1;
}

// Corner k of triangle prim in world space at the given time (static triangles
// do not move; a motion instance's are moved by its transform at that time).
vec3 bvh_triangle_vertex_t(uint prim, uint k, float time) {
    vec3 p = bvh_triangle_vertex(prim, k);
    int i = motion_instance_of(prim);
    if (i < 0) return p;
    vec3 translation;
    mat3 rotation, scale;
    motion_transform(i, time, translation, rotation, scale);
    return translation + rotation * (scale * p);
}
