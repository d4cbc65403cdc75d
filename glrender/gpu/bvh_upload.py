"""Upload a :class:`~glrender.accel.bvh.Bvh` (or its :class:`~glrender.accel.bvh.BvhBuffers`)
and the triangles' shading data as the buffer textures the GLSL reads.

Texture units 0-6 and 16-31 belong to geometry (:mod:`glrender.gpu.bindings` ``TEX_BVH_*``
and ``TEX_TRI_*``); ``shaders/geometry/bvh_layout.glsl`` declares them and nothing else does
(a test checks the units below against it).

A buffer texture holds at most GL_MAX_TEXTURE_BUFFER_SIZE texels (2^27 on llvmpipe: the
corners of 44.7M triangles). Each kind of data past that is cut into parts of
:func:`part_texels` texels, part 0 at the kind's own unit and parts 1.. from its ``*_MORE``
unit up to the next kind's (the last kind's up to the device's unit count); the kernels learn
the parts from :func:`part_defines`. A scene that needs more parts than a kind has units is
refused with a :class:`~glrender.errors.UsageError` before anything is uploaded.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..gl.buffers import BufferTexture
from ..accel.bvh import Bvh, BvhBuffers, max_depth
from . import bindings

# node widths a GLSL traversal reads: 4 (shaders/geometry/bvh.glsl, the render kernels') and
# 8 (shaders/geometry/bvh8.glsl, per lane and cooperative: benchmarks/traversal.py)
TRAVERSAL_WIDTHS = (4, 8)
UNITS_RESERVED = range(bindings.TEX_BVH_NODES, bindings.TEX_GEOMETRY_RESERVED + 1)
# Test only: texels a buffer texture may hold in place of the device's limit (None: the
# device's). Tests lower it to cut small meshes into parts.
TEXEL_LIMIT: int | None = None
# A part's texels are a multiple of this, so that no 4-wide node (4 texels), 8-wide node (6)
# or triangle record (1 to 3) straddles two parts (geometry/bvh_layout.glsl).
PART_MULTIPLE = 12


@dataclass(frozen=True)
class Kind:
    """One kind of geometry data: the unit of its first texture and the first unit of its
    further parts, its buffer texture format and GLSL sampler, the host define that gives
    the kernels its number of parts, and what it is, for messages."""

    unit: int
    more: int
    fmt: str
    sampler: str
    parts_define: str
    label: str
    texels_per_triangle: int = 0     # 0: not a per-triangle kind (the nodes)


KINDS = {
    "nodes": Kind(bindings.TEX_BVH_NODES, bindings.TEX_BVH_NODES_MORE, "rgba32ui", "u_bvh_nodes",
                  "GLRENDER_BVH_NODE_PARTS", "BVH nodes"),
    "triangles": Kind(bindings.TEX_BVH_TRIANGLES, bindings.TEX_BVH_TRIANGLES_MORE, "rgba32f",
                      "u_bvh_triangles", "GLRENDER_BVH_TRIANGLE_PARTS", "triangle corners", 3),
    "normals": Kind(bindings.TEX_TRI_NORMALS, bindings.TEX_TRI_NORMALS_MORE, "rgba32f", "u_tri_normals",
                    "GLRENDER_TRI_NORMAL_PARTS", "vertex normals", 3),
    "uvs": Kind(bindings.TEX_TRI_UVS, bindings.TEX_TRI_UVS_MORE, "rgba32f", "u_tri_uvs",
                "GLRENDER_TRI_UV_PARTS", "texture coordinates", 2),
    "info": Kind(bindings.TEX_TRI_INFO, bindings.TEX_TRI_INFO_MORE, "rgba32ui", "u_tri_info",
                 "GLRENDER_TRI_INFO_PARTS", "triangle records", 1),
}
# the motion instances: one texture (a record per moving mesh)
INSTANCES = (bindings.TEX_BVH_INSTANCES, "rgba32f", "u_bvh_instances")


def texel_limit(gl) -> int:
    """Texels one buffer texture may hold: the device's GL_MAX_TEXTURE_BUFFER_SIZE, or
    :data:`TEXEL_LIMIT` when a test set it."""
    return int(TEXEL_LIMIT if TEXEL_LIMIT is not None else gl.info["GL_MAX_TEXTURE_BUFFER_SIZE"])


def part_texels(gl) -> int:
    """Texels of one part: the texel limit rounded down to a multiple of PART_MULTIPLE."""
    return texel_limit(gl) // PART_MULTIPLE * PART_MULTIPLE


def max_parts(gl, kind: str) -> int:
    """How many textures ``kind`` may span: its first, and one per unit from its ``*_MORE``
    unit up to the next kind's (the last kind: up to GL_MAX_COMPUTE_TEXTURE_IMAGE_UNITS)."""
    more = KINDS[kind].more
    end = min([k.more for k in KINDS.values() if k.more > more] +
              [int(gl.info["GL_MAX_COMPUTE_TEXTURE_IMAGE_UNITS"])])
    return 1 + max(0, end - more)


