"""A bounding volume hierarchy over lights for next-event estimation (``light_selection =
"bvh"``): Conty Estevez and Kulla 2018, "Importance Sampling of Many Lights with Adaptive
Tree Splitting", in the form of pbrt-v4's ``BVHLightSampler``.

Every light with a position (area lights, spheres, point and spot lights) is a leaf. A node
bounds its lights by a box, their summed intensity ``phi``, an orientation cone (axis ``w``
and half angle ``theta_o`` holding every light's normal or spot axis) and the largest angle
``theta_e`` beyond those normals that they emit into (pi/2 for a diffuse surface). A
shading point p with normal n descends from the root, at each node choosing a child with
probability proportional to its importance, a bound on what the child's lights bring to p:

    importance = phi cos(theta') / d^2 * cos(theta_i')   (0 where theta' >= theta_e)

where d is the distance to the box's centre (at least a quarter of its diagonal, and
1e-5), theta' the angle from the cone to p less theta_o and the angle the box subtends from
p, and theta_i' the angle between n and the direction to the box, less that subtended
angle (within the box's bounding sphere both angles are taken as 0). The light reached has
the product of the choices as its probability; its probability for MIS (a BSDF sample that
hits it) repeats the descent along the light's bit trail.

Lights at infinity (environment, directional) stay outside the tree, beside its root: each
has an importance of its own, the irradiance it can deliver (pi times an environment's
mean radiance; a directional light's irradiance times |cos| to n), and the root and they
are chosen among in proportion to their importance at p. (pbrt-v4 gives them
n_inf / (n_inf + 1) of the samples whatever the point: with one dim sky over a street of
lights, half the light samples went to the sky.)

A quarter of the diagonal as the distance's floor (pbrt-v4 takes half the diagonal's
length, not squared): at half the diagonal a node holding the point weighed its lights by
their power alone, and near lights no more than far ones; a quarter cut the variance of
light selection 1.4x further on a street of lights (tests/render/test_light_bvh.py's).

``phi`` is an intensity, not a power: a planar light's radiance times its area (its
intensity along its normal), a sphere's radiance times its cross-section, a point or spot
light's intensity. Then phi / d^2 is the irradiance each delivers head-on, and the tree
weighs area and point lights alike.

The build splits each node at the best of 12 buckets along each axis by the cost
phi M_omega(theta_o, theta_e) area(box) (pbrt-v4's EvaluateCost, with its regularisation of
thin boxes), in whole-array numpy per node; nodes of 16 lights or fewer split at the median
of their widest axis. A node's cone is the set's mean axis
(weighted by phi) with the largest angle of any member's cone from it: not the tightest
cone, but one found without a pass per member.

Packed format (one block of glrender.sampling.distributions' float32 array; *uint*
entries are bit-exact):

    [0] nodes (uint), [1] n_inf (uint), [2] 0, [3] trails (uint: the per-light table's
    offset in the block); then per light at infinity 8 elements: its light index (uint),
    its importance scale, 1 (uint) for a directional light (times |cos| to n), 0, its
    direction xyz, 0; then the nodes, 16 elements each (depth first: a node's first child
    follows it): the box's centre xyz, phi; its half extent xyz (rounded outward),
    cos(theta_o); w xyz, cos(theta_e); the second child's node index or the leaf's light
    index (uint), flags (uint: 1 leaf, 2 two-sided), sin(theta_o), the box's half
    diagonal;
    then per light: its leaf's node index + 1 (uint, 0: not in the tree) and its bit trail
    (uint: bit k is 1 where the descent takes the second child at depth k).

The GLSL sampler is ``shaders/lights/light_tree.glsl``; the functions here named like its
functions are its numpy twins, reading the same packed block.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._array import ONE_MINUS_EPSILON

BUCKETS = 12
SMALL = 16            # nodes of at most this many lights split at the median of their widest axis
MAX_DEPTH = 32        # the bit trail's width: deeper subtrees are split by count
HEADER = 4
INFINITE_FLOATS = 8
NODE_FLOATS = 16
CLAMP = 0.25          # d^2 >= (CLAMP |diagonal|)^2
FLAG_LEAF = 1
FLAG_TWO_SIDED = 2
MIN_DISTANCE2 = 1e-10   # d^2's floor: a point light's box has no extent


@dataclass
class LightBounds:
    """Per light (n of them): box ``lo``, ``hi`` (n, 3), intensity ``phi`` (n,), cone axis
    ``w`` (n, 3), ``cos_o`` and ``cos_e`` (n,), ``two_sided`` (n,) bool; ``infinite`` (n,)
    bool marks lights at infinity, which the tree leaves out: their ``phi`` is the
    irradiance they deliver, and ``cos_o`` 1 marks a directional light along ``w`` (its
    irradiance times |cos| to the normal); their other fields are ignored."""
    lo: np.ndarray
    hi: np.ndarray
    phi: np.ndarray
    w: np.ndarray
    cos_o: np.ndarray
    cos_e: np.ndarray
    two_sided: np.ndarray
    infinite: np.ndarray


def _uints(values) -> np.ndarray:
    return np.asarray(values, np.uint32).view(np.float32)


def _orientation_measure(cos_o: np.ndarray, cos_e: np.ndarray) -> np.ndarray:
    """pbrt-v4's M_omega: the solid angle measure of a cone of half angle theta_o emitting
    up to theta_e beyond it."""
    theta_o = np.arccos(np.clip(cos_o, -1.0, 1.0))
    theta_e = np.arccos(np.clip(cos_e, -1.0, 1.0))
    theta_w = np.minimum(theta_o + theta_e, math.pi)
    sin_o = np.sin(theta_o)
    return 2 * math.pi * (1 - cos_o) + math.pi / 2 * (
        2 * theta_w * sin_o - np.cos(theta_o - 2 * theta_w) - 2 * theta_o * sin_o + cos_o)


def _cone(w: np.ndarray, cos_o: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, float]:
    """A cone holding the cones (w_i, theta_o,i): the phi-weighted mean axis and the largest
    angle of a member cone's edge from it (the whole sphere where the axes cancel)."""
    axis = (w * np.maximum(phi, 1e-30)[:, None]).sum(axis=0)
    norm = np.linalg.norm(axis)
    if not norm > 1e-6 * max(float(phi.sum()), 1e-30):
        return np.array([0.0, 0.0, 1.0]), -1.0
    axis = axis / norm
    angle = np.arccos(np.clip(w @ axis, -1.0, 1.0)) + np.arccos(np.clip(cos_o, -1.0, 1.0))
    theta = float(angle.max())
    return axis, (math.cos(theta) if theta < math.pi else -1.0)


