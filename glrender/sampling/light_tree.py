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

    [0] nodes (uint), [1] n_inf (uint), [2] pad (uint), [3] trails (uint: the per-light table's
    offset in the block), [4:7] the root's box's lo xyz (float32, rounded outward), 0,
    [8:11] its hi xyz, 0; then per light at infinity 8 elements: its light index (uint),
    its importance scale, 1 (uint) for a directional light (times |cos| to n), 0, its
    direction xyz, 0; then pad zeros (0-3: the nodes start on a multiple of 4 elements of
    the whole array, LightBounds.offset giving where the block starts, so that the shader
    reads a node as two 16-byte loads); then the nodes, 8 elements (32 bytes) each, the
    root first and a node's two children adjacent (a level of the descent reads one 64-byte
    run):
    [0] phi; [1] the radius of a sphere about the decoded box's centre holding the decoded
    box (float32, rounded up); [2] the cone's axis w, octahedral (uint: x in the low 16
    bits, y in the high 16, pbrt-v4's OctahedralVector); [3] (uint) cos(theta_o) in bits
    0-14, cos(theta_e) in bits 15-29 (each 15-bit steps over [-1, 1]), bit 30 two-sided,
    bit 31 leaf; [4] the first child's node index or the leaf's light index (uint);
    [5:8] the box (uint, six 16-bit steps, low halves first: lo x, lo y, lo z, hi x, hi y,
    hi z): lo = parent lo + q (parent hi - parent lo) / 65535, hi = parent hi - q (...)
    within the parent's decoded box (the header's box for the root), as pbrt-v4's
    CompactLightBounds quantises within the scene's;
    then per light: its leaf's node index + 1 (uint, 0: not in the tree) and its bit trail
    (uint: bit k is 1 where the descent takes the second child at depth k).