def count_parts(gl, kind: str, texels: int, triangles: int) -> int:
    """The parts ``texels`` texels of ``kind`` take on this device; a UsageError naming the
    scene's ``triangles`` when they are more than the kind may span."""
    parts = max(1, -(-texels // part_texels(gl)))
    most = max_parts(gl, kind)
    if parts > most:
        raise UsageError(f"{triangles:,} triangles are too many for this device: their "
                         f"{KINDS[kind].label} need {parts} buffer textures of at most "
                         f"{texel_limit(gl):,} texels (GL_MAX_TEXTURE_BUFFER_SIZE) and glrender "
                         f"binds {most}; render the scene in pieces of fewer triangles")
    return parts


def triangle_ceiling(gl) -> tuple[int, str]:
    """The most triangles :func:`check_triangles` accepts on this device and the kind whose
    textures they fill first: over the per-triangle kinds, the least of the texels its parts
    may hold over its texels per triangle (one more triangle needs one texture too many)."""
    size = part_texels(gl)
    return min(((max_parts(gl, kind) * size // spec.texels_per_triangle, kind)
                for kind, spec in KINDS.items() if spec.texels_per_triangle), key=lambda c: c[0])


def check_triangles(gl, triangles: int) -> None:
    """Refuses (UsageError) ``triangles`` whose per-triangle data would span more textures
    than this device binds: before their BVH is built."""
    for kind, spec in KINDS.items():
        if spec.texels_per_triangle:
            count_parts(gl, kind, spec.texels_per_triangle * triangles, triangles)


def part_defines(parts: dict[str, int], gl) -> dict[str, int]:
    """The host defines that make the kernels read kinds cut into parts (geometry/bvh_layout.glsl):
    none when every kind is one texture, so such a scene compiles to the same kernels as
    before parts existed."""
    defines = {KINDS[kind].parts_define: n for kind, n in parts.items() if n > 1}
    if defines:
        defines["GLRENDER_GEOMETRY_PART_TEXELS"] = part_texels(gl)
    return defines


class PartedTexture:
    """One kind of geometry data on the device, in as many buffer textures as it takes."""

    def __init__(self, ctx, kind: str, data: np.ndarray, triangles: int):
        spec = KINDS[kind]
        gl = getattr(ctx, "gl", ctx)
        texels = np.ascontiguousarray(data).reshape(-1, 4)
        size = part_texels(gl)
        self.kind = kind
        self.parts: list[BufferTexture] = []
        try:
            for j in range(count_parts(gl, kind, len(texels), triangles)):
                name = spec.label if j == 0 else f"{spec.label} part {j}"
                self.parts.append(BufferTexture(ctx, texels[j * size:(j + 1) * size], spec.fmt, name))
        except Exception:
            self.release()
            raise

    @property
    def nbytes(self) -> int:
        return sum(t.nbytes for t in self.parts)

    @property
    def texels(self) -> int:
        return sum(t.texels for t in self.parts)

    def bind(self) -> None:
        spec = KINDS[self.kind]
        for j, texture in enumerate(self.parts):
            texture.bind(spec.unit if j == 0 else spec.more + j - 1)

    def release(self) -> None:
        for texture in self.parts:
            texture.release()
        self.parts = []


class GpuBvh:
    """A BVH's buffer textures on one context; :meth:`bind` before dispatching, with the
    kernels compiled with :meth:`defines`."""

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
        self.gl = getattr(ctx, "gl", ctx)
        self.triangles = packed["triangles"].size // 12    # 3 texels of 4 floats each
        for kind in ("nodes", "triangles"):     # refused before anything is uploaded
            count_parts(self.gl, kind, packed[kind].size // 4, self.triangles)
        self.textures: dict[str, PartedTexture] = {}
        self.instances: BufferTexture | None = None
        try:
            for kind in ("nodes", "triangles"):
                self.textures[kind] = PartedTexture(ctx, kind, packed[kind], self.triangles)
            self.instances = BufferTexture(ctx, packed["instances"], INSTANCES[1], "bvh instances")
        except Exception:
            self.release()
            raise

    @property
    def nbytes(self) -> int:
        return sum(t.nbytes for t in self.textures.values()) + \
            (self.instances.nbytes if self.instances is not None else 0)

    @property
    def parts(self) -> dict[str, int]:
        """How many buffer textures the nodes and the triangle corners span."""
        return {kind: len(t.parts) for kind, t in self.textures.items()}

    def defines(self) -> dict[str, int]:
        """The host defines of the kernels that read this tree (geometry/bvh_layout.glsl)."""
        return part_defines(self.parts, self.gl)

    def bind(self) -> None:
        """Bind every texture to its units (see ``shaders/geometry/bvh_layout.glsl``)."""
        for texture in self.textures.values():
            texture.bind()
        if self.instances is not None:
            self.instances.bind(INSTANCES[0])

    def release(self) -> None:
        for texture in self.textures.values():
            texture.release()
        if self.instances is not None:
            self.instances.release()
        self.textures, self.instances = {}, None
