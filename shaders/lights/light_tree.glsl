// The light BVH of light selection "bvh": choosing a light for a light sample at a point by
// descending a tree over the lights, each step by the children's importance there (Conty
// Estevez and Kulla 2018; pbrt-v4's BVHLightSampler). The tree, its packed layout (32-byte
// quantised nodes, a node's two children adjacent) and the importance are documented in
// one place, glrender/sampling/light_tree.py, which builds it; its functions named like
// these are their numpy twins.
#include "common/constants.glsl"
#include "sampling/distribution_data.glsl"
#include "lights/light_choice.glsl"

const uint kLightTreeHeader = 12u;            // counts, then the root's box
const uint kLightTreeInfiniteFloats = 8u;
const uint kLightTreeNodeFloats = 8u;
const uint kLightTreeLeaf = 1u << 31;         // in a node's word 3
const uint kLightTreeTwoSided = 1u << 30;
const float kLightTreeClamp = 0.25;           // d^2 >= (kLightTreeClamp |diagonal|)^2
const float kLightTreeMinDistance2 = 1e-10;
const int kLightTreeMaxDepth = 32;

// A decoded node: its box (rounded outward), the sphere about the box's centre that holds
// it, intensity and cone (widened by its quantisation).
struct LightTreeNode {
    vec3 lo;
    vec3 hi;
    float phi;
    float half_diag;  // the radius of the box's bounding sphere
    vec3 w;
    float cos_o;
    float cos_e;
    uint word;        // cos_o and cos_e's steps, kLightTreeTwoSided, kLightTreeLeaf
    uint child;       // the first child's node index (the second's follows), or a leaf's light index
};

// Elements i .. i + 3 of the packed array (i a multiple of 4) as one 16-byte load: defined
// beside distribution_fetch (scene/layout.glsl: one uvec4 of the buffer).
uvec4 distribution_fetch4(uint i);

// Where the nodes of the tree whose block starts at `tree` start (a multiple of 4).
uint light_tree_nodes(uint tree) {
    return tree + kLightTreeHeader + kLightTreeInfiniteFloats * distribution_fetch_uint(tree + 1u) +
           distribution_fetch_uint(tree + 2u);
}

// pbrt-v4's OctahedralVector: x in the low 16 bits, y in the high 16.
vec3 light_tree_octahedral(uint bits) {
    vec2 e = vec2(float(bits & 0xFFFFu), float(bits >> 16u)) * (2.0 / 65535.0) - 1.0;
    float z = 1.0 - abs(e.x) - abs(e.y);
    if (z < 0.0)
        e = vec2((1.0 - abs(e.y)) * (e.x >= 0.0 ? 1.0 : -1.0), (1.0 - abs(e.x)) * (e.y >= 0.0 ? 1.0 : -1.0));
    return normalize(vec3(e, z));
}

// Node `at` (its first element's index, a multiple of 4) decoded within its parent's
// decoded box: two 16-byte loads.
LightTreeNode light_tree_decode(uint at, vec3 parent_lo, vec3 parent_hi) {
    uvec4 a = distribution_fetch4(at);
    uvec4 b = distribution_fetch4(at + 4u);
    LightTreeNode nd;
    nd.phi = uintBitsToFloat(a.x);
    nd.half_diag = uintBitsToFloat(a.y);
    nd.w = light_tree_octahedral(a.z);
    nd.word = a.w;
    nd.child = b.x;
    nd.cos_o = float(nd.word & 0x7FFFu) * (2.0 / 32767.0) - 1.0;
    nd.cos_e = float((nd.word >> 15u) & 0x7FFFu) * (2.0 / 32767.0) - 1.0;
    vec3 s = (parent_hi - parent_lo) * (1.0 / 65535.0);
    nd.lo = parent_lo + vec3(float(b.y & 0xFFFFu), float(b.y >> 16u), float(b.z & 0xFFFFu)) * s;
    nd.hi = parent_hi - vec3(float(b.z >> 16u), float(b.w & 0xFFFFu), float(b.w >> 16u)) * s;
    return nd;
}