def _prefix_cones(w, cos_o, phi, bucket, nb) -> tuple[np.ndarray, np.ndarray]:
    """The cone (_cone's) of buckets [0, b] for each b < nb - 1 (prefix) or of [b + 1, nb)
    (suffix) at once: (nb - 1, 2) cosines, column 0 the prefixes', 1 the suffixes'."""
    weighted = w * np.maximum(phi, 1e-30)[:, None]
    per_bucket = np.zeros((nb, 3))
    np.add.at(per_bucket, bucket, weighted)
    pre = np.cumsum(per_bucket, axis=0)[:-1]
    suf = np.cumsum(per_bucket[::-1], axis=0)[::-1][1:]
    cosines = np.empty((nb - 1, 2))
    theta_o = np.arccos(np.clip(cos_o, -1.0, 1.0))
    for col, axes, left in ((0, pre, True), (1, suf, False)):
        norms = np.linalg.norm(axes, axis=1)
        unit = axes / np.maximum(norms, 1e-300)[:, None]
        angles = np.arccos(np.clip(w @ unit.T, -1.0, 1.0)) + theta_o[:, None]   # (n, nb - 1)
        member = bucket[:, None] <= np.arange(nb - 1)[None, :]
        if not left:
            member = ~member
        theta = np.where(member, angles, -np.inf).max(axis=0)
        cos = np.where(theta < math.pi, np.cos(np.minimum(theta, math.pi)), -1.0)
        cosines[:, col] = np.where(norms > 1e-9, cos, -1.0)
    return cosines[:, 0], cosines[:, 1]


