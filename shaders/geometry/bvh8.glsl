// Closest-hit and any-hit ray queries against the 8-wide BVH of glrender/accel, two ways:
//
// - per lane: each invocation traverses its own ray (every device);
// - cooperatively: the 8 invocations of a SIMD vector (a subgroup on llvmpipe; an
//   aligned group of 8 in a wider one) trace the rays of the vector one at a time,
//   lane k testing child k of a node or triangle k of a leaf, with ballotARB giving
//   the hit mask. On llvmpipe a vector executes a branch for all 8 lanes whenever
//   one takes it, so a lane without a ray of its own idles through a per-lane
//   traversal; cooperatively it helps instead.
//
// The cooperative query needs every lane of the vector present at the call (ballot
// sees only active invocations): it checks that, and falls back to the per-lane
// traversal when a call site is divergent, so it is correct anywhere and fast where
// call sites are uniform.
//
// Node layout (glrender/accel/quantize.py), 6 rgba32ui texels per node:
//   0: origin p.xyz (float bits), w = biased exponents of the three axes (bytes)
//   1, 2: child references 0-3 and 4-7
//   3, 4, 5: per axis x, y, z: (lo of children 0-3, lo of 4-7, hi of 0-3, hi of 4-7),
//            byte k of a word = child k of its four.
#extension GL_ARB_shader_ballot : enable
#extension GL_ARB_gpu_shader_int64 : enable
#include "common/constants.glsl"
#include "common/loop_counter.glsl"
#include "common/params.glsl"
#include "geometry/aabb.glsl"
#include "geometry/bvh.glsl"

const int kBvh8TexelsPerNode = 6;
// glrender/accel/bvh.py MAX_DEPTH_BY_WIDTH[8]: the per-lane stack holds 7 entries per level
const int kBvh8MaxDepth = 21;
const int kBvh8StackSize = 7 * (kBvh8MaxDepth + 1);

// Entry distances into children 0-3 (half 0) or 4-7 (half 1) of a node, +inf if missed.
vec4 bvh8_half_entry(SlabRay r, NodeFrame f, uvec4 px, uvec4 py, uvec4 pz, int part, float t_max) {
    // word h: lo of this half, word 2 + h: hi
    uint lx = part == 0 ? px.x : px.y, hx = part == 0 ? px.z : px.w;
    uint ly = part == 0 ? py.x : py.y, hy = part == 0 ? py.z : py.w;
    uint lz = part == 0 ? pz.x : pz.y, hz = part == 0 ? pz.z : pz.w;
    vec4 nx = fma(bvh_plane_bytes(r.neg.x ? hx : lx), vec4(f.a.x), vec4(f.bn.x));
    vec4 fx = fma(bvh_plane_bytes(r.neg.x ? lx : hx), vec4(f.a.x), vec4(f.bf.x));
    vec4 ny = fma(bvh_plane_bytes(r.neg.y ? hy : ly), vec4(f.a.y), vec4(f.bn.y));
    vec4 fy = fma(bvh_plane_bytes(r.neg.y ? ly : hy), vec4(f.a.y), vec4(f.bf.y));
    vec4 nz = fma(bvh_plane_bytes(r.neg.z ? hz : lz), vec4(f.a.z), vec4(f.bn.z));
    vec4 fz = fma(bvh_plane_bytes(r.neg.z ? lz : hz), vec4(f.a.z), vec4(f.bf.z));
    return slab_combine4(nx, fx, ny, fy, nz, fz, t_max);
}

// Tests the leaf's triangles [first, first + count) one at a time (per-lane traversal).
// True when an any-hit query is answered.
bool bvh8_lane_leaf(WatertightRay tri_ray, uint first, uint count, const bool any_hit,
                    inout BvhHit hit, inout bool found) {
    for (uint i = 0u; i < count; ++i) {
        LOOP_TICK();
        uint prim = first + i;
        float t;
        vec2 bary;
        if (bvh_triangle_hit(tri_ray, prim, hit.t, t, bary)) {
            hit = BvhHit(t, prim, bary);
            found = true;
            if (any_hit) return true;
        }
    }
    return false;
}

