// The light BVH of light selection "bvh": choosing a light for a light sample at a point by
// descending a tree over the lights, each step by the children's importance there (Conty
// Estevez and Kulla 2018; pbrt-v4's BVHLightSampler). The tree, its packed layout and the
// importance are documented in one place, glrender/sampling/light_tree.py, which builds
// it; its functions named like these are their numpy twins.
#include "common/constants.glsl"
#include "sampling/distribution_data.glsl"
#include "lights/light_choice.glsl"

const uint kLightTreeHeader = 4u;
const uint kLightTreeInfiniteFloats = 8u;
const uint kLightTreeNodeFloats = 16u;
const uint kLightTreeLeaf = 1u;
const uint kLightTreeTwoSided = 2u;
const float kLightTreeClamp = 0.25;           // d^2 >= (kLightTreeClamp |diagonal|)^2
const float kLightTreeMinDistance2 = 1e-10;
const int kLightTreeMaxDepth = 32;

struct LightTreeNode {
    vec3 centre;
    float phi;
    vec3 extent;      // the box's half extent
    float cos_o;
    vec3 w;
    float cos_e;
    uint child;       // the second child's node index, or a leaf's light index
    uint flags;
    float sin_o;
    float half_diag;  // length(extent)
};

// Where the nodes of the tree whose block starts at `tree` start.
uint light_tree_nodes(uint tree) {
    return tree + kLightTreeHeader + kLightTreeInfiniteFloats * distribution_fetch_uint(tree + 1u);
}

// Node i of the tree whose nodes start at `nodes`.
LightTreeNode light_tree_node(uint nodes, uint i) {
    uint at = nodes + kLightTreeNodeFloats * i;
    LightTreeNode nd;
    nd.centre = vec3(distribution_fetch(at), distribution_fetch(at + 1u), distribution_fetch(at + 2u));
    nd.phi = distribution_fetch(at + 3u);
    nd.extent = vec3(distribution_fetch(at + 4u), distribution_fetch(at + 5u), distribution_fetch(at + 6u));
    nd.cos_o = distribution_fetch(at + 7u);
    nd.w = vec3(distribution_fetch(at + 8u), distribution_fetch(at + 9u), distribution_fetch(at + 10u));
    nd.cos_e = distribution_fetch(at + 11u);
    nd.child = distribution_fetch_uint(at + 12u);
    nd.flags = distribution_fetch_uint(at + 13u);
    nd.sin_o = distribution_fetch(at + 14u);
    nd.half_diag = distribution_fetch(at + 15u);
    return nd;
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
    vec3 v = p - nd.centre;
    float dc2 = dot(v, v);
    float floor_d = 2.0 * kLightTreeClamp * nd.half_diag;
    float d2 = max(max(dc2, floor_d * floor_d), kLightTreeMinDistance2);
    if (all(lessThanEqual(abs(v), nd.extent)) || dc2 <= nd.half_diag * nd.half_diag) return nd.phi / d2;
    float inv_d = inversesqrt(dc2);
    vec3 wi = v * inv_d;
    float cos_w = dot(wi, nd.w);
    if ((nd.flags & kLightTreeTwoSided) != 0u) cos_w = abs(cos_w);
    float sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0));
    // the cone of directions the box subtends from p
    float sin_b = min(nd.half_diag * inv_d, 1.0);
    float cos_b = sqrt(max(1.0 - sin_b * sin_b, 0.0));
    // the angle from the emission cone to p, less the box's: theta' = max(0, theta_w -
    // theta_o - theta_b)
    float cos_x = cos_sub_clamped(sin_w, cos_w, nd.sin_o, nd.cos_o);
    float sin_x = sin_sub_clamped(sin_w, cos_w, nd.sin_o, nd.cos_o);
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

// One level of the descent from internal node nd (index i): its two children, the first
// following nd and the second at nd.child, weighed by their importance at p; the second is
// taken where u >= the first's share p0 (so u = -1 takes the first, 1 the second). nd and i
// become the child taken and u is rescaled to [0, 1) for the levels below. Returns the
// step's probability (0: both children have importance 0, a dead end).
float light_tree_step(uint nodes, inout LightTreeNode nd, inout uint i, inout float u, vec3 p, vec3 n) {
    LightTreeNode first = light_tree_node(nodes, i + 1u);
    LightTreeNode second = light_tree_node(nodes, nd.child);
    float i0 = light_tree_importance(first, p, n);
    float i1 = light_tree_importance(second, p, n);
    if (!(i0 + i1 > 0.0)) return 0.0;
    float p0 = i0 / (i0 + i1);
    bool take_second = u >= p0;
    i = take_second ? nd.child : i + 1u;
    nd = take_second ? second : first;
    u = min(take_second ? (u - p0) / (1.0 - p0) : u / p0, kOneMinusEpsilon);
    return take_second ? 1.0 - p0 : p0;
}

// The light chosen at p (normal n) for u in [0, 1) and its probability (0: none, no light
// can reach p). One pass over the lights at infinity and the root: each candidate replaces
// the one held with probability its importance over the sum so far (u rescaled after each).
LightChoice light_tree_sample(uint tree, vec3 p, vec3 n, float u) {
    uint n_inf = distribution_fetch_uint(tree + 1u);
    bool has_root = distribution_fetch_uint(tree) > 0u;
    uint nodes = light_tree_nodes(tree);
    LightTreeNode nd;
    if (has_root) nd = light_tree_node(nodes, 0u);
    float total = 0.0;
    float weight = 0.0;
    uint chosen = n_inf;         // n_inf: the root
    for (uint k = 0u; k <= n_inf; ++k) {
        float importance = k < n_inf ? light_tree_infinite_importance(tree, k, n)
                                     : (has_root ? light_tree_importance(nd, p, n) : 0.0);
        total += importance;
        if (!(total > 0.0)) continue;
        float q = importance / total;
        if (u < q) {
            chosen = k;
            weight = importance;
            u = min(u / q, kOneMinusEpsilon);
        } else {
            u = min((u - q) / (1.0 - q), kOneMinusEpsilon);
        }
    }
    if (!(total > 0.0)) return LightChoice(0u, 0.0);
    if (chosen < n_inf)
        return LightChoice(distribution_fetch_uint(tree + kLightTreeHeader + kLightTreeInfiniteFloats * chosen),
                           weight / total);
    float pmf = weight / total;
    uint i = 0u;
    for (int depth = 0; depth <= kLightTreeMaxDepth; ++depth) {
        if ((nd.flags & kLightTreeLeaf) != 0u) return LightChoice(nd.child, pmf);
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
    uint nodes = light_tree_nodes(tree);
    LightTreeNode nd;
    float root = 0.0;
    if (has_root) {
        nd = light_tree_node(nodes, 0u);
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
    for (int depth = 0; depth < kLightTreeMaxDepth && i != leaf; ++depth) {
        float u = (trail & 1u) != 0u ? 1.0 : -1.0;
        float step = light_tree_step(nodes, nd, i, u, p, n);
        if (!(step > 0.0)) return 0.0;
        pmf *= step;
        trail >>= 1u;
    }
    return pmf;
}
