"""The mesh part of a scene as the device reads it, kept in the BVH cache (accel/disk_cache.py).

A cached BVH alone still leaves a large mesh's whole-array passes to every load: packing
flattens each mesh into world-space triangles with their normals and uvs
(gpu/pack.py ``_transform_mesh``), and the device scene gathers that per-triangle data into
the tree's order (gpu/device_scene.py). An entry of kind ``device-mesh`` holds what those
passes end in: the BVH's packed buffers and the three per-triangle texel arrays (normals,
uvs, material and light), with the bounds of the triangles and which of the scene's shapes
they came from. On a hit packing skips those shapes and the device scene uploads the arrays.

The key is computed from the scene before anything is flattened: for every shape in order
its kind, material index, whether that material cuts out (opacity), whether it emits,
whether it moves, its transform, ``flip_normals`` and ``face_normals``, and for meshes the
bytes, dtypes and shapes of its vertex, triangle, normal and uv arrays; then
:data:`~glrender.gpu.pack.PACKER_VERSION` and :data:`~glrender.accel.bvh.BUILDER_VERSION`.
These are everything that decides which shapes go to the BVH and what the arrays hold
(a small mesh is compiled into the kernel, or not, by its triangles and by the primitives
before it), so a hit gives the arrays a fresh load gives, bit for bit.

Only scenes whose BVH triangles are all static and none emits are stored (emissive
triangles add lights as they are packed; moving meshes have trees of their own, cached by
accel/bvh_cache.py, as are instanced meshes' trees: a scene with ``Shape.instances`` has no
entry), and only when they hold :data:`~glrender.accel.bvh_cache.MIN_TRIANGLES`
or more mesh triangles.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..accel import bvh_cache, disk_cache
from ..accel.bvh import BUILDER_VERSION, BvhBuffers
from ..scene import model as m

KIND = "device-mesh"
TEXELS = ("normals", "uvs", "info")
_BVH_ARRAYS = ("nodes", "triangles", "instances")


@dataclass
class DeviceMesh:
    """The BVH triangles of a scene as uploaded: the tree (with no ``prim_orders``: the
    per-triangle data is in its order already) and the normals, uvs and info texel arrays
    (device_scene.py ``_upload_mesh``)."""

    bvh: BvhBuffers
    texels: tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass
class MeshSlot:
    """A scene's place in the cache: its ``key``, and on a hit (``mesh`` not None) the
    indices of the shapes whose triangles the entry holds and the triangles' (lo, hi)."""

    key: str
    mesh: DeviceMesh | None = None
    shapes: frozenset[int] = frozenset()
    bounds: tuple[np.ndarray, np.ndarray] | None = None


def lookup(scene: m.Scene, version: int) -> MeshSlot | None:
    """The slot of ``scene`` (packer ``version``), read from the cache; None when the
    cache is off or the scene's meshes are too small to be worth an entry."""
    if not disk_cache.enabled() or any(s.instances is not None for s in scene.shapes):
        return None       # instanced meshes: their trees are cached by accel/bvh_cache.py
    count = sum(np.size(s.triangles) // 3 for s in scene.shapes
                if s.kind == "mesh" and s.triangles is not None)
    if count < bvh_cache.MIN_TRIANGLES:
        return None
    params, arrays = [], []
    for shape in scene.shapes:
        material = scene.materials[shape.material] if 0 <= shape.material < len(scene.materials) \
            else None
        params.append([shape.kind, shape.material, material is not None and material.opacity is not None,
                       shape.emission is not None, bool(shape.moving), shape.flip_normals,
                       shape.face_normals, np.asarray(shape.world_from_object, np.float64).tolist()])
        if shape.kind == "mesh":
            for a in (shape.vertices, shape.triangles, shape.normals, shape.uvs):
                arrays.append(np.zeros(0) if a is None else np.asarray(a))
            params[-1].append([a is None for a in (shape.normals, shape.uvs)])
    key = disk_cache.key(KIND, version, {"shapes": params, "builder": BUILDER_VERSION}, arrays)
    slot = MeshSlot(key)
    entry = disk_cache.load(KIND, key, version)
    if entry is not None:
        try:
            a, meta = entry.arrays, entry.meta
            bvh = BvhBuffers({name: a[name] for name in _BVH_ARRAYS}, [], int(meta["width"]),
                             int(meta["depth"]), dict(meta["stats"]))
            texels = tuple(a[name] for name in TEXELS)
            if not all(len(t) == int(meta["triangles"]) for t in texels):
                return slot
            slot.mesh = DeviceMesh(bvh, texels)
            slot.shapes = frozenset(int(i) for i in meta["shapes"])
            slot.bounds = (np.array(meta["bounds"][0], np.float64), np.array(meta["bounds"][1], np.float64))
        except (KeyError, TypeError, ValueError, IndexError):
            slot.mesh = None                     # not what store() writes: packed afresh, replaced
    return slot


def store(slot: MeshSlot, version: int, mesh: DeviceMesh, shapes: list[int],
          bounds: tuple[np.ndarray, np.ndarray]) -> None:
    """Keep what a scene's packing and gathering made for its slot (see the module doc for
    which scenes qualify; the caller checks)."""
    arrays = dict(mesh.bvh.packed)
    arrays.update(zip(TEXELS, mesh.texels))
    disk_cache.store(KIND, slot.key, version, arrays,
                     {"width": mesh.bvh.width, "depth": mesh.bvh.depth, "stats": mesh.bvh.build_stats,
                      "triangles": len(mesh.texels[0]), "shapes": list(shapes),
                      "bounds": [np.asarray(b, np.float64).tolist() for b in bounds]})
