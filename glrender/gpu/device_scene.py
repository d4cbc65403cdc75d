"""A scene on one device: everything of it that does not depend on the render settings.

:class:`DeviceScene` turns a :class:`~glrender.scene.model.Scene` into what the kernels read:
the packed arrays (:func:`~glrender.gpu.pack.pack_scene`), the BVH over the mesh triangles
with the per-triangle shading data in the tree's order, the surface textures, and the
environment image with its importance weights. It is built once per scene and context and
shared by every driver that renders the scene (the render kernel's, photon mapping's, SPPM's,
a noise pilot, a seen-emission pass): each driver :meth:`~DeviceScene.acquire` s it and
releases it, and the device memory goes with the last release.

What depends on the settings as well is made here on request, from the same data:
:meth:`DeviceScene.light_table` (the light records with their selection pmf, alias table and
spherical-rectangle flag, and the distributions the kernels sample).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..scene import model as m
from . import bindings, envmap, layout
from .pack import PackedScene, pack_scene


@dataclass(frozen=True)
class LightTable:
    """The lights as one render's settings sample them: ``lights`` (layout.LIGHT records
    with their ``selection_pmf``) and ``distributions`` (float32: the alias
    table of the selection by power and the environment's 2-D distribution, packed by
    :class:`~glrender.sampling.distributions.DistributionPacker`)."""

    lights: np.ndarray
    distributions: np.ndarray


class DeviceScene:
    """A scene's settings-independent data on the device of ``ctx``.

    ``packed``: the scene already packed (None: pack it here). Holds ``packed``, ``bvh``
    (a :class:`~glrender.gpu.bvh_upload.GpuBvh`, None without mesh triangles) and the
    triangle, surface and environment textures; :meth:`bind` binds them all to their units.
    ``timings``: seconds of packing ("pack") and of packing plus building and uploading
    ("build")."""

    def __init__(self, ctx: Any, scene: m.Scene, packed: PackedScene | None = None) -> None:
        t0 = time.perf_counter()
        self.ctx = ctx
        self.scene = scene
        self.packed = packed if packed is not None else pack_scene(scene)
        t_pack = time.perf_counter()
        self.users = 1
        self.bvh: Any = None
        self.env_texture: Any = None
        self.env_weights: np.ndarray | None = None
        self.texture_bytes = 0              # the atlas pages (RGBA16F) on the device
        self._units: list[tuple[int, Any]] = []    # (texture unit, its bind call) for bind()
        self._owned: list[Any] = []                # released with the last user
        try:
            if self.packed.env_image is not None:
                self._upload_environment()
            if self.packed.has_bvh:
                self._upload_mesh()
            self._upload_textures()
            self._upload_microfacet_tables()
            self._upload_media_grids()
        except BaseException:
            self._free()
            raise
        self.timings = {"pack": t_pack - t0, "build": time.perf_counter() - t0}

    # -- sharing -----------------------------------------------------------------------------
    def acquire(self) -> DeviceScene:
        """One more driver uses this data (each calls :meth:`release` once)."""
        if self.users == 0:
            from ..errors import UsageError

            raise UsageError("the device scene was released: build it again")
        self.users += 1
        return self

    def release(self) -> None:
        """One driver is done with it; the last one frees the device memory."""
        self.users -= 1
        if self.users == 0:
            self._free()

    def _free(self) -> None:
        for obj in self._owned:
            obj.release()
        if self.bvh is not None:
            self.bvh.release()
        self._owned, self._units, self.bvh = [], [], None

    # -- what the kernels read ----------------------------------------------------------------
    def bind(self) -> None:
        """Bind the environment, surface and triangle textures and the BVH to their units."""
        for unit, bind in self._units:
            bind(unit)
        if self.bvh is not None:
            self.bvh.bind()

    def light_table(self, light_selection: str, area_sampling: str) -> LightTable:
        """The light records and distributions under the settings' light selection
        (``power``: proportional to ``packed.light_weights`` through an alias table, else
        uniform) and area sampling (``solid-angle``: rectangles are sampled as spherical
        rectangles, Urena et al. 2013: ``bindings.LIGHT_FLAG_RECTANGLE`` in ``info.y``)."""
        from ..sampling.distributions import DistributionPacker

        p = self.packed
        lights = p.lights.copy()
        n_lights = len(lights)
        packer = DistributionPacker()
        weights = p.light_weights
        if n_lights:
            if light_selection == "power" and weights.sum() > 0:
                pmf = weights / weights.sum()
                if n_lights > 1:
                    packer.add_alias_table(weights)
            else:
                pmf = np.full(n_lights, 1.0 / n_lights)
            lights["selection_pmf"] = pmf
            if area_sampling == "solid-angle":
                # rectangles (orthogonal edges) can use Urena et al.'s spherical rectangles
                dots = np.einsum("ij,ij->i", lights["e1"][:, :3], lights["e2"][:, :3])
                norms = np.linalg.norm(lights["e1"][:, :3], axis=1) * \
                    np.linalg.norm(lights["e2"][:, :3], axis=1)
                rect = (lights["info"][:, 0] == layout.LIGHT_KINDS["parallelogram"]) & \
                    (np.abs(dots) <= 1e-5 * np.maximum(norms, 1e-30))
                lights["info"][rect, 1] |= bindings.LIGHT_FLAG_RECTANGLE
        if self.env_weights is not None:
            env = p.environment - 1
            lights[env]["info"][3] = packer.add_distribution_2d(self.env_weights)
        dist = packer.array()
        if not dist.size:
            dist = np.zeros(4, np.float32)
        return LightTable(lights, np.ascontiguousarray(dist, np.float32))

    # -- uploads -----------------------------------------------------------------------------
    def _upload_environment(self) -> None:
        """The environment image as a float texture (bilinear, wrapping in u) and its
        importance weights (glrender/gpu/envmap.py: per texel, or per block of texels for a
        map larger than the table's limit)."""
        image = self.packed.env_image
        assert image is not None
        gl = self.ctx.gl
        envmap.check_texture_size(image, gl.info["GL_MAX_TEXTURE_SIZE"], self.scene.source)
        self.env_weights = envmap.importance_weights(image)
        h, w = image.shape[:2]
        tex = gl.texture((w, h), 3, np.ascontiguousarray(image, np.float32).tobytes(), dtype="f4")
        tex.filter = (gl.LINEAR, gl.LINEAR)
        tex.repeat_x, tex.repeat_y = True, False
        self.env_texture = tex
        self._owned.append(tex)
        self._units.append((bindings.TEX_ENVMAP, tex.use))

    def _upload_textures(self) -> None:
        """The materials' textures: image layers and records (scenes without textures bind
        nothing)."""
        from . import textures

        if len(self.packed.textures):
            array, records = textures.upload(self.ctx, self.packed.textures, self.scene.source)
            self.texture_bytes = array.width * array.height * array.layers * 8
            self._owned += [array, records]
            self._units += [(bindings.TEX_TEXTURES, array.use), (bindings.TEX_TEXTURE_RECORDS, records.bind)]

    def _upload_microfacet_tables(self) -> None:
        """The coating table over alpha that per-texel rough plastic reads (scenes with a
        metallicroughness material only)."""
        from ..gl.buffers import BufferTexture
        from .microfacet_tables import alpha_table

        if "metallicroughness" in self.packed.material_kinds:
            tex = BufferTexture(self.ctx, np.ascontiguousarray(alpha_table()).reshape(-1), "r32f",
                                "microfacet tables")
            self._owned.append(tex)
            self._units.append((bindings.TEX_MICROFACET_TABLES, tex.bind))

    def _upload_media_grids(self) -> None:
        """The voxels of heterogeneous media (scenes with such media only)."""
        from ..gl.buffers import BufferTexture

        grids = self.packed.media_grids
        if grids is not None:
            tex = BufferTexture(self.ctx, np.ascontiguousarray(grids, np.float32).reshape(-1), "rgba32f",
                                "media grids")
            self._owned.append(tex)
            self._units.append((bindings.TEX_MEDIA_GRIDS, tex.bind))

    def _upload_mesh(self) -> None:
        """BVH over the static mesh triangles (world space) plus one tree per moving mesh
        (object space), and per-triangle shading data in the BVH's triangle order."""
        from ..accel import MotionInstance, build_bvh
        from ..gl.buffers import BufferTexture
        from .bvh_upload import GpuBvh

        p = self.packed
        if p.mesh is not None:
            positions, normals, uvs, material, light = p.mesh
        else:  # only moving meshes
            positions, normals = np.zeros((0, 3, 3)), np.zeros((0, 3, 3))
            uvs, material, light = np.zeros((0, 3, 2)), np.zeros(0, np.uint32), np.zeros(0, np.uint32)
        motion = [MotionInstance(mm.positions.reshape(-1, 3), np.arange(3 * len(mm.positions)).reshape(-1, 3),
                                 mm.world_from_object_open, mm.world_from_object_close)
                  for mm in p.moving_meshes]
        tri = positions.reshape(-1, 3)
        bvh = build_bvh(tri.astype(np.float32), np.arange(len(tri)).reshape(-1, 3), motion=motion)
        # shading data of every BVH triangle id: the static ones, then each moving mesh's block
        parts = [(normals, uvs, material, light, bvh.prim_order)]
        for mm, mbvh in zip(p.moving_meshes, bvh.motion):
            k = len(mm.positions)
            parts.append((mm.normals, mm.uvs, np.full(k, mm.material, np.uint32), np.zeros(k, np.uint32),
                          mbvh.bvh.prim_order))
        # each part gathered into its rows of the float32 texel arrays (np.take: 2-3x faster
        # than indexing with an index array); uv texels hold u0 v0 u1 v1 | u2 v2 0 0
        total = sum(len(o) for *_, o in parts)
        n4 = np.zeros((total, 3, 4), np.float32)
        uv4 = np.zeros((total, 2, 4), np.float32)
        info = np.zeros((total, 4), np.uint32)
        row = 0
        for n, u, mt, li, o in parts:
            rows = slice(row, row + len(o))
            n4[rows, :, :3] = np.take(n, o, axis=0)
            # one uv triple for every triangle (a mesh without uvs) is broadcast: no gather
            uv4.reshape(total, 8)[rows, :6] = np.reshape(u[0], 6) if u.strides[0] == 0 and len(o) \
                else np.take(u, o, axis=0).reshape(len(o), 6)
            info[rows, 0], info[rows, 1] = np.take(mt, o), np.take(li, o)
            row += len(o)
        self.bvh = GpuBvh(self.ctx, bvh)
        for unit, data, fmt, name in ((bindings.TEX_TRI_NORMALS, n4, "rgba32f", "triangle normals"),
                                      (bindings.TEX_TRI_UVS, uv4, "rgba32f", "triangle uvs"),
                                      (bindings.TEX_TRI_INFO, info, "rgba32ui", "triangle info")):
            tex = BufferTexture(self.ctx, data, fmt, name)
            self._owned.append(tex)
            self._units.append((unit, tex.bind))
