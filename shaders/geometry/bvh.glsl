// Closest-hit and any-hit ray queries against the 4-wide BVH of glrender/accel
// (layout: geometry/bvh_layout.glsl).
//
// Ordered traversal: the children a ray enters are sorted by entry distance, the
// nearest is visited next and the others are pushed farthest first, each with its
// entry distance so that entries beyond the closest hit found since are dropped
// when popped.
//
// llvmpipe runs 8 invocations per SIMD vector and executes a branch for the
// whole vector whenever one lane takes it, so each loop iteration does one node
// test AND one triangle test for every lane: a lane holds a leaf being tested
// (one triangle per iteration) and, at the same time, the next inner node. This
// measured 1.2x faster than one node-or-triangle step per iteration
// (benchmarks/RESULTS.md, "BVH").
//
// Stack bound: a node pushes at most 3 entries, so a tree whose inner nodes lie
// at depth <= kBvhMaxDepth needs at most kBvhStackSize = 3 (kBvhMaxDepth + 1)
// entries. The builder guarantees that depth (glrender/accel/bvh.py, MAX_DEPTH)
// and GpuBvh refuses deeper trees, so the stack cannot overflow. Should it ever
// be about to (a corrupted tree), the query stops and reports hit.prim =
// kBvhStackOverflow: it never writes out of bounds, loops, or misses silently.
#include "common/constants.glsl"
#include "common/loop_counter.glsl"
#include "common/params.glsl"
#include "geometry/aabb.glsl"
#include "geometry/bvh_layout.glsl"
#include "geometry/triangle.glsl"

const int kBvhStackSize = 3 * (kBvhMaxDepth + 1);
const uint kBvhNoHit = 0xFFFFFFFFu;

#if GLRENDER_ALPHA_CUTOUTS
// Whether the hit at barycentrics bary of triangle prim is solid (not cut out by its
// material's opacity texture): defined by the scene code (glrender/gpu/codegen.py).
bool bvh_alpha_pass(uint prim, vec2 bary);
#endif
const uint kBvhStackOverflow = 0xFFFFFFFEu;

// A ray hit: distance t along d (in units of |d|), triangle in BVH order, and
// barycentrics (b1, b2) of its corners v1 and v2.
struct BvhHit {
    float t;
    uint prim;
    vec2 bary;
};

// Corner k (0, 1, 2) of triangle prim (BVH order), in world space.
vec3 bvh_triangle_vertex(uint prim, uint k) {
    return bvh_triangle_texel(int(prim) * kBvhTexelsPerTriangle, int(k)).xyz;
}

// Whether the ray hits triangle prim (BVH order) in (0, t_max) where it is solid (not cut
// out by an opacity texture): its distance t and barycentrics, in units of the ray's d.
// The 8-wide traversal calls it; bvh_traverse's loop writes it out.
bool bvh_triangle_hit(WatertightRay r, uint prim, float t_max, out float t, out vec2 bary) {
    int base = int(prim) * kBvhTexelsPerTriangle;
    vec4 uvwt;
    t = t_max;
    bary = vec2(0.0);
    bool solid = false;
    if (watertight_candidate(r, bvh_triangle_texel(base, 0).xyz, bvh_triangle_texel(base, 1).xyz,
                             bvh_triangle_texel(base, 2).xyz, t_max, uvwt)) {
        solid = watertight_resolve(uvwt, t_max, t, bary);
#if GLRENDER_ALPHA_CUTOUTS
        solid = solid && bvh_alpha_pass(prim, bary);
#endif
    }
    return solid;
}

// The four 8-bit planes in word w (byte k = child k) as floats 0..255 (the
// bytes are below 2^31, so the signed conversion is exact: one instruction on
// AVX2, which has no unsigned one).
vec4 bvh_plane_bytes(uint w) {
    return vec4(ivec4(w & 255u, (w >> 8u) & 255u, (w >> 16u) & 255u, w >> 24u));
}

// Entry distances of the ray into the four children of a node (+inf: missed or
// beyond t_max), and the children's references.
//
// A plane p + q s (q = 0..255, s = 2^e) meets the ray at t = (p + q s - o) / d =
// q (s / d) + (p - o) / d: per node and axis a = s * inv_d (exact: s is a power of
// two) and b = (p - o) * inv_d (two roundings), then one fused multiply-add per
// plane. Unlike (plane - o) * inv_d, whose rounding is relative to the result (the
// far factor kRobustFar covers it), b's error is relative to b, and an unfused
// q * a would add one relative to q a <= 255 |a|: the near planes take b - pad and
// the far planes b + pad, pad = 5 ulp(1) (|b| + 255 |a|) > those errors and the
// subtraction's, so before the last rounding the near distance never exceeds the
// exact one and the far distance never falls short of it; kRobustFar covers the
// last rounding as before: no box the ray touches is rejected. The planes are
// exact reals p + q s that contain the child boxes (glrender/accel/quantize.py).
// Per node and axis, the affine map from a plane byte q to the ray distance of its plane:
// t = q a + bn (near planes) or q a + bf (far planes), from the node's head texel (see
// bvh_node_entry, which writes it out). The 8-wide traversal (geometry/bvh8.glsl) calls it.
struct NodeFrame {
    vec3 a;
    vec3 bn;
    vec3 bf;
};