class _Builder:
    def __init__(self, b: LightBounds, lights: np.ndarray) -> None:
        self.b = b
        self.lights = lights
        self.nodes: list[np.ndarray] = []
        self.trail = np.zeros(len(b.phi), np.uint64)
        self.leaf = np.zeros(len(b.phi), np.uint32)

    def node(self, idx: np.ndarray) -> np.ndarray:
        b = self.b
        rec = np.zeros(NODE_FLOATS, np.float32)
        lo, hi = b.lo[idx].min(axis=0), b.hi[idx].max(axis=0)
        # the box as centre and half extent, rounded outward in float32
        centre = (0.5 * (lo + hi)).astype(np.float32)
        extent = np.maximum(hi - centre, centre - lo).astype(np.float32)
        extent = np.nextafter(extent, np.float32(np.inf))
        rec[0:3] = centre
        rec[3] = b.phi[idx].sum()
        rec[4:7] = extent
        axis, cos_o = _cone(b.w[idx], b.cos_o[idx], b.phi[idx])
        rec[7] = cos_o
        rec[8:11] = axis
        rec[11] = b.cos_e[idx].min()
        rec[13] = _uints([FLAG_TWO_SIDED if b.two_sided[idx].any() else 0])[0]
        rec[14] = math.sqrt(max(1.0 - float(np.float32(cos_o)) ** 2, 0.0))
        rec[15] = np.linalg.norm(extent.astype(np.float64))
        return rec

    def split(self, idx: np.ndarray, depth: int) -> tuple[np.ndarray, np.ndarray]:
        b = self.b
        centroid = 0.5 * (b.lo[idx] + b.hi[idx])
        c_lo, c_hi = centroid.min(axis=0), centroid.max(axis=0)
        box_lo, box_hi = b.lo[idx].min(axis=0), b.hi[idx].max(axis=0)
        extent = box_hi - box_lo
        # a subtree whose lights could need more levels than the trail has splits by count;
        # so do small nodes, where the bucketed cost's numpy passes cost more than they find
        if len(idx) <= SMALL or depth + math.ceil(math.log2(len(idx))) >= MAX_DEPTH - 1 or \
                not (c_hi > c_lo).any():
            axis = int(np.argmax(c_hi - c_lo))
            order = np.argsort(centroid[:, axis], kind="stable")
            half = len(idx) // 2
            return idx[order[:half]], idx[order[half:]]
        best = (math.inf, 0, 0)
        for dim in range(3):
            if not c_hi[dim] > c_lo[dim]:
                continue
            t = (centroid[:, dim] - c_lo[dim]) / (c_hi[dim] - c_lo[dim])
            bucket = np.minimum((t * BUCKETS).astype(np.int64), BUCKETS - 1)
            lo = np.full((BUCKETS, 3), np.inf)
            hi = np.full((BUCKETS, 3), -np.inf)
            np.minimum.at(lo, bucket, b.lo[idx])
            np.maximum.at(hi, bucket, b.hi[idx])
            phi = np.bincount(bucket, b.phi[idx], BUCKETS)
            cos_e = np.ones(BUCKETS)
            np.minimum.at(cos_e, bucket, b.cos_e[idx])
            counts = np.bincount(bucket, minlength=BUCKETS)
            cos_o_l, cos_o_r = _prefix_cones(b.w[idx], b.cos_o[idx], b.phi[idx], bucket, BUCKETS)
            sides = []
            for rng in (slice(None, None), slice(None, None, -1)):
                l_lo = np.minimum.accumulate(lo[rng], axis=0)
                l_hi = np.maximum.accumulate(hi[rng], axis=0)
                d = np.maximum(l_hi - l_lo, 0.0)
                area = 2 * (d[:, 0] * d[:, 1] + d[:, 1] * d[:, 2] + d[:, 2] * d[:, 0])
                sides.append((np.cumsum(phi[rng]), area, np.minimum.accumulate(cos_e[rng]),
                              np.cumsum(counts[rng])))
            (phi_l, area_l, ce_l, n_l), (phi_r, area_r, ce_r, n_r) = sides
            phi_r, area_r, ce_r, n_r = (a[::-1] for a in (phi_r, area_r, ce_r, n_r))
            # split after bucket k: left [0, k], right [k + 1, BUCKETS)
            left = (phi_l[:-1] * _orientation_measure(cos_o_l, ce_l[:-1]) * area_l[:-1])
            right = (phi_r[1:] * _orientation_measure(cos_o_r, ce_r[1:]) * area_r[1:])
            regular = extent.max() / max(extent[dim], 1e-30)
            cost = regular * (left + right)
            cost[(n_l[:-1] == 0) | (n_r[1:] == 0)] = np.inf
            k = int(np.argmin(cost))
            if cost[k] < best[0]:
                best = (float(cost[k]), dim, k)
        _, dim, k = best
        if not math.isfinite(best[0]):
            axis = int(np.argmax(c_hi - c_lo))
            order = np.argsort(centroid[:, axis], kind="stable")
            half = len(idx) // 2
            return idx[order[:half]], idx[order[half:]]
        t = (centroid[:, dim] - c_lo[dim]) / (c_hi[dim] - c_lo[dim])
        bucket = np.minimum((t * BUCKETS).astype(np.int64), BUCKETS - 1)
        return idx[bucket <= k], idx[bucket > k]

    def build(self, idx: np.ndarray, depth: int, trail: int) -> int:
        at = len(self.nodes)
        rec = self.node(idx)
        self.nodes.append(rec)
        if len(idx) == 1:
            light = int(self.lights[idx[0]])
            rec[12] = _uints([light])[0]
            rec[13] = _uints([np.float32(rec[13]).view(np.uint32) | FLAG_LEAF])[0]
            self.leaf[light] = at + 1
            self.trail[light] = trail
            return at
        first, second = self.split(idx, depth)
        self.build(first, depth + 1, trail)
        child = self.build(second, depth + 1, trail | (1 << depth))
        rec[12] = _uints([child])[0]
        return at