// Per-lane traversal of the 8-wide tree from node `root`: children sorted by entry
// distance, the nearest visited next, the others pushed farthest first.
bool bvh8_traverse_lane(uint root, vec3 o, vec3 d, float t_max, const bool any_hit,
                        out BvhHit hit) {
    hit = BvhHit(t_max, kBvhNoHit, vec2(0.0));
    if (!(t_max > 0.0) || all(equal(d, vec3(0.0)))) {
        return false;
    }
    SlabRay slab = make_slab_ray(o, d);
    WatertightRay tri_ray = make_watertight_ray(o, d);
    const uint kNone = 0xFFFFFFFFu;
    uint stack[kBvh8StackSize];
    float stack_t[kBvh8StackSize];
    int sp = 0;
    uint node = root;
    bool found = false;
    while (true) {
        LOOP_TICK();
        if ((node & kBvhLeafFlag) != 0u) {
            if (bvh8_lane_leaf(tri_ray, node & kBvhLeafFirstMask,
                               (node >> kBvhLeafCountShift) & 7u, any_hit, hit, found)) {
                return true;
            }
            node = kNone;
        } else {
            int base = int(node) * kBvh8TexelsPerNode;
            NodeFrame f = bvh_node_frame(slab, bvh_node_texel(base, 0));
            uvec4 c03 = bvh_node_texel(base, 1);
            uvec4 c47 = bvh_node_texel(base, 2);
            uvec4 px = bvh_node_texel(base, 3);
            uvec4 py = bvh_node_texel(base, 4);
            uvec4 pz = bvh_node_texel(base, 5);
            vec4 ta = bvh8_half_entry(slab, f, px, py, pz, 0, hit.t);
            vec4 tb = bvh8_half_entry(slab, f, px, py, pz, 1, hit.t);
            float t0 = ta.x, t1 = ta.y, t2 = ta.z, t3 = ta.w;
            float t4 = tb.x, t5 = tb.y, t6 = tb.z, t7 = tb.w;
            uint c0 = c03.x, c1 = c03.y, c2 = c03.z, c3 = c03.w;
            uint c4 = c47.x, c5 = c47.y, c6 = c47.z, c7 = c47.w;
            // Batcher's odd-even merge sort of eight (19 compare-exchanges); misses sink.
            bvh_sort2(t0, c0, t1, c1); bvh_sort2(t2, c2, t3, c3);
            bvh_sort2(t4, c4, t5, c5); bvh_sort2(t6, c6, t7, c7);
            bvh_sort2(t0, c0, t2, c2); bvh_sort2(t1, c1, t3, c3);
            bvh_sort2(t4, c4, t6, c6); bvh_sort2(t5, c5, t7, c7);
            bvh_sort2(t1, c1, t2, c2); bvh_sort2(t5, c5, t6, c6);
            bvh_sort2(t0, c0, t4, c4); bvh_sort2(t1, c1, t5, c5);
            bvh_sort2(t2, c2, t6, c6); bvh_sort2(t3, c3, t7, c7);
            bvh_sort2(t2, c2, t4, c4); bvh_sort2(t3, c3, t5, c5);
            bvh_sort2(t1, c1, t2, c2); bvh_sort2(t3, c3, t4, c4);
            bvh_sort2(t5, c5, t6, c6);
            if (sp + 7 > kBvh8StackSize) {
                hit.prim = kBvhStackOverflow;
                return false;
            }
            if (t7 < kInfinity) { stack_t[sp] = t7; stack[sp++] = c7; }
            if (t6 < kInfinity) { stack_t[sp] = t6; stack[sp++] = c6; }
            if (t5 < kInfinity) { stack_t[sp] = t5; stack[sp++] = c5; }
            if (t4 < kInfinity) { stack_t[sp] = t4; stack[sp++] = c4; }
            if (t3 < kInfinity) { stack_t[sp] = t3; stack[sp++] = c3; }
            if (t2 < kInfinity) { stack_t[sp] = t2; stack[sp++] = c2; }
            if (t1 < kInfinity) { stack_t[sp] = t1; stack[sp++] = c1; }
            node = t0 < kInfinity ? c0 : kNone;
        }
        while (node == kNone) {
            if (sp == 0) return found;
            sp--;
            node = stack_t[sp] > hit.t ? kNone : stack[sp];
        }
    }
    return found;
}

#if defined(GL_ARB_shader_ballot) && defined(GL_ARB_gpu_shader_int64)
const bool kBvhCooperative = true;