NodeFrame bvh_node_frame(SlabRay r, uvec4 head) {
    const float kPlaneError = 5.0 * kMachineEpsilon;
    vec3 scale = uintBitsToFloat(((uvec3(head.w) >> uvec3(0u, 8u, 16u)) & 255u) << 23u);
    vec3 a = scale * r.inv_d;
    vec3 b = (uintBitsToFloat(head.xyz) - r.o) * r.inv_d;
    vec3 pad = (abs(b) + 255.0 * abs(a)) * kPlaneError;
    return NodeFrame(a, b - pad, b + pad);
}

vec4 bvh_node_entry(SlabRay r, uint node, float t_max, out uvec4 child) {
    const float kPlaneError = 5.0 * kMachineEpsilon;
    int base = int(node) * kBvhTexelsPerNode;
    uvec4 head = bvh_node_texel(base, 0);
    child = bvh_node_texel(base, 1);
    uvec4 xy = bvh_node_texel(base, 2);  // lo.x, hi.x, lo.y, hi.y
    uvec2 z = bvh_node_texel(base, 3).xy;  // lo.z, hi.z
    // as bvh_node_frame, written out: through the struct this loop measured ~3% slower
    vec3 scale = uintBitsToFloat(((uvec3(head.w) >> uvec3(0u, 8u, 16u)) & 255u) << 23u);
    vec3 a = scale * r.inv_d;
    vec3 b = (uintBitsToFloat(head.xyz) - r.o) * r.inv_d;
    vec3 pad = (abs(b) + 255.0 * abs(a)) * kPlaneError;
    vec3 bn = b - pad;
    vec3 bf = b + pad;
    // The near plane of an axis is its min plane unless the ray runs towards -axis.
    vec4 nx = fma(bvh_plane_bytes(r.neg.x ? xy.y : xy.x), vec4(a.x), vec4(bn.x));
    vec4 fx = fma(bvh_plane_bytes(r.neg.x ? xy.x : xy.y), vec4(a.x), vec4(bf.x));
    vec4 ny = fma(bvh_plane_bytes(r.neg.y ? xy.w : xy.z), vec4(a.y), vec4(bn.y));
    vec4 fy = fma(bvh_plane_bytes(r.neg.y ? xy.z : xy.w), vec4(a.y), vec4(bf.y));
    vec4 nz = fma(bvh_plane_bytes(r.neg.z ? z.y : z.x), vec4(a.z), vec4(bn.z));
    vec4 fz = fma(bvh_plane_bytes(r.neg.z ? z.x : z.y), vec4(a.z), vec4(bf.z));
    return slab_combine4(nx, fx, ny, fy, nz, fz, t_max);
}

// Compare-exchange of (t, ref) pairs: afterwards ta <= tb.
void bvh_sort2(inout float ta, inout uint ra, inout float tb, inout uint rb) {
    bool swap = tb < ta;
    float t = ta;
    uint r = ra;
    ta = swap ? tb : ta;
    ra = swap ? rb : ra;
    tb = swap ? t : tb;
    rb = swap ? r : rb;
}

// One inner node of an ordered traversal (bvh_traverse, instances_traverse): the children
// the ray enters closer than hit.t, sorted by entry distance; the nearest becomes `node`
// (kNone if none) and the others are pushed farthest first. Reads and writes the caller's
// slab, node, hit, stack, stack_t, sp and kNone; on a stack about to overflow it sets
// hit.prim = kBvhStackOverflow and returns false from the caller. A macro, not a function:
// GLSL passes arrays by copy, and the traversal loop is the hot path.
#define BVH_VISIT_INNER_NODE() { \
    uvec4 child; \
    vec4 tn = bvh_node_entry(slab, node, hit.t, child); \
    float t0 = tn.x, t1 = tn.y, t2 = tn.z, t3 = tn.w; \
    uint c0 = child.x, c1 = child.y, c2 = child.z, c3 = child.w; \
    /* Sorting network for four; misses (+inf) sink to the end. */ \
    bvh_sort2(t0, c0, t1, c1); \
    bvh_sort2(t2, c2, t3, c3); \
    bvh_sort2(t0, c0, t2, c2); \
    bvh_sort2(t1, c1, t3, c3); \
    bvh_sort2(t1, c1, t2, c2); \
    if (sp + 3 > kBvhStackSize) { \
        hit.prim = kBvhStackOverflow; \
        return false; \
    } \
    if (t3 < kInfinity) { \
        stack_t[sp] = t3; \
        stack[sp++] = c3; \
    } \
    if (t2 < kInfinity) { \
        stack_t[sp] = t2; \
        stack[sp++] = c2; \
    } \
    if (t1 < kInfinity) { \
        stack_t[sp] = t1; \
        stack[sp++] = c1; \
    } \
    node = t0 < kInfinity ? c0 : kNone; \
}

