"""Instances: a few static copies are flattened, many share one tree, motion gets its own.

Static instances (glTF nodes, Mitsuba ``shapegroup``/``instance``, TOML ``instances``)
of a mesh with few copies are flattened at load: their triangles are transformed to
world space and join the one BVH. On llvmpipe a second traversal level costs a ray
transform and a second stack per instance visited, and breaks the
one-node-one-triangle rhythm of the traversal loop. Heavy repetition (a forest) is
kept two-level (:class:`StaticInstances`): each prototype mesh has one bottom-level
tree over its object-space triangles, stored after the static tree in the same node
and triangle buffers, and a top-level tree over the instances' world boxes (leaves of
one instance each, in the node buffer after the bottom-level trees) leads a ray to
the instances it may meet; there it is moved into the instance's object space
(geometry/instances.glsl). Memory grows with the prototypes' triangles plus
:data:`TEXELS_PER_STATIC_INSTANCE` texels per instance, not with the copies.

Motion instances (rigid motion over the shutter, for motion blur) cannot be
flattened: their triangles move. Each keeps its own BVH over its object-space
triangles, stored after the static tree in the same node and triangle buffers,
and two object-to-world transforms, at shutter open (time 0) and close (time 1).
Each transform is split into translation T, rotation R (a unit quaternion) and
a symmetric scale/shear S by polar decomposition (Shoemake & Duff 1992;
M = T R S), and in between T and S are interpolated linearly and R by slerp, so
a spinning object turns rigidly instead of shrinking as a lerped matrix would
(pbrt's AnimatedTransform does the same). The GLSL traversal moves the ray into
object space with the inverse of the transform interpolated at the ray's time
(geometry/motion.glsl); ray distances are unchanged by an affine map.

World bounds over the shutter are computed conservatively: the object box's
corners are transformed at N + 1 evenly spaced times and the union is grown by
L / (2N), where L bounds the speed of any point of the box,
``|T1 - T0| + (theta * max(|S0|, |S1|) + |S1 - S0|) * r`` (theta: the
rotation angle swept, r: the largest distance of a box corner from the object
origin, |.|: spectral norms; |S(t)| is at most the larger end value since the
norm is convex). Between two samples no point is farther than L / (2N) from
where it was at the nearer one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError, UsageError

BOUND_SAMPLES = 128
TEXELS_PER_INSTANCE = 12
MAX_MOTION_INSTANCES = 64
# A static instance's record (geometry/instances.glsl): object_from_world's three rows,
# world_from_object's three rows, and its prototype's root node.
TEXELS_PER_STATIC_INSTANCE = 7


def _affine(m, name: str) -> np.ndarray:
    m = np.asarray(m, np.float64)
    if m.shape == (4, 4):
        if not np.allclose(m[3], [0, 0, 0, 1]):
            raise UsageError(f"{name}: the last row of a 4x4 transform must be (0, 0, 0, 1)")
        m = m[:3]
    if m.shape != (3, 4):
        raise UsageError(f"{name}: expected a 3x4 or 4x4 affine transform, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise SceneError(f"{name}: transform has NaN or infinite entries")
    return m


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Apply a 3x4 affine transform to points (N, 3)."""
    m = _affine(m, "transform")
    return np.asarray(p, np.float64) @ m[:, :3].T + m[:, 3]


def flatten_instances(meshes, instances) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Static instances into one world-space triangle soup.

    ``meshes``: list of (vertices (V, 3), triangles (T, 3)); ``instances``: list of
    (mesh index, world_from_object 3x4 or 4x4). Returns (vertices float32,
    triangles, instance id per triangle, triangle index within its mesh).
    """
    verts, tris, inst, local = [], [], [], []
    base = 0
    for k, (mesh_index, m) in enumerate(instances):
        if not 0 <= mesh_index < len(meshes):
            raise SceneError(f"instance {k}: mesh {mesh_index} does not exist ({len(meshes)} meshes)")
        v, f = meshes[mesh_index]
        v = transform_points(_affine(m, f"instance {k}"), v)
        f = np.asarray(f, np.int64).reshape(-1, 3)
        verts.append(v)
        tris.append(f + base)
        inst.append(np.full(len(f), k, np.int64))
        local.append(np.arange(len(f), dtype=np.int64))
        base += len(v)
    if not verts:
        return (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64),
                np.zeros(0, np.int64), np.zeros(0, np.int64))
    return (np.concatenate(verts).astype(np.float32), np.concatenate(tris),
            np.concatenate(inst), np.concatenate(local))


def quaternion_from_matrix(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method)."""
    t = np.trace(r)
    if t > 0:
        s = 2.0 * np.sqrt(t + 1.0)
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + r[i, i] - r[j, j] - r[k, k])
        q = np.zeros(4)
        q[i] = 0.25 * s
        q[j] = (r[j, i] + r[i, j]) / s
        q[k] = (r[k, i] + r[i, k]) / s
        q[3] = (r[k, j] - r[j, k]) / s
    q = np.asarray(q, np.float64)
    return q / np.linalg.norm(q)