// The vote of every lane of this invocation's group of 8 (bit k: lane k of the group).
uint bvh8_ballot(bool b) {
    uvec2 m = unpackUint2x32(ballotARB(b));
    uint lane = gl_SubGroupInvocationARB;
    uint word = lane < 32u ? m.x : m.y;
    return (word >> (lane & 24u)) & 255u;
}

// Every lane of the group present at the call.
bool bvh8_group_complete() {
    return gl_SubGroupSizeARB % 8u == 0u && bvh8_ballot(true) == 255u;
}

// Value x of lane j (0-7, the same in every lane) of this invocation's group of 8.
// A subgroup of 8 is one group; a wider one reads once per group.
#define BVH8_READ(T) \
T bvh8_read(T x, uint j) { \
    if (gl_SubGroupSizeARB == 8u) return readInvocationARB(x, j); \
    T v = x; \
    uint own = gl_SubGroupInvocationARB & ~7u; \
    for (uint g = 0u; g < gl_SubGroupSizeARB; g += 8u) { \
        T w = readInvocationARB(x, g + j); \
        v = own == g ? w : v; \
    } \
    return v; \
}
BVH8_READ(float)
BVH8_READ(uint)
BVH8_READ(vec2)
BVH8_READ(vec3)

// Cooperative traversal: the rays of the lanes with `has_ray` one after another, all
// eight lanes working on each. Call with every lane of the group present.
//
// The stack holds one record per inner node with children left to visit: each lane
// keeps its own child's reference, entry distance and rank (by distance among the hit
// children) at the record's level, and every lane the record's count and next rank; a
// pop finds the lane holding the next rank by a ballot and reads its child.
bool bvh8_traverse_group(bool has_ray, uint root, vec3 o, vec3 d, float t_max,
                         const bool any_hit, out BvhHit hit) {
    hit = BvhHit(t_max, kBvhNoHit, vec2(0.0));
    bool valid = has_ray && t_max > 0.0 && !all(equal(d, vec3(0.0)));
    uint lane = gl_SubGroupInvocationARB & 7u;
    uint todo = bvh8_ballot(valid);
    bool found = false;
    const uint kNone = 0xFFFFFFFFu;
    uint stack_ref[kBvh8MaxDepth + 1];
    float stack_t[kBvh8MaxDepth + 1];
    uint stack_rank[kBvh8MaxDepth + 1];
    uint stack_next[kBvh8MaxDepth + 1];  // next rank | count << 4 (the same in every lane)
    // per-lane plane word selection, by child index
    uint half_sel = lane >> 2u;
    uint shift = 8u * (lane & 3u);
    while (todo != 0u) {
        LOOP_TICK();
        uint owner = findLSB(todo);
        todo &= todo - 1u;
        vec3 ro = bvh8_read(o, owner);
        vec3 rd = bvh8_read(d, owner);
        float best_t = bvh8_read(t_max, owner);
        uint best_prim = kBvhNoHit;
        vec2 best_bary = vec2(0.0);
        SlabRay slab = make_slab_ray(ro, rd);
        WatertightRay tri_ray = make_watertight_ray(ro, rd);
        // this lane's plane words: near and far per axis (ray-constant)
        uvec3 near_word = uvec3(slab.neg) * 2u + half_sel;
        uvec3 far_word = (1u - uvec3(slab.neg)) * 2u + half_sel;
        int sp = 0;
        uint node = root;
        bool done = false;
        while (!done) {
            LOOP_TICK();
            if ((node & kBvhLeafFlag) != 0u) {
                uint first = node & kBvhLeafFirstMask;
                uint count = (node >> kBvhLeafCountShift) & 7u;
                bool hit_here = false;
                float t = kInfinity;
                vec2 bary = vec2(0.0);
                if (lane < count) {
                    hit_here = bvh_triangle_hit(tri_ray, first + lane, best_t, t, bary);
                }
                uint hits = bvh8_ballot(hit_here);
                if (hits != 0u) {
                    // the nearest of the leaf's hits (the lowest lane among equals)
                    uint win = findLSB(hits);
                    float tw = bvh8_read(t, win);
                    for (uint m = hits & (hits - 1u); m != 0u; m &= m - 1u) {
                        uint j = findLSB(m);
                        float tj = bvh8_read(t, j);
                        win = tj < tw ? j : win;
                        tw = min(tw, tj);
                    }
                    best_t = tw;
                    best_prim = first + win;
                    best_bary = bvh8_read(bary, win);
                    if (any_hit) break;
                }
                node = kNone;
            } else {
                int base = int(node) * kBvh8TexelsPerNode;
                NodeFrame f = bvh_node_frame(slab, bvh_node_texel(base, 0));
                uvec4 refs = bvh_node_texel(base, 1 + int(half_sel));
                uint ref = lane < 4u ? refs[lane] : refs[lane - 4u];
                uvec4 px = bvh_node_texel(base, 3);
                uvec4 py = bvh_node_texel(base, 4);
                uvec4 pz = bvh_node_texel(base, 5);
                vec3 qn = vec3(float((px[near_word.x] >> shift) & 255u),
                               float((py[near_word.y] >> shift) & 255u),
                               float((pz[near_word.z] >> shift) & 255u));
                vec3 qf = vec3(float((px[far_word.x] >> shift) & 255u),
                               float((py[far_word.y] >> shift) & 255u),
                               float((pz[far_word.z] >> shift) & 255u));
                vec3 tn3 = fma(qn, f.a, f.bn);
                vec3 tf3 = fma(qf, f.a, f.bf);
                float tn = max(max(tn3.x, tn3.y), max(tn3.z, 0.0));
                float tf = min(min(min(tf3.x, tf3.y), tf3.z) * kRobustFar, best_t);
                float t = tn <= tf ? tn : kInfinity;
                uint hits = bvh8_ballot(t < kInfinity);
                uint n = uint(bitCount(hits));
                node = kNone;
                if (n == 1u) {
                    node = bvh8_read(ref, findLSB(hits));
                } else if (n > 1u) {
                    // rank of this lane's child among the hit ones (ties by lane)
                    uint rank = 0u;
                    for (uint j = 0u; j < 8u; ++j) {
                        float tj = bvh8_read(t, j);
                        rank += (tj < t || (tj == t && j < lane)) ? 1u : 0u;
                    }
                    node = bvh8_read(ref, findLSB(bvh8_ballot(t < kInfinity && rank == 0u)));
                    if (sp > kBvh8MaxDepth) {
                        best_prim = kBvhStackOverflow;
                        found = false;
                        break;
                    }
                    stack_ref[sp] = ref;
                    stack_t[sp] = t;
                    stack_rank[sp] = rank;
                    stack_next[sp] = 1u | (n << 4u);
                    sp++;
                }
            }
            // an empty hand takes the next child of the top record (dropped if entered
            // beyond the closest hit)
            while (node == kNone) {
                if (sp == 0) {
                    done = true;
                    break;
                }
                uint next = stack_next[sp - 1];
                uint r = next & 15u;
                uint j = findLSB(bvh8_ballot(stack_t[sp - 1] < kInfinity && stack_rank[sp - 1] == r));
                float tj = bvh8_read(stack_t[sp - 1], j);
                uint cj = bvh8_read(stack_ref[sp - 1], j);
                if (r + 1u == (next >> 4u)) {
                    sp--;
                } else {
                    stack_next[sp - 1] = next + 1u;
                }
                node = tj > best_t ? kNone : cj;
            }
        }
        if (lane == owner) {
            hit = BvhHit(best_t, best_prim, best_bary);
            found = best_prim != kBvhNoHit && best_prim != kBvhStackOverflow;
        }
    }
    return found;
}
#else
const bool kBvhCooperative = false;
bool bvh8_group_complete() { return false; }
bool bvh8_traverse_group(bool has_ray, uint root, vec3 o, vec3 d, float t_max,
                         const bool any_hit, out BvhHit hit) {
    hit = BvhHit(t_max, kBvhNoHit, vec2(0.0));
    return false;
}
#endif

// The traversal behind every query: `has_ray` false asks nothing (the lane may still
// help the others). Cooperative when the whole group is present and at most
// kCoopLanes of its lanes have rays, per lane otherwise.
bool bvh8_traverse(bool has_ray, uint root, vec3 o, vec3 d, float t_max, const bool any_hit,
                   out BvhHit hit) {
    if (kCoopLanes > 0u && kBvhCooperative && bvh8_group_complete()) {
        uint want = uint(bitCount(bvh8_ballot(has_ray)));
        if (want <= kCoopLanes) {
            return bvh8_traverse_group(has_ray, root, o, d, t_max, any_hit, hit);
        }
    }
    hit = BvhHit(t_max, kBvhNoHit, vec2(0.0));
    return has_ray && bvh8_traverse_lane(root, o, d, t_max, any_hit, hit);
}