// The root of the tree whose block starts at `tree`, within the header's box.
LightTreeNode light_tree_root(uint tree) {
    vec3 lo = vec3(distribution_fetch(tree + 4u), distribution_fetch(tree + 5u), distribution_fetch(tree + 6u));
    vec3 hi = vec3(distribution_fetch(tree + 8u), distribution_fetch(tree + 9u), distribution_fetch(tree + 10u));
    return light_tree_decode(light_tree_nodes(tree), lo, hi);
}

// cos(max(0, a - b)) and sin(max(0, a - b)) from the sines and cosines of a and b.
float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.0 : cos_a * cos_b + sin_a * sin_b;
}

float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.0 : sin_a * cos_b - cos_a * sin_b;
}

// A bound on what node nd's lights bring to point p with normal n (0: a point in a medium).
float light_tree_importance(LightTreeNode nd, vec3 p, vec3 n) {
    vec3 v = p - 0.5 * (nd.lo + nd.hi);
    vec3 extent = 0.5 * (nd.hi - nd.lo);
    float dc2 = dot(v, v);
    float floor_d = 2.0 * kLightTreeClamp * nd.half_diag;
    float d2 = max(max(dc2, floor_d * floor_d), kLightTreeMinDistance2);
    if (all(lessThanEqual(abs(v), extent)) || dc2 <= nd.half_diag * nd.half_diag) return nd.phi / d2;
    float inv_d = inversesqrt(dc2);
    vec3 wi = v * inv_d;
    float cos_w = dot(wi, nd.w);
    if ((nd.word & kLightTreeTwoSided) != 0u) cos_w = abs(cos_w);
    float sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0));
    float sin_o = sqrt(max(1.0 - nd.cos_o * nd.cos_o, 0.0));
    // the cone of directions the box subtends from p
    float sin_b = min(nd.half_diag * inv_d, 1.0);
    float cos_b = sqrt(max(1.0 - sin_b * sin_b, 0.0));
    // the angle from the emission cone to p, less the box's: theta' = max(0, theta_w -
    // theta_o - theta_b)
    float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, nd.cos_o);
    float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, nd.cos_o);
    float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p <= nd.cos_e) return 0.0;
    float importance = nd.phi * cos_p / d2;
    if (dot(n, n) > 0.0) {
        float cos_i = abs(dot(wi, n));
        float sin_i = sqrt(max(1.0 - cos_i * cos_i, 0.0));
        importance *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    }
    return max(importance, 0.0);
}

// The importance of light at infinity k (its irradiance, times |cos| to n for a
// directional light).
float light_tree_infinite_importance(uint tree, uint k, vec3 n) {
    uint at = tree + kLightTreeHeader + kLightTreeInfiniteFloats * k;
    float importance = distribution_fetch(at + 1u);
    if (distribution_fetch_uint(at + 2u) != 0u) {
        vec3 w = vec3(distribution_fetch(at + 4u), distribution_fetch(at + 5u), distribution_fetch(at + 6u));
        importance *= abs(dot(w, n));
    }
    return importance;
}

// One level of the descent from internal node nd (index i): its two children, adjacent at
// nd.child, decoded within its box and weighed by their importance at p; the second is
// taken where u >= the first's share p0 (so u = -1 takes the first, 1 the second). nd and
// i become the child taken and u is rescaled to [0, 1) for the levels below. Returns the
// step's probability (0: both children have importance 0, a dead end).
float light_tree_step(uint nodes, inout LightTreeNode nd, inout uint i, inout float u, vec3 p, vec3 n) {
    uint at = nodes + kLightTreeNodeFloats * nd.child;
    LightTreeNode first = light_tree_decode(at, nd.lo, nd.hi);
    LightTreeNode second = light_tree_decode(at + kLightTreeNodeFloats, nd.lo, nd.hi);
    float i0 = light_tree_importance(first, p, n);
    float i1 = light_tree_importance(second, p, n);
    if (!(i0 + i1 > 0.0)) return 0.0;
    float p0 = i0 / (i0 + i1);
    bool take_second = u >= p0;
    i = nd.child + (take_second ? 1u : 0u);
    nd = take_second ? second : first;
    u = min(take_second ? (u - p0) / (1.0 - p0) : u / p0, kOneMinusEpsilon);
    return take_second ? 1.0 - p0 : p0;
}