def matrix_from_quaternion(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def decompose(m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split an affine transform into translation, rotation quaternion and scale/shear S.

    ``M = T R S`` with R a proper rotation and S = V diag(sigma) V^T symmetric
    (polar decomposition through the SVD); a reflection (det < 0) is kept in S
    as a negative eigenvalue so that R stays a rotation.
    """
    m = _affine(m, "transform")
    u, sigma, vt = np.linalg.svd(m[:, :3])
    if np.linalg.det(u @ vt) < 0:
        u[:, 2] = -u[:, 2]
        sigma = sigma * np.array([1.0, 1.0, -1.0])
    if abs(sigma).min() <= 1e-12 * max(abs(sigma).max(), 1e-300):
        raise SceneError("motion transform is singular (it flattens the object)")
    r = u @ vt
    s = vt.T @ np.diag(sigma) @ vt
    return m[:, 3].copy(), quaternion_from_matrix(r), s


def slerp(q0: np.ndarray, q1: np.ndarray, t: float) -> np.ndarray:
    """Spherical interpolation of unit quaternions (q1 already on q0's hemisphere)."""
    c = float(np.clip(np.dot(q0, q1), -1.0, 1.0))
    if c > 0.9995:
        q = q0 + t * (q1 - q0)
    else:
        phi = np.arccos(c)
        q = (np.sin((1 - t) * phi) * q0 + np.sin(t * phi) * q1) / np.sin(phi)
    return q / np.linalg.norm(q)


@dataclass
class MotionInstance:
    """A rigid (affine) motion of one mesh over the shutter interval [0, 1]."""

    vertices: np.ndarray  # (V, 3) object space
    triangles: np.ndarray  # (T, 3)
    world_from_object_open: np.ndarray  # 3x4 or 4x4 at time 0
    world_from_object_close: np.ndarray  # 3x4 or 4x4 at time 1

    def __post_init__(self):
        t0, q0, s0 = decompose(self.world_from_object_open)
        t1, q1, s1 = decompose(self.world_from_object_close)
        if np.sign(np.linalg.det(s0)) != np.sign(np.linalg.det(s1)):
            raise SceneError("motion instance: a reflection appears or vanishes over the shutter")
        if np.dot(q0, q1) < 0:
            q1 = -q1
        self._keys = (t0, q0, s0), (t1, q1, s1)

    def keys(self):
        """(T, q, S) at open and close, with q1 on q0's hemisphere (shortest rotation)."""
        return self._keys

    def world_from_object(self, time: float) -> np.ndarray:
        """The interpolated 3x4 transform at ``time`` in [0, 1]."""
        (t0, q0, s0), (t1, q1, s1) = self.keys()
        time = float(np.clip(time, 0.0, 1.0))
        r = matrix_from_quaternion(slerp(q0, q1, time))
        s = (1 - time) * s0 + time * s1
        return np.concatenate([r @ s, ((1 - time) * t0 + time * t1)[:, None]], axis=1)


def motion_bounds(instance: MotionInstance, lo: np.ndarray, hi: np.ndarray,
                  samples: int = BOUND_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """A world box containing the object box (lo, hi) at every time of the shutter."""
    (t0, q0, s0), (t1, q1, s1) = instance.keys()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])], np.float64)
    reach = np.linalg.norm(corners, axis=1).max()
    theta = 2.0 * np.arccos(np.clip(np.dot(q0, q1), -1.0, 1.0))
    norm = lambda m: np.linalg.norm(m, 2)  # spectral norm
    speed = np.linalg.norm(t1 - t0) + (theta * max(norm(s0), norm(s1)) + norm(s1 - s0)) * reach
    speed *= 1.01  # slerp falls back to normalised lerp below 1.8 degrees: not quite constant speed
    world = np.stack([transform_points(instance.world_from_object(i / samples), corners)
                      for i in range(samples + 1)])
    margin = speed / (2 * samples)
    wlo, whi = world.min(axis=(0, 1)) - margin, world.max(axis=(0, 1)) + margin
    # Round outwards to float32, with room for the rounding of the transform itself.
    pad = 1e-6 * (np.abs(world).max() + margin) + 1e-30
    return (np.nextafter((wlo - pad).astype(np.float32), np.float32(-np.inf)),
            np.nextafter((whi + pad).astype(np.float32), np.float32(np.inf)))