// The traversal behind every query, from node `root` (0: the static scene; a
// motion instance's own tree otherwise). any_hit is a constant at every call
// site, so the compiler keeps only one variant's code in each.
bool bvh_traverse(uint root, vec3 o, vec3 d, float t_max, const bool any_hit, out BvhHit hit) {
    hit = BvhHit(t_max, kBvhNoHit, vec2(0.0));
    if (!(t_max > 0.0) || all(equal(d, vec3(0.0)))) {
        return false;
    }
    SlabRay slab = make_slab_ray(o, d);
    WatertightRay tri_ray = make_watertight_ray(o, d);
    const uint kNone = 0xFFFFFFFFu;
    uint stack[kBvhStackSize];
    float stack_t[kBvhStackSize];
    int sp = 0;
    uint node = root;  // next inner node (the root first), a leaf waiting for the slot, or kNone
    uint leaf_first = 0u;  // the leaf being tested, one triangle per iteration
    uint leaf_count = 0u;
    bool found = false;
    while (true) {
        LOOP_TICK();
        // One triangle of the current leaf ...
        if (leaf_count > 0u) {
            // as bvh_triangle_hit, written out: through the function this loop measured
            // 4-5% slower (benchmarks/RESULTS.md, "Busy lanes")
            int base = int(leaf_first) * kBvhTexelsPerTriangle;
            vec4 uvwt;
            if (watertight_candidate(tri_ray, bvh_triangle_texel(base, 0).xyz,
                                     bvh_triangle_texel(base, 1).xyz,
                                     bvh_triangle_texel(base, 2).xyz, hit.t, uvwt)) {
                float t;
                vec2 bary;
                bool solid = watertight_resolve(uvwt, hit.t, t, bary);
#if GLRENDER_ALPHA_CUTOUTS
                solid = solid && bvh_alpha_pass(leaf_first, bary);
#endif
                if (solid) {
                    hit = BvhHit(t, leaf_first, bary);
                    found = true;
                    if (any_hit) {
                        return true;
                    }
                }
            }
            leaf_first++;
            leaf_count--;
        }
        // ... and one inner node.
        if ((node & kBvhLeafFlag) == 0u) {
            BVH_VISIT_INNER_NODE();
        }
        // A leaf reference takes the free leaf slot; an empty hand pops the stack
        // (one entry per iteration; one entered beyond the closest hit is dropped).
        if (node != kNone && (node & kBvhLeafFlag) != 0u && leaf_count == 0u) {
            leaf_first = node & kBvhLeafFirstMask;
            leaf_count = (node >> kBvhLeafCountShift) & 7u;
            node = kNone;
        }
        if (node == kNone) {
            if (sp > 0) {
                sp--;
                node = stack_t[sp] > hit.t ? kNone : stack[sp];
            } else if (leaf_count == 0u) {
                break;
            }
        }
    }
    return found;
}

// A second-level query (a motion instance's or a static instance's tree, the ray (o, d)
// moved into its space) closer than hit.t: a closer hit replaces hit and returns true; a
// stack overflow sets hit.prim to kBvhStackOverflow and returns false.
bool bvh_traverse_closer(uint root, vec3 o, vec3 d, const bool any_hit, inout BvhHit hit) {
    BvhHit h;
    if (bvh_traverse(root, o, d, hit.t, any_hit, h)) {
        hit = h;
        return true;
    }
    if (h.prim == kBvhStackOverflow) {
        hit.prim = kBvhStackOverflow;
    }
    return false;
}

// Nearest hit of the ray o + t d, t in (0, t_max), in the static scene (d need
// not be normalized). Motion instances: geometry/motion.glsl.
bool bvh_intersect_closest(vec3 o, vec3 d, float t_max, out BvhHit hit) {
    return bvh_traverse(0u, o, d, t_max, false, hit);
}

// Whether anything blocks o + t d for t in (0, t_max): shadow rays, early exit.
bool bvh_intersect_any(vec3 o, vec3 d, float t_max) {
    BvhHit hit;
    return bvh_traverse(0u, o, d, t_max, true, hit);
}