The quantisation rounds outward, so that each decoded node still bounds its lights and the
importance stays an upper bound: box steps round toward the parent's sides (with a margin
of two float32 steps of the parent's coordinates for the shader's rounding); the cosines
round down (the cones widen: by up to 2/32767 in cos theta, about 0.6 degrees for a
single planar light's cone of 0); the cone's half angle grows by the angle between its
axis and the decoded axis (at most about 1e-4 radians) and 1e-6. The probabilities are
those of the decoded tree: up to these roundings, the unquantised tree's.

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
HEADER = 12           # counts, then the root's box (float32 lo xyz, 0, hi xyz, 0)
INFINITE_FLOATS = 8
NODE_FLOATS = 8       # 32 bytes: CompactLightBounds-style quantised nodes
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
    offset: int = 0     # where the packed block will start in the distributions array


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


# ---- quantised nodes ----------------------------------------------------------------------
BOX_STEPS = 65535     # a box coordinate: 16 bits within the parent's decoded box
COS_STEPS = 32767     # cos(theta_o), cos(theta_e): 15 bits over [-1, 1]
OCT_STEPS = 65535     # each octahedral coordinate of the cone's axis: 16 bits over [-1, 1]
WORD_TWO_SIDED = 1 << 30
WORD_LEAF = 1 << 31
CONE_MARGIN = 1e-6    # radians the cone widens beyond the axis's encoding error (float32 decode)


def decode_box(q_lo, q_hi, p_lo, p_hi) -> tuple[np.ndarray, np.ndarray]:
    """The box of quantised steps q_lo (up from the parent box's lo) and q_hi (down from its
    hi) within the parent's decoded box p_lo, p_hi, in float32 as the shader decodes it."""
    p_lo, p_hi = np.asarray(p_lo, np.float32), np.asarray(p_hi, np.float32)
    s = (p_hi - p_lo) * np.float32(1.0 / BOX_STEPS)
    return (p_lo + np.asarray(q_lo).astype(np.float32) * s,
            p_hi - np.asarray(q_hi).astype(np.float32) * s)


def quantise_box(lo, hi, p_lo, p_hi):
    """Boxes lo, hi (m, 3) inside the decoded parent boxes p_lo, p_hi (float32): the steps
    (uint32) and the decoded boxes, rounded outward (the decoded box holds the box, with a
    margin of two float32 steps of the parent's coordinates for the shader's rounding)."""
    p_lo, p_hi = np.asarray(p_lo, np.float32), np.asarray(p_hi, np.float32)
    ext = (p_hi.astype(np.float64) - p_lo)
    with np.errstate(invalid="ignore", divide="ignore"):
        t_lo = np.where(ext > 0, (lo - p_lo.astype(np.float64)) / ext * BOX_STEPS, 0.0)
        t_hi = np.where(ext > 0, (p_hi.astype(np.float64) - hi) / ext * BOX_STEPS, 0.0)
    q_lo = np.clip(np.floor(t_lo), 0, BOX_STEPS).astype(np.int64)
    q_hi = np.clip(np.floor(t_hi), 0, BOX_STEPS).astype(np.int64)
    margin = 2 * np.spacing(np.maximum(np.abs(p_lo), np.abs(p_hi))).astype(np.float64)
    for _ in range(4):
        d_lo, d_hi = decode_box(q_lo, q_hi, p_lo, p_hi)
        bad_lo = (q_lo > 0) & (d_lo.astype(np.float64) + margin > lo)
        bad_hi = (q_hi > 0) & (d_hi.astype(np.float64) - margin < hi)
        if not (bad_lo.any() or bad_hi.any()):
            break
        q_lo -= bad_lo
        q_hi -= bad_hi
    else:   # still too close after 4 steps (a box of steps below float32's): the parent's side
        q_lo[bad_lo] = 0
        q_hi[bad_hi] = 0
    d_lo, d_hi = decode_box(q_lo, q_hi, p_lo, p_hi)
    return q_lo.astype(np.uint32), q_hi.astype(np.uint32), d_lo, d_hi


def half_diagonal(lo, hi) -> np.ndarray:
    """The radius (float32, rounded up) of a sphere about the decoded box's centre, as the
    shader computes it (0.5 (lo + hi) in float32), that holds the box."""
    lo, hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
    centre = np.float32(0.5) * (lo + hi)
    reach = np.maximum(hi.astype(np.float64) - centre, centre.astype(np.float64) - lo)
    radius = np.linalg.norm(reach, axis=-1) * (1 + 2.0 ** -20)
    return np.nextafter(radius.astype(np.float32), np.float32(np.inf))


def decode_octahedral(bits) -> np.ndarray:
    """Unit vectors (float32, as the shader decodes them) of octahedral words: x in the
    low 16 bits, y in the high 16 (pbrt-v4's OctahedralVector)."""
    bits = np.asarray(bits, np.uint32)
    x = (bits & 0xFFFF).astype(np.float32) * np.float32(2.0 / OCT_STEPS) - np.float32(1)
    y = (bits >> 16).astype(np.float32) * np.float32(2.0 / OCT_STEPS) - np.float32(1)
    z = np.float32(1) - np.abs(x) - np.abs(y)
    fold = z < 0
    fx = np.where(fold, (np.float32(1) - np.abs(y)) * np.where(x >= 0, 1, -1).astype(np.float32), x)
    fy = np.where(fold, (np.float32(1) - np.abs(x)) * np.where(y >= 0, 1, -1).astype(np.float32), y)
    v = np.stack([fx, fy, z], axis=-1).astype(np.float32)
    return (v / np.linalg.norm(v.astype(np.float64), axis=-1, keepdims=True)).astype(np.float32)


def encode_octahedral(w) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors w (m, 3) as octahedral words (uint32) and the vectors they decode to."""
    w = np.asarray(w, np.float64)
    v = w / np.maximum(np.abs(w).sum(axis=-1, keepdims=True), 1e-300)
    fold = v[:, 2] < 0
    sx = np.where(v[:, 0] >= 0, 1.0, -1.0)
    sy = np.where(v[:, 1] >= 0, 1.0, -1.0)
    x = np.where(fold, (1 - np.abs(v[:, 1])) * sx, v[:, 0])
    y = np.where(fold, (1 - np.abs(v[:, 0])) * sy, v[:, 1])
    enc = lambda f: np.round(np.clip((f + 1) / 2, 0, 1) * OCT_STEPS).astype(np.uint32)
    bits = enc(x) | (enc(y) << 16)
    return bits, decode_octahedral(bits)


def widen_cone(cos_o, w, w_decoded) -> np.ndarray:
    """cos(theta_o) of cones about the decoded axes that hold the cones (w, theta_o):
    theta_o grows by the angle between w and its decoded axis (and CONE_MARGIN)."""
    w = np.asarray(w, np.float64)
    wd = np.asarray(w_decoded, np.float64)
    error = np.arctan2(np.linalg.norm(np.cross(w, wd), axis=-1), (w * wd).sum(axis=-1))
    theta = np.arccos(np.clip(cos_o, -1.0, 1.0)) + error + CONE_MARGIN
    return np.where((np.asarray(cos_o) <= -1.0) | (theta >= math.pi), -1.0, np.cos(np.minimum(theta, math.pi)))


def decode_cos(q) -> np.ndarray:
    """Cosines (float32, as the shader decodes them) of 15-bit steps."""
    return np.asarray(q).astype(np.float32) * np.float32(2.0 / COS_STEPS) - np.float32(1)


def quantise_cos(c) -> np.ndarray:
    """Cosines in [-1, 1] as 15-bit steps (uint32) rounded down: the decoded angle is at
    least the angle (a cone widens), with a margin of two float32 steps for the shader's
    rounding."""
    c = np.asarray(c, np.float64)
    q = np.clip(np.floor((c + 1) / 2 * COS_STEPS), 0, COS_STEPS).astype(np.int64)
    q -= (q > 0) & (decode_cos(q).astype(np.float64) > c - 2.0 ** -22)
    return q.astype(np.uint32)


class _Builder:
    """Builds the tree top-down into node slots allocated a pair at a time (a node's two
    children adjacent): per slot its box, intensity, cone, flags and child (or light)."""

    def __init__(self, b: LightBounds, lights: np.ndarray) -> None:
        self.b = b
        self.lights = lights
        size = max(2 * len(b.phi) - 1, 1)
        self.lo = np.zeros((size, 3))
        self.hi = np.zeros((size, 3))
        self.phi = np.zeros(size)
        self.w = np.zeros((size, 3))
        self.cos_o = np.zeros(size)
        self.cos_e = np.zeros(size)
        self.flags = np.zeros(size, np.uint32)
        self.child = np.zeros(size, np.uint32)
        self.parent = np.full(size, -1, np.int64)
        self.depth = np.zeros(size, np.int64)
        self.used = 1                      # slot 0: the root
        self.trail = np.zeros(len(b.phi), np.uint64)
        self.leaf = np.zeros(len(b.phi), np.uint32)

    def node(self, idx: np.ndarray, slot: int) -> None:
        b = self.b
        self.lo[slot], self.hi[slot] = b.lo[idx].min(axis=0), b.hi[idx].max(axis=0)
        self.phi[slot] = b.phi[idx].sum()
        self.w[slot], self.cos_o[slot] = _cone(b.w[idx], b.cos_o[idx], b.phi[idx])
        self.cos_e[slot] = b.cos_e[idx].min()
        self.flags[slot] = FLAG_TWO_SIDED if b.two_sided[idx].any() else 0

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

    def build(self, idx: np.ndarray, depth: int, trail: int, slot: int) -> None:
        self.node(idx, slot)
        self.depth[slot] = depth
        if len(idx) == 1:
            light = int(self.lights[idx[0]])
            self.child[slot] = light
            self.flags[slot] |= FLAG_LEAF
            self.leaf[light] = slot + 1
            self.trail[light] = trail
            return
        first, second = self.split(idx, depth)
        pair = self.used
        self.used += 2
        self.child[slot] = pair
        self.parent[pair:pair + 2] = slot
        self.build(first, depth + 1, trail, pair)
        self.build(second, depth + 1, trail | (1 << depth), pair + 1)

    def encode(self) -> tuple[np.ndarray, np.ndarray]:
        """The packed nodes (NODE_FLOATS each) and the root's box (float32 lo, hi): each
        node's box quantised within its parent's decoded box, a level at a time."""
        count = self.used
        words = np.zeros((count, NODE_FLOATS), np.uint32)
        lo, hi = self.lo[:count], self.hi[:count]
        # the root's box in float32, rounded outward: the frame of the root's quantised box
        root_lo = np.nextafter(lo[0].astype(np.float32), np.float32(-np.inf))
        root_hi = np.nextafter(hi[0].astype(np.float32), np.float32(np.inf))
        dec_lo = np.zeros((count, 3), np.float32)
        dec_hi = np.zeros((count, 3), np.float32)
        depth = self.depth[:count]
        for level in range(int(depth.max()) + 1):
            at = np.flatnonzero(depth == level)
            parent = self.parent[at]
            p_lo = np.where(parent[:, None] < 0, root_lo, dec_lo[np.maximum(parent, 0)])
            p_hi = np.where(parent[:, None] < 0, root_hi, dec_hi[np.maximum(parent, 0)])
            q_lo, q_hi, dec_lo[at], dec_hi[at] = quantise_box(lo[at], hi[at], p_lo, p_hi)
            words[at, 5] = q_lo[:, 0] | (q_lo[:, 1] << 16)
            words[at, 6] = q_lo[:, 2] | (q_hi[:, 0] << 16)
            words[at, 7] = q_hi[:, 1] | (q_hi[:, 2] << 16)
        words[:, 1] = np.float32(half_diagonal(dec_lo, dec_hi)).view(np.uint32)
        words[:, 0] = self.phi[:count].astype(np.float32).view(np.uint32)
        oct_bits, w_decoded = encode_octahedral(self.w[:count])
        words[:, 2] = oct_bits
        cos_o = widen_cone(self.cos_o[:count], self.w[:count], w_decoded)
        words[:, 3] = (quantise_cos(cos_o) | (quantise_cos(self.cos_e[:count]) << 15) |
                       np.where(self.flags[:count] & FLAG_TWO_SIDED, WORD_TWO_SIDED, 0).astype(np.uint32) |
                       np.where(self.flags[:count] & FLAG_LEAF, WORD_LEAF, 0).astype(np.uint32))
        words[:, 4] = self.child[:count]
        return words.view(np.float32), np.stack([root_lo, root_hi])


def _build(bounds: LightBounds) -> _Builder:
    """The tree over ``bounds``'s finite lights with phi > 0, unquantised."""
    builder = _Builder(bounds, np.arange(len(bounds.phi)))
    finite = np.flatnonzero(~bounds.infinite & (bounds.phi > 0))
    if len(finite):
        builder.build(finite, 0, 0, 0)
    return builder


def light_tree_table(bounds: LightBounds) -> np.ndarray:
    """The packed block (module docstring) of the tree over ``bounds``'s finite lights with
    phi > 0 (the others are never chosen by the tree)."""
    n = len(bounds.phi)
    infinite = np.flatnonzero(bounds.infinite)
    finite = np.flatnonzero(~bounds.infinite & (bounds.phi > 0))
    builder = _build(bounds)
    header = np.zeros(HEADER, np.float32)
    if len(finite):
        nodes, root_box = builder.encode()
        header[4:7], header[8:11] = root_box
    else:
        nodes = np.zeros((0, NODE_FLOATS), np.float32)
    n_inf = len(infinite)
    inf_block = np.zeros((n_inf, INFINITE_FLOATS), np.float32)
    inf_block[:, 0] = _uints(infinite)
    inf_block[:, 1] = np.maximum(bounds.phi[infinite], 0.0)
    inf_block[:, 2] = _uints((bounds.cos_o[infinite] == 1.0).astype(np.uint32))
    inf_block[:, 4:7] = bounds.w[infinite]
    # the nodes start on a multiple of 4 elements of the whole array: two 16-byte loads each
    pad = -(bounds.offset + HEADER + inf_block.size) % 4
    trails_at = HEADER + inf_block.size + pad + nodes.size
    header[[0, 1, 2, 3]] = _uints([len(nodes), n_inf, pad, trails_at])
    per_light = np.zeros((n, 2), np.float32)
    per_light[:, 0] = _uints(builder.leaf)
    per_light[:, 1] = _uints(builder.trail.astype(np.uint32))
    return np.concatenate([header, inf_block.reshape(-1), np.zeros(pad, np.float32), nodes.reshape(-1),
                           per_light.reshape(-1)])


# ---- numpy twins of shaders/lights/light_tree.glsl --------------------------------------------
def _u(block, i) -> int:
    return int(np.asarray(block[i], np.float32).view(np.uint32))


@dataclass
class LightTreeNode:
    """A decoded node (float32 values, as the shader decodes them)."""
    lo: np.ndarray
    hi: np.ndarray
    phi: float
    half_diag: float
    w: np.ndarray
    cos_o: float
    cos_e: float
    two_sided: bool
    leaf: bool
    child: int


def _decode(block, i: int, p_lo, p_hi) -> LightTreeNode:
    """Node i of the block, its box within the decoded parent box p_lo, p_hi."""
    at = HEADER + INFINITE_FLOATS * _u(block, 1) + _u(block, 2) + NODE_FLOATS * i
    w = np.asarray(block[at:at + NODE_FLOATS], np.float32).view(np.uint32)
    q_lo = np.array([w[5] & 0xFFFF, w[5] >> 16, w[6] & 0xFFFF])
    q_hi = np.array([w[6] >> 16, w[7] & 0xFFFF, w[7] >> 16])
    lo, hi = decode_box(q_lo, q_hi, p_lo, p_hi)
    return LightTreeNode(lo=lo, hi=hi, phi=float(w[0:1].view(np.float32)[0]),
                         half_diag=float(w[1:2].view(np.float32)[0]), w=decode_octahedral(w[2]),
                         cos_o=float(decode_cos(w[3] & 0x7FFF)), cos_e=float(decode_cos((w[3] >> 15) & 0x7FFF)),
                         two_sided=bool(w[3] & WORD_TWO_SIDED), leaf=bool(w[3] & WORD_LEAF), child=int(w[4]))


def light_tree_root(block) -> LightTreeNode:
    """The tree's root, decoded within the header's box."""
    lo = np.asarray(block[4:7], np.float32)
    hi = np.asarray(block[8:11], np.float32)
    return _decode(block, 0, lo, hi)


def _cos_sub_clamped(sin_a, cos_a, sin_b, cos_b):
    return np.where(cos_a > cos_b, 1.0, cos_a * cos_b + sin_a * sin_b)


def _sin_sub_clamped(sin_a, cos_a, sin_b, cos_b):
    return np.where(cos_a > cos_b, 0.0, sin_a * cos_b - cos_a * sin_b)


def light_tree_importance(node: LightTreeNode, p, n) -> np.ndarray:
    """Importance of the decoded node at points p (..., 3) with normals n (..., 3; 0: a
    point in a medium, no cosine there)."""
    p = np.asarray(p, np.float64)
    n = np.asarray(n, np.float64)
    pc = (np.float32(0.5) * (node.lo + node.hi)).astype(np.float64)
    extent = (np.float32(0.5) * (node.hi - node.lo)).astype(np.float64)
    phi, cos_o, w, cos_e = node.phi, node.cos_o, node.w.astype(np.float64), node.cos_e
    sin_o = math.sqrt(max(1.0 - cos_o * cos_o, 0.0))
    half_diag = node.half_diag
    v = p - pc
    dc2 = (v * v).sum(axis=-1)
    d2 = np.maximum(np.maximum(dc2, (2 * CLAMP * half_diag) ** 2), MIN_DISTANCE2)
    inside = np.all(np.abs(v) <= extent, axis=-1) | (dc2 <= half_diag * half_diag)
    with np.errstate(invalid="ignore", divide="ignore"):
        wi = v / np.sqrt(np.maximum(dc2, 1e-300))[..., None]
        cos_w = wi @ w
        if node.two_sided:
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


def _infinite_importance(block, k, n) -> float:
    at = HEADER + INFINITE_FLOATS * k
    importance = float(block[at + 1])
    if _u(block, at + 2):
        importance *= abs(float(np.dot(np.asarray(block[at + 4:at + 7], np.float64), n)))
    return importance


def light_tree_step(block, node: LightTreeNode, p, n, u: float):
    """One level of the descent from internal node ``node``: its two children (adjacent)
    and their importances at p; the second is taken where u >= the first's share p0 (so u
    = -1 takes the first, 1 the second). (child, its node index, u rescaled to [0, 1) for
    the levels below, the step's probability; 0: both children have importance 0)."""
    first = _decode(block, node.child, node.lo, node.hi)
    second = _decode(block, node.child + 1, node.lo, node.hi)
    i0 = float(light_tree_importance(first, p, n))
    i1 = float(light_tree_importance(second, p, n))
    if not i0 + i1 > 0:
        return node, -1, u, 0.0
    p0 = i0 / (i0 + i1)
    if u < p0:
        return first, node.child, min(u / p0, ONE_MINUS_EPSILON) if p0 > 0 else 0.0, p0
    return second, node.child + 1, min((u - p0) / (1 - p0), ONE_MINUS_EPSILON) if p0 < 1 else 0.0, 1 - p0


def light_tree_sample(block: np.ndarray, p, n, u: float) -> tuple[int, float]:
    """The light the tree chooses at one point p (normal n) for u in [0, 1), and its
    probability ((-1, 0.0): none, every light's importance is 0). One pass over the lights
    at infinity and the root: each candidate replaces the one held with probability its
    importance over the sum so far (u rescaled after each)."""
    n = np.asarray(n, np.float64)
    total, chosen, weight = 0.0, -1, 0.0
    candidates = [(_u(block, HEADER + INFINITE_FLOATS * k), _infinite_importance(block, k, n))
                  for k in range(_u(block, 1))]
    root = light_tree_root(block) if _u(block, 0) else None
    if root is not None:
        candidates.append((None, float(light_tree_importance(root, p, n))))
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
    pmf, node = weight / total, root
    while not node.leaf:
        node, _, u, step = light_tree_step(block, node, p, n, u)
        if not step > 0:
            return -1, 0.0
        pmf *= step
    return node.child, pmf


def light_tree_pmf(block: np.ndarray, p, n, light: int, infinite: bool) -> float:
    """The probability that light_tree_sample chooses ``light`` at p (normal n)."""
    n = np.asarray(n, np.float64)
    importances = [_infinite_importance(block, k, n) for k in range(_u(block, 1))]
    root = light_tree_root(block) if _u(block, 0) else None
    root_importance = float(light_tree_importance(root, p, n)) if root is not None else 0.0
    total = sum(importances) + root_importance
    if not total > 0:
        return 0.0
    if infinite:
        for k, importance in enumerate(importances):
            if _u(block, HEADER + INFINITE_FLOATS * k) == light:
                return importance / total
        return 0.0
    at = _u(block, 3) + 2 * light
    leaf, trail = _u(block, at) - 1, _u(block, at + 1)
    if leaf < 0 or not root_importance > 0:
        return 0.0
    pmf, node, i = root_importance / total, root, 0
    while i != leaf:
        node, i, _, step = light_tree_step(block, node, p, n, 1.0 if trail & 1 else -1.0)
        if not step > 0:
            return 0.0
        pmf *= step
        trail >>= 1
    return pmf