def pack_instance(instance: MotionInstance, root: int, prim_begin: int, prim_end: int,
                  world_lo: np.ndarray, world_hi: np.ndarray) -> np.ndarray:
    """The TEXELS_PER_INSTANCE rgba32f texels of one motion instance (geometry/motion.glsl)."""
    (t0, q0, s0), (t1, q1, s1) = instance.keys()
    tex = np.zeros((TEXELS_PER_INSTANCE, 4), np.float32)
    as_float = lambda u: np.array([u], np.uint32).view(np.float32)[0]
    tex[0, :3], tex[0, 3] = world_lo, as_float(root)
    tex[1, :3], tex[1, 3] = world_hi, as_float(prim_begin)
    tex[2, :3], tex[2, 3] = t0, as_float(prim_end)
    tex[3] = q0
    tex[4:7, :3] = s0
    tex[7, :3] = t1
    tex[8] = q1
    tex[9:12, :3] = s1
    return tex


@dataclass
class StaticInstances:
    """Copies of prototype meshes, each placed by an affine transform (two-level BVH).

    ``prototypes``: list of (vertices (V, 3), triangles (T, 3)) in object space;
    ``prototype``: (K,) the prototype of each instance; ``transforms``: (K, 3, 4) or
    (K, 4, 4) world_from_object of each instance."""

    prototypes: list
    prototype: np.ndarray
    transforms: np.ndarray

    def __post_init__(self):
        self.prototype = np.asarray(self.prototype, np.int64).reshape(-1)
        t = np.asarray(self.transforms, np.float64)
        if t.ndim != 3 or t.shape[0] != len(self.prototype) or t.shape[1:] not in ((3, 4), (4, 4)):
            raise UsageError(f"StaticInstances: transforms must have shape (K, 3, 4) or (K, 4, 4) "
                             f"for K = {len(self.prototype)} instances, got {t.shape}")
        if not np.all(np.isfinite(t)):
            raise SceneError("StaticInstances: a transform has NaN or infinite entries")
        if t.shape[1] == 4 and not np.allclose(t[:, 3], [0, 0, 0, 1]):
            raise UsageError("StaticInstances: the last row of a 4x4 transform must be (0, 0, 0, 1)")
        self.transforms = np.ascontiguousarray(t[:, :3])
        if len(self.prototype) and not (0 <= self.prototype.min() and
                                        self.prototype.max() < len(self.prototypes)):
            raise UsageError(f"StaticInstances: a prototype index outside [0, {len(self.prototypes)})")
        det = np.linalg.det(self.transforms[:, :, :3])
        scale = np.abs(self.transforms[:, :, :3]).max(axis=(1, 2)) ** 3
        if np.any(np.abs(det) <= 1e-12 * np.maximum(scale, 1e-300)):
            raise SceneError("StaticInstances: a transform is singular (it flattens its instance)")

    def __len__(self) -> int:
        return len(self.prototype)


def instance_world_bounds(transforms: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World boxes (K, 3) of the object box (lo, hi) under each 3x4 transform (K, 3, 4),
    rounded outwards to float32 with room for the rounding of the transform."""
    t = np.asarray(transforms, np.float64)
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    # an affine map of a box: centre to centre, half extent through |M| (Arvo 1990)
    c = np.einsum("kij,j->ki", t[:, :, :3], centre) + t[:, :, 3]
    e = np.einsum("kij,j->ki", np.abs(t[:, :, :3]), half)
    pad = 1e-6 * (np.abs(c) + e).max(axis=1, keepdims=True) + 1e-30
    return (np.nextafter((c - e - pad).astype(np.float32), np.float32(-np.inf)),
            np.nextafter((c + e + pad).astype(np.float32), np.float32(np.inf)))


def pack_static_instances(transforms: np.ndarray, roots: np.ndarray) -> np.ndarray:
    """The TEXELS_PER_STATIC_INSTANCE rgba32f texels of each instance (geometry/instances.glsl):
    object_from_world's rows, world_from_object's rows, the root node (uint bits)."""
    t = np.asarray(transforms, np.float64)
    k = len(t)
    tex = np.zeros((k, TEXELS_PER_STATIC_INSTANCE, 4), np.float32)
    inverse = np.linalg.inv(t[:, :, :3])
    tex[:, 0:3, :3] = inverse
    tex[:, 0:3, 3] = -np.einsum("kij,kj->ki", inverse, t[:, :, 3])
    tex[:, 3:6] = t
    tex[:, 6, 0] = np.asarray(roots, np.uint32).view(np.float32)
    return tex.reshape(-1, 4)