def light_tree_table(bounds: LightBounds) -> np.ndarray:
    """The packed block (module docstring) of the tree over ``bounds``'s finite lights with
    phi > 0 (the others are never chosen by the tree)."""
    n = len(bounds.phi)
    infinite = np.flatnonzero(bounds.infinite)
    finite = np.flatnonzero(~bounds.infinite & (bounds.phi > 0))
    builder = _Builder(bounds, np.arange(n))
    if len(finite):
        builder.build(finite, 0, 0)
    nodes = np.array(builder.nodes, np.float32).reshape(-1, NODE_FLOATS)
    n_inf = len(infinite)
    inf_block = np.zeros((n_inf, INFINITE_FLOATS), np.float32)
    inf_block[:, 0] = _uints(infinite)
    inf_block[:, 1] = np.maximum(bounds.phi[infinite], 0.0)
    inf_block[:, 2] = _uints((bounds.cos_o[infinite] == 1.0).astype(np.uint32))
    inf_block[:, 4:7] = bounds.w[infinite]
    trails_at = HEADER + inf_block.size + nodes.size
    header = np.zeros(HEADER, np.float32)
    header[[0, 1, 3]] = _uints([len(nodes), n_inf, trails_at])
    per_light = np.zeros((n, 2), np.float32)
    per_light[:, 0] = _uints(builder.leaf)
    per_light[:, 1] = _uints(builder.trail.astype(np.uint32))
    return np.concatenate([header, inf_block.reshape(-1), nodes.reshape(-1), per_light.reshape(-1)])


# ---- numpy twins of shaders/lights/light_tree.glsl --------------------------------------------
def _u(block, i) -> int:
    return int(np.asarray(block[i], np.float32).view(np.uint32))


def _cos_sub_clamped(sin_a, cos_a, sin_b, cos_b):
    return np.where(cos_a > cos_b, 1.0, cos_a * cos_b + sin_a * sin_b)


def _sin_sub_clamped(sin_a, cos_a, sin_b, cos_b):
    return np.where(cos_a > cos_b, 0.0, sin_a * cos_b - cos_a * sin_b)


def light_tree_importance(node: np.ndarray, p, n) -> np.ndarray:
    """Importance of the node record ``node`` (16 floats) at points p (..., 3) with normals
    n (..., 3; 0: a point in a medium, no cosine there)."""
    p = np.asarray(p, np.float64)
    n = np.asarray(n, np.float64)
    pc, extent = node[0:3].astype(np.float64), node[4:7].astype(np.float64)
    phi, cos_o, w, cos_e = float(node[3]), float(node[7]), node[8:11].astype(np.float64), float(node[11])
    two_sided = (_u(node, 13) & FLAG_TWO_SIDED) != 0
    sin_o, half_diag = float(node[14]), float(node[15])
    v = p - pc
    dc2 = (v * v).sum(axis=-1)
    d2 = np.maximum(np.maximum(dc2, (2 * CLAMP * half_diag) ** 2), MIN_DISTANCE2)
    inside = np.all(np.abs(v) <= extent, axis=-1) | (dc2 <= half_diag * half_diag)
    with np.errstate(invalid="ignore", divide="ignore"):
        wi = v / np.sqrt(np.maximum(dc2, 1e-300))[..., None]
        cos_w = wi @ w
        if two_sided:
            cos_w = np.abs(cos_w)
        sin_w = np.sqrt(np.maximum(1 - cos_w * cos_w, 0.0))
        sin_b = np.minimum(half_diag / np.sqrt(np.maximum(dc2, 1e-300)), 1.0)
        cos_b = np.sqrt(np.maximum(1 - sin_b * sin_b, 0.0))
        cos_x = _cos_sub_clamped(sin_w, cos_w, sin_o, cos_o)
        sin_x = _sin_sub_clamped(sin_w, cos_w, sin_o, cos_o)
        cos_p = _cos_sub_clamped(sin_x, cos_x, sin_b, cos_b)
        imp = np.where(cos_p <= cos_e, 0.0, phi * cos_p / d2)
        cos_i = np.abs((wi * n).sum(axis=-1))
        sin_i = np.sqrt(np.maximum(1 - cos_i * cos_i, 0.0))
        has_n = (n * n).sum(axis=-1) > 0
        imp = np.where(has_n, imp * _cos_sub_clamped(sin_i, cos_i, sin_b, cos_b), imp)
    return np.where(inside, phi / d2, np.maximum(imp, 0.0))