// One candidate of the first choice (a light at infinity, then the root): it replaces the
// one held with probability its importance over the sum so far, `total` (which it joins);
// u is rescaled to [0, 1) for what follows. True: it is held.
bool light_tree_candidate(float importance, inout float total, inout float u) {
    total += importance;
    if (!(total > 0.0)) return false;
    float q = importance / total;
    bool take = u < q;
    u = min(take ? u / q : (u - q) / (1.0 - q), kOneMinusEpsilon);
    return take;
}

// The light chosen at p (normal n) for u in [0, 1) and its probability (0: none, no light
// can reach p). One pass over the lights at infinity and the root (light_tree_candidate).
LightChoice light_tree_sample(uint tree, vec3 p, vec3 n, float u) {
    uint n_inf = distribution_fetch_uint(tree + 1u);
    float total = 0.0;
    float weight = 0.0;
    uint chosen = n_inf;         // n_inf: the root
    for (uint k = 0u; k < n_inf; ++k) {
        float importance = light_tree_infinite_importance(tree, k, n);
        if (light_tree_candidate(importance, total, u)) {
            chosen = k;
            weight = importance;
        }
    }
    LightTreeNode nd;
    if (distribution_fetch_uint(tree) > 0u) {
        nd = light_tree_root(tree);
        float importance = light_tree_importance(nd, p, n);
        if (light_tree_candidate(importance, total, u)) {
            chosen = n_inf;
            weight = importance;
        }
    }
    if (!(total > 0.0)) return LightChoice(0u, 0.0);
    if (chosen < n_inf)
        return LightChoice(distribution_fetch_uint(tree + kLightTreeHeader + kLightTreeInfiniteFloats * chosen),
                           weight / total);
    float pmf = weight / total;
    uint nodes = light_tree_nodes(tree);
    uint i = 0u;
    for (int depth = 0; depth <= kLightTreeMaxDepth; ++depth) {
        if ((nd.word & kLightTreeLeaf) != 0u) return LightChoice(nd.child, pmf);
        float step = light_tree_step(nodes, nd, i, u, p, n);
        if (!(step > 0.0)) break;
        pmf *= step;
    }
    return LightChoice(0u, 0.0);
}

// The probability that light_tree_sample chooses light `light` at p (normal n); `infinite`:
// the light is at infinity (outside the tree).
float light_tree_pmf(uint tree, vec3 p, vec3 n, uint light, bool infinite) {
    uint n_inf = distribution_fetch_uint(tree + 1u);
    float total = 0.0;
    float mine = 0.0;
    for (uint k = 0u; k < n_inf; ++k) {
        float importance = light_tree_infinite_importance(tree, k, n);
        total += importance;
        if (infinite && distribution_fetch_uint(tree + kLightTreeHeader + kLightTreeInfiniteFloats * k) == light)
            mine = importance;
    }
    bool has_root = distribution_fetch_uint(tree) > 0u;
    LightTreeNode nd;
    float root = 0.0;
    if (has_root) {
        nd = light_tree_root(tree);
        root = light_tree_importance(nd, p, n);
    }
    total += root;
    if (!(total > 0.0)) return 0.0;
    if (infinite) return mine / total;
    uint at = distribution_fetch_uint(tree + 3u) + 2u * light;
    uint leaf = distribution_fetch_uint(tree + at);
    uint trail = distribution_fetch_uint(tree + at + 1u);
    if (leaf == 0u || !(root > 0.0)) return 0.0;
    leaf -= 1u;
    float pmf = root / total;
    uint i = 0u;
    uint nodes = light_tree_nodes(tree);
    for (int depth = 0; depth < kLightTreeMaxDepth && i != leaf; ++depth) {
        float u = (trail & 1u) != 0u ? 1.0 : -1.0;
        float step = light_tree_step(nodes, nd, i, u, p, n);
        if (!(step > 0.0)) return 0.0;
        pmf *= step;
        trail >>= 1u;
    }
    return pmf;
}
