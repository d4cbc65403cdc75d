"""Built BVHs kept on disk (:mod:`.disk_cache`), so a mesh is built once, not on every run.

:func:`build_bvh_buffers` is :func:`~.bvh.build_bvh` returning :class:`~.bvh.BvhBuffers`
(what the upload needs: the packed node, triangle and instance buffers, each tree's triangle
order, the build's statistics), read from the cache when the same build was done before.
The key covers everything the tree depends on: the vertex and index arrays' bytes, dtypes
and shapes (the device scene passes world-space triangles, so the transforms that
flattening applied are in those bytes), each motion instance's arrays and its two
transforms, each static prototype's arrays with the instances' prototypes and transforms, every parameter of ``build_bvh`` but ``threads`` (the tree is the same for any
thread count), and :data:`~.bvh.BUILDER_VERSION`. Builds of fewer than
:data:`MIN_TRIANGLES` triangles are not cached: they take milliseconds.
"""
from __future__ import annotations

import inspect

import numpy as np

from . import disk_cache
from .bvh import BUILDER_VERSION, BvhBuffers, build_bvh

KIND = "bvh"
# below this many triangles (static and moving together) a build costs less than a file
MIN_TRIANGLES = 1 << 15
_SIGNATURE = inspect.signature(build_bvh)
_NOT_IN_KEY = ("vertices", "triangles", "motion", "instanced", "threads")


def build_bvh_buffers(vertices, triangles, **options) -> tuple[BvhBuffers, str]:
    """``build_bvh(vertices, triangles, **options).buffers()``, and where it came from:
    ``"hit"`` (the cache), ``"miss"`` (built, then stored) or ``"uncached"`` (built: the
    cache is off or the mesh is small)."""
    bound = _SIGNATURE.bind(vertices, triangles, **options)
    bound.apply_defaults()
    motion = list(bound.arguments["motion"])
    instanced = bound.arguments["instanced"]
    prototypes = list(instanced.prototypes) if instanced is not None else []
    count = (np.size(triangles) + sum(np.size(m.triangles) for m in motion)
             + sum(np.size(f) for _, f in prototypes)) // 3
    if count < MIN_TRIANGLES or not disk_cache.enabled():
        return build_bvh(vertices, triangles, **options).buffers(), "uncached"
    params = {k: v for k, v in bound.arguments.items() if k not in _NOT_IN_KEY}
    inputs = [np.asarray(vertices), np.asarray(triangles)]
    for m in motion:
        inputs += [np.asarray(m.vertices), np.asarray(m.triangles),
                   np.asarray(m.world_from_object_open, np.float64),
                   np.asarray(m.world_from_object_close, np.float64)]
    for v, f in prototypes:
        inputs += [np.asarray(v), np.asarray(f)]
    if instanced is not None:
        inputs += [instanced.prototype, instanced.transforms]
    key = disk_cache.key(KIND, BUILDER_VERSION, {"build": params, "motion": len(motion),
                                                 "prototypes": len(prototypes)}, inputs)
    entry = disk_cache.load(KIND, key, BUILDER_VERSION)
    if entry is not None:
        buffers = _from_entry(entry, len(motion) + len(prototypes))
        if buffers is not None:
            return buffers, "hit"
    buffers = build_bvh(vertices, triangles, **options).buffers()
    arrays = dict(buffers.packed)
    arrays.update({f"prim_order{k}": order for k, order in enumerate(buffers.prim_orders)})
    disk_cache.store(KIND, key, BUILDER_VERSION, arrays,
                     {"width": buffers.width, "depth": buffers.depth, "stats": buffers.build_stats})
    return buffers, "miss"


def _from_entry(entry: disk_cache.Entry, tree_count: int) -> BvhBuffers | None:
    """The buffers of an entry with ``tree_count`` trees besides the static one."""
    try:
        a, meta = entry.arrays, entry.meta
        packed = {name: a[name] for name in ("nodes", "triangles", "instances")}
        orders = [a[f"prim_order{k}"] for k in range(tree_count + 1)]
        return BvhBuffers(packed, orders, int(meta["width"]), int(meta["depth"]), dict(meta["stats"]))
    except (KeyError, TypeError, ValueError):
        return None