def _node(block, i) -> np.ndarray:
    at = HEADER + INFINITE_FLOATS * _u(block, 1) + NODE_FLOATS * i
    return np.asarray(block[at:at + NODE_FLOATS], np.float32)


def _infinite_importance(block, k, n) -> float:
    at = HEADER + INFINITE_FLOATS * k
    importance = float(block[at + 1])
    if _u(block, at + 2):
        importance *= abs(float(np.dot(np.asarray(block[at + 4:at + 7], np.float64), n)))
    return importance


def light_tree_step(block, node: np.ndarray, i: int, p, n, u: float):
    """One level of the descent from internal node ``node`` (index i): its two children (the
    first follows it, the second at its child index) and their importances at p; the
    second is taken where u >= the first's share p0 (so u = -1 takes the first, 1 the
    second). (the child taken, its index, u rescaled to [0, 1) for the levels below, the
    step's probability; 0: both children have importance 0)."""
    second = _u(node, 12)
    first_node, second_node = _node(block, i + 1), _node(block, second)
    i0 = float(light_tree_importance(first_node, p, n))
    i1 = float(light_tree_importance(second_node, p, n))
    if not i0 + i1 > 0:
        return node, i, u, 0.0
    p0 = i0 / (i0 + i1)
    if u < p0:
        return first_node, i + 1, min(u / p0, ONE_MINUS_EPSILON) if p0 > 0 else 0.0, p0
    return second_node, second, min((u - p0) / (1 - p0), ONE_MINUS_EPSILON) if p0 < 1 else 0.0, 1 - p0


def light_tree_sample(block: np.ndarray, p, n, u: float) -> tuple[int, float]:
    """The light the tree chooses at one point p (normal n) for u in [0, 1), and its
    probability ((-1, 0.0): none, every light's importance is 0). One pass over the lights
    at infinity and the root: each candidate replaces the one held with probability its
    importance over the sum so far (u rescaled after each)."""
    n = np.asarray(n, np.float64)
    total, chosen, weight = 0.0, -1, 0.0
    candidates = [(_u(block, HEADER + INFINITE_FLOATS * k), _infinite_importance(block, k, n))
                  for k in range(_u(block, 1))]
    if _u(block, 0):
        candidates.append((None, float(light_tree_importance(_node(block, 0), p, n))))
    for light, importance in candidates:
        total += importance
        if not total > 0:
            continue
        q = importance / total
        if u < q:
            chosen, weight, u = light, importance, min(u / q, ONE_MINUS_EPSILON)
        else:
            u = min((u - q) / (1 - q), ONE_MINUS_EPSILON)
    if not total > 0:
        return -1, 0.0
    if chosen is not None:
        return chosen, weight / total
    pmf, node, i = weight / total, _node(block, 0), 0
    while not _u(node, 13) & FLAG_LEAF:
        node, i, u, step = light_tree_step(block, node, i, p, n, u)
        if not step > 0:
            return -1, 0.0
        pmf *= step
    return _u(node, 12), pmf


def light_tree_pmf(block: np.ndarray, p, n, light: int, infinite: bool) -> float:
    """The probability that light_tree_sample chooses ``light`` at p (normal n)."""
    n = np.asarray(n, np.float64)
    importances = [_infinite_importance(block, k, n) for k in range(_u(block, 1))]
    root = float(light_tree_importance(_node(block, 0), p, n)) if _u(block, 0) else 0.0
    total = sum(importances) + root
    if not total > 0:
        return 0.0
    if infinite:
        for k, importance in enumerate(importances):
            if _u(block, HEADER + INFINITE_FLOATS * k) == light:
                return importance / total
        return 0.0
    at = _u(block, 3) + 2 * light
    leaf, trail = _u(block, at) - 1, _u(block, at + 1)
    if leaf < 0 or not root > 0:
        return 0.0
    pmf, node, i = root / total, _node(block, 0), 0
    while i != leaf:
        node, i, _, step = light_tree_step(block, node, i, p, n, 1.0 if trail & 1 else -1.0)
        if not step > 0:
            return 0.0
        pmf *= step
        trail >>= 1
    return pmf
