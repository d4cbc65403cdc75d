// Ray queries against static instances: a top-level tree over the instances' world boxes,
// and per instance its prototype's own tree in object space (glrender/accel/instances.py
// explains the model; the records' layout is in geometry/bvh_layout.glsl).
//
// Record of static instance k at 1 + kTexelsPerMotionInstance * (motion instances) +
// kTexelsPerStaticInstance * k, k in the top-level tree's leaf order:
//   0-2: rows of object_from_world (xyz: the 3x3 part, w: the translation)
//   3-5: rows of world_from_object
//   6: the prototype tree's root node (x, uint bits)
// An affine map leaves the ray parameter unchanged: a hit's t in object space is its t in
// world space, so the closest hit over instances is found with one running t.
#include "geometry/bvh.glsl"

const uint kNoInstance = 0xFFFFFFFFu;

int static_instance_record(uint k) {
    uint motion = floatBitsToUint(texelFetch(u_bvh_instances, 0).x);
    return 1 + int(motion) * kTexelsPerMotionInstance + int(k) * kTexelsPerStaticInstance;
}

// Static instances the ray o + t d may meet closer than hit.t: a closer hit replaces hit
// (prim: its prototype's triangle in BVH order) and inst (its instance); returns whether
// one did. any_hit stops at the first. A stack overflow in either level sets hit.prim to
// kBvhStackOverflow and returns false, as bvh_traverse.
bool instances_traverse(vec3 o, vec3 d, const bool any_hit, inout BvhHit hit, inout uint inst) {
    uvec4 header = floatBitsToUint(texelFetch(u_bvh_instances, 0));
    if (header.z == 0u || !(hit.t > 0.0) || all(equal(d, vec3(0.0)))) {
        return false;
    }
    SlabRay slab = make_slab_ray(o, d);
    const uint kNone = 0xFFFFFFFFu;
    uint stack[kBvhStackSize];
    float stack_t[kBvhStackSize];
    int sp = 0;
    uint node = header.w;
    bool found = false;
    while (true) {
        LOOP_TICK();
        if (node == kNone) {
            if (sp == 0) {
                break;
            }
            sp--;
            node = stack_t[sp] > hit.t ? kNone : stack[sp];
            continue;
        }
        if ((node & kBvhLeafFlag) == 0u) {
            BVH_VISIT_INNER_NODE();
            continue;
        }
        // a leaf: one instance (the builder's leaves hold one)
        uint k = node & kBvhLeafFirstMask;
        node = kNone;
        int base = static_instance_record(k);
        vec4 r0 = texelFetch(u_bvh_instances, base);
        vec4 r1 = texelFetch(u_bvh_instances, base + 1);
        vec4 r2 = texelFetch(u_bvh_instances, base + 2);
        vec3 oo = vec3(dot(r0.xyz, o) + r0.w, dot(r1.xyz, o) + r1.w, dot(r2.xyz, o) + r2.w);
        vec3 dd = vec3(dot(r0.xyz, d), dot(r1.xyz, d), dot(r2.xyz, d));
        uint root = floatBitsToUint(texelFetch(u_bvh_instances, base + 6).x);
        if (bvh_traverse_closer(root, oo, dd, any_hit, hit)) {
            inst = k;
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

// Moves a surface record of instance inst's prototype (mesh_surface) to world space:
// points and tangents by world_from_object, normals by its inverse transpose (the
// transpose of object_from_world); the geometric normal is turned to the shading
// normal's side, as mesh_surface does.
void instance_surface(uint inst, inout vec3 p, inout vec3 ng, inout vec3 ns, inout vec3 dpdu) {
    int base = static_instance_record(inst);
    vec4 r0 = texelFetch(u_bvh_instances, base);
    vec4 r1 = texelFetch(u_bvh_instances, base + 1);
    vec4 r2 = texelFetch(u_bvh_instances, base + 2);
    vec4 w0 = texelFetch(u_bvh_instances, base + 3);
    vec4 w1 = texelFetch(u_bvh_instances, base + 4);
    vec4 w2 = texelFetch(u_bvh_instances, base + 5);
    p = vec3(dot(w0.xyz, p) + w0.w, dot(w1.xyz, p) + w1.w, dot(w2.xyz, p) + w2.w);
    dpdu = vec3(dot(w0.xyz, dpdu), dot(w1.xyz, dpdu), dot(w2.xyz, dpdu));
    ng = normalize(ng.x * r0.xyz + ng.y * r1.xyz + ng.z * r2.xyz);
    ns = normalize(ns.x * r0.xyz + ns.y * r1.xyz + ns.z * r2.xyz);
    ng = dot(ng, ns) < 0.0 ? -ng : ng;
}
