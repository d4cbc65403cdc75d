"""How large a mesh fits on a device: the bytes per triangle of what the renderer uploads for
its BVH triangles, and the most triangles the device takes (``--stats``, ``glrender info``).

Every BVH triangle lives in buffer textures (accel/bvh.py ``pack``, device_scene.py): the
tree's nodes and triangle corners, and the normal, uv and info texels in the tree's order.
A buffer texture holds at most ``GL_MAX_TEXTURE_BUFFER_SIZE`` texels, and each kind of that
data may span several textures (gpu/bvh_upload.py's parts, as many as the kind has units), so
the most triangles is the limit the upload refuses a scene past (bvh_upload.py
``triangle_ceiling``); the bytes per triangle say what such a mesh costs in device memory
(which GL does not report).
"""
from __future__ import annotations

import numpy as np

# the device limits that bound a scene's size: buffer textures (the BVH and triangle data),
# storage blocks (materials, lights, the film) and 2-D textures (the environment, the atlas)
LIMITS = ("GL_MAX_TEXTURE_BUFFER_SIZE", "GL_MAX_SHADER_STORAGE_BLOCK_SIZE", "GL_MAX_TEXTURE_SIZE")
REFERENCE_GRID = 64     # glrender info's reference mesh: a 64 x 64 height field, 8,192 triangles


def device_limits(gl_info) -> dict[str, int]:
    """The :data:`LIMITS` of a context (``ctx.gl.info``)."""
    return {name: int(gl_info[name]) for name in LIMITS}


def mesh_capacity(buffers: dict[str, tuple[int, int]], triangles: int) -> dict:
    """What the BVH triangles' ``buffers`` (name -> (texels, bytes) on the device) cost per
    triangle for ``triangles`` triangles (the most triangles a device takes is
    :func:`device_ceiling`'s)."""
    texels = {name: t / triangles for name, (t, _) in buffers.items()}
    return {"triangles": triangles,
            "device_bytes": sum(b for _, b in buffers.values()),
            "bytes_per_triangle": round(sum(b for _, b in buffers.values()) / triangles, 2),
            "texels_per_triangle": {name: round(t, 4) for name, t in texels.items()}}


def device_ceiling(gl) -> dict:
    """The most BVH triangles the device of ``gl`` (a context's ``gl``) takes, as the upload
    decides it (bvh_upload.py ``triangle_ceiling``): ``max_triangles``; ``limited_by``, the
    data that fills its textures first; ``textures``, how many textures that data may span."""
    from .bvh_upload import KINDS, max_parts, triangle_ceiling

    most, kind = triangle_ceiling(gl)
    return {"max_triangles": most, "limited_by": KINDS[kind].label, "textures": max_parts(gl, kind)}


def reference_capacity(gl) -> dict:
    """:func:`mesh_capacity` of a reference mesh (a height field of 8,192 triangles, built as
    a render builds its BVH) with the triangle data device_scene.py uploads, and the
    :func:`device_ceiling` of ``gl``: what a scene without its own figures may expect."""
    from ..accel import build_bvh

    n = REFERENCE_GRID
    y, x = np.mgrid[0:n + 1, 0:n + 1] / n
    vertices = np.stack([x, y, 0.1 * np.sin(7 * x) * np.cos(5 * y)], axis=-1).reshape(-1, 3)
    k = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).reshape(-1)
    triangles = np.concatenate([np.stack([k, k + 1, k + n + 2], 1), np.stack([k, k + n + 2, k + n + 1], 1)])
    packed = build_bvh(vertices.astype(np.float32), triangles).pack()
    count = len(triangles)
    buffers = {f"bvh {name}": (a.size // 4, a.nbytes) for name, a in packed.items()}
    # the normal, uv and info texels (16 bytes each): 3, 2 and 1 per triangle
    buffers.update({"triangle normals": (3 * count, 48 * count), "triangle uvs": (2 * count, 32 * count),
                    "triangle info": (count, 16 * count)})
    return {**mesh_capacity(buffers, count), **device_ceiling(gl)}
