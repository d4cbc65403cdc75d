"""Upload a :class:`~glrender.accel.bvh.Bvh` (or its :class:`~glrender.accel.bvh.BvhBuffers`)
as the buffer textures the GLSL traversal reads.

Texture units 0-3 belong to geometry (:mod:`glrender.gpu.bindings` ``TEX_BVH_*``);
``shaders/geometry/bvh_layout.glsl`` declares them and nothing else does (a test checks the
units below against it).
"""
from __future__ import annotations

from ..errors import UsageError
from ..gl.buffers import BufferTexture
from ..accel.bvh import Bvh, BvhBuffers, max_depth
from . import bindings

# node widths a GLSL traversal reads: 4 (shaders/geometry/bvh.glsl, the render kernels') and
# 8 (shaders/geometry/bvh8.glsl, per lane and cooperative: benchmarks/traversal.py)
TRAVERSAL_WIDTHS = (4, 8)
UNITS_RESERVED = range(bindings.TEX_BVH_NODES, bindings.TEX_GEOMETRY_RESERVED + 1)
# name in Bvh.pack() -> (texture unit, buffer texture format, GLSL sampler name)
TEXTURES = {
    "nodes": (bindings.TEX_BVH_NODES, "rgba32ui", "u_bvh_nodes"),
    "triangles": (bindings.TEX_BVH_TRIANGLES, "rgba32f", "u_bvh_triangles"),
    "instances": (bindings.TEX_BVH_INSTANCES, "rgba32f", "u_bvh_instances"),
}


class GpuBvh:
    """A BVH's buffer textures on one context; :meth:`bind` before dispatching."""

    def __init__(self, ctx, bvh: Bvh | BvhBuffers):
        if bvh.width not in TRAVERSAL_WIDTHS:
            raise UsageError(f"GpuBvh: the GLSL traversals read "
                             f"{' or '.join(map(str, TRAVERSAL_WIDTHS))}-wide trees, this one is "
                             f"{bvh.width}-wide")
        if bvh.depth > max_depth(bvh.width):
            raise UsageError(f"GpuBvh: tree depth {bvh.depth} exceeds the traversal stack "
                             f"bound {max_depth(bvh.width)} (build it with glrender.accel.build_bvh)")
        packed = bvh.pack()
        self.bvh = bvh
        self.textures = {}
        try:
            for name, (unit, fmt, _) in TEXTURES.items():
                self.textures[name] = BufferTexture(ctx, packed[name], fmt, f"bvh {name}")
        except Exception:
            self.release()
            raise

    @property
    def nbytes(self) -> int:
        return sum(t.nbytes for t in self.textures.values())

    def bind(self) -> None:
        """Bind every texture to its unit (see ``shaders/geometry/bvh_layout.glsl``)."""
        for name, texture in self.textures.items():
            texture.bind(TEXTURES[name][0])

    def release(self) -> None:
        for texture in self.textures.values():
            texture.release()
        self.textures = {}
