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
from . import bindings, envmap, layout, mesh_cache
from .mesh_cache import DeviceMesh
from .pack import PACKER_VERSION, PackedScene, pack_scene


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
    (a :class:`~glrender.gpu.bvh_upload.GpuBvh`, None without mesh triangles), ``shading``
    (the triangles' normals, uvs and records, each a
    :class:`~glrender.gpu.bvh_upload.PartedTexture`) and the surface and environment
    textures; :meth:`bind` binds them all to their units, and the kernels compile with
    :meth:`defines`.
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
        self.shading: dict[str, Any] = {}
        self.env_texture: Any = None
        self.env_weights: np.ndarray | None = None
        self.texture_bytes = 0              # the atlas pages (RGBA16F) on the device
        # the BVH triangles' normals, uvs and info texels as uploaded (empty: no BVH)
        self.mesh_texels: tuple[np.ndarray, ...] = ()
        self.bvh_cache = "none"             # the BVH: "hit", "miss", "uncached" (accel/bvh_cache.py)
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
        for texture in self.shading.values():
            texture.release()
        if self.bvh is not None:
            self.bvh.release()
        self._owned, self._units, self.bvh, self.shading = [], [], None, {}

    # -- what the kernels read ----------------------------------------------------------------
    def bind(self) -> None:
        """Bind the environment, surface and triangle textures and the BVH to their units."""
        for unit, bind in self._units:
            bind(unit)
        for texture in self.shading.values():
            texture.bind()
        if self.bvh is not None:
            self.bvh.bind()

    def defines(self) -> dict[str, int]:
        """The host defines of the kernels that read this scene's geometry: the kinds of it cut
        into parts (glrender/gpu/bvh_upload.py part_defines; none in a scene that fits one
        buffer texture of each)."""
        from .bvh_upload import part_defines

        if self.bvh is None:
            return {}
        parts = {**self.bvh.parts, **{kind: len(t.parts) for kind, t in self.shading.items()}}
        return part_defines(parts, self.ctx.gl)

    def light_table(self, light_selection: str, area_sampling: str) -> LightTable:
        """The light records and distributions under the settings' light selection
        (``power``: proportional to ``packed.light_weights`` through an alias table, else
        uniform; ``bvh``: the alias table for the light subpaths and the light tree after
        it, shaders/lights/light_selection.glsl) and area sampling (``solid-angle``:
        rectangles are sampled as spherical rectangles, Urena et al. 2013:
        ``bindings.LIGHT_FLAG_RECTANGLE`` in ``info.y``)."""
        from ..sampling.distributions import DistributionPacker
        from ..sampling.light_tree import light_tree_table

        p = self.packed
        lights = p.lights.copy()
        n_lights = len(lights)
        packer = DistributionPacker()
        weights = p.light_weights
        if n_lights:
            if light_selection in ("power", "bvh") and weights.sum() > 0:
                pmf = weights / weights.sum()
            else:
                pmf = np.full(n_lights, 1.0 / n_lights)
            if light_selection in ("power", "bvh") and n_lights > 1:
                packer.add_alias_table(weights if weights.sum() > 0 else pmf)
            lights["selection_pmf"] = pmf
            if light_selection == "bvh":
                packer.add(light_tree_table(light_bounds(lights, weights, p.bounds)))
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
        (object space), and per-triangle shading data in the BVH's triangle order: from the
        device-ready mesh cache on a hit (gpu/mesh_cache.py), else built and gathered here
        and kept there."""
        from .bvh_upload import GpuBvh, PartedTexture, check_triangles

        mesh = self.packed.cached_mesh
        total = len(mesh.texels[2]) if mesh is not None else 0
        if mesh is not None:
            check_triangles(self.ctx.gl, total)   # (a miss checks before building the tree)
            self.bvh_cache = "hit"
        else:
            mesh = self._gather_mesh()
            total = len(mesh.texels[2])
        self.mesh_texels = mesh.texels
        self.bvh = GpuBvh(self.ctx, mesh.bvh)
        for kind, data in zip(("normals", "uvs", "info"), mesh.texels):
            self.shading[kind] = PartedTexture(self.ctx, kind, data, total)

    def mesh_capacity(self) -> dict | None:
        """:func:`~glrender.gpu.capacity.mesh_capacity` of the uploaded BVH triangles (the
        tree's buffers and the triangle texels) with the device's
        :func:`~glrender.gpu.capacity.device_ceiling`, and for instanced meshes the copies and
        the triangles they place; None without BVH triangles."""
        from .capacity import device_ceiling, mesh_capacity

        if self.bvh is None or not len(self.mesh_texels[0]):
            return None
        buffers = {f"bvh {name}": (t.texels, t.nbytes) for name, t in self.bvh.textures.items()}
        buffers.update({f"triangle {kind}": (t.texels, t.nbytes) for kind, t in self.shading.items()})
        capacity = {**mesh_capacity(buffers, len(self.mesh_texels[0])), **device_ceiling(self.ctx.gl)}
        stats = getattr(self.bvh.bvh, "build_stats", None) or self.bvh.bvh.stats()
        if stats.get("static_instances"):
            # instanced meshes: the copies placed and the triangles they draw (each counted)
            capacity["instances"] = int(stats["static_instances"])
            capacity["placed_triangles"] = int(stats["instanced_triangles"]) + \
                len(self.mesh_texels[0]) - int(stats["prototype_triangles"])
        return capacity

    def _gather_mesh(self) -> DeviceMesh:
        """The BVH (accel/bvh_cache.py) and the per-triangle texels in its order; stored in
        the device-ready mesh cache when the scene has a slot there and its BVH triangles
        are static and emit nothing."""
        from ..accel import MotionInstance
        from ..accel.bvh_cache import build_bvh_buffers
        from ..accel.instances import StaticInstances
        from .bvh_upload import check_triangles

        p = self.packed
        if p.mesh is not None:
            positions, normals, uvs, material, light = p.mesh
        else:  # only moving meshes
            positions, normals = np.zeros((0, 3, 3)), np.zeros((0, 3, 3))
            uvs, material, light = np.zeros((0, 3, 2)), np.zeros(0, np.uint32), np.zeros(0, np.uint32)
        motion = [MotionInstance(mm.positions.reshape(-1, 3), np.arange(3 * len(mm.positions)).reshape(-1, 3),
                                 mm.world_from_object_open, mm.world_from_object_close)
                  for mm in p.moving_meshes]
        instanced = None
        if p.instanced_meshes:
            prototypes = [(im.positions.reshape(-1, 3).astype(np.float32),
                           np.arange(3 * len(im.positions)).reshape(-1, 3)) for im in p.instanced_meshes]
            instanced = StaticInstances(
                prototypes, np.concatenate([np.full(len(im.transforms), k)
                                            for k, im in enumerate(p.instanced_meshes)]),
                np.concatenate([im.transforms for im in p.instanced_meshes]))
        check_triangles(self.ctx.gl, len(positions) + sum(len(mm.positions) for mm in p.moving_meshes)
                        + sum(len(im.positions) for im in p.instanced_meshes))
        tri = positions.reshape(-1, 3)
        bvh, self.bvh_cache = build_bvh_buffers(tri.astype(np.float32), np.arange(len(tri)).reshape(-1, 3),
                                                motion=motion, instanced=instanced)
        # shading data of every BVH triangle id: the static ones, then each moving mesh's
        # block, then each instanced mesh's
        parts = [(normals, uvs, material, light, bvh.prim_orders[0])]
        for mesh, order in zip(p.moving_meshes + p.instanced_meshes, bvh.prim_orders[1:]):
            k = len(mesh.positions)
            parts.append((mesh.normals, mesh.uvs, np.full(k, mesh.material, np.uint32),
                          np.zeros(k, np.uint32), order))
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
        mesh = DeviceMesh(bvh, (n4, uv4, info))
        if p.mesh_slot is not None and not p.moving_meshes and not light.any():
            mesh_cache.store(p.mesh_slot, PACKER_VERSION, mesh, p.mesh_shapes, p.mesh_bounds)
        return mesh


def light_bounds(lights: np.ndarray, weights: np.ndarray, scene_bounds):
    """The light tree's bounds of each packed light record (glrender.sampling.light_tree):
    boxes, intensities (a planar light's power weight over pi, per side; a sphere's over
    4 pi, its radiance times its cross-section; a point or spot light's intensity) and
    emission cones (a surface's normal, theta_e = pi/2; a spot's beam, theta_e to its
    cutoff; the whole sphere for points and spheres); for lights at infinity the
    irradiance they deliver, from the power weights glrender.gpu.pack gives them over the
    scene's bounding sphere (radius R): a directional light's pi R^2 E, an environment's
    4 pi^2 R^2 times its mean radiance L, which delivers pi L. Their ``offset``: where
    light_table packs the tree, after select_light's alias table (1 + 3n elements for n > 1
    lights; shaders/lights/light_selection.glsl light_tree_offset)."""
    from ..sampling.light_tree import LightBounds

    kinds = {v: k for k, v in layout.LIGHT_KINDS.items()}
    n = len(lights)
    b = LightBounds(lo=np.zeros((n, 3)), hi=np.zeros((n, 3)), phi=np.zeros(n), w=np.zeros((n, 3)),
                    cos_o=np.full(n, -1.0), cos_e=np.zeros(n), two_sided=np.zeros(n, bool),
                    infinite=np.zeros(n, bool), offset=1 + 3 * n if n > 1 else 0)
    b.w[:, 2] = 1.0
    lo, hi = (np.asarray(v, np.float64) for v in scene_bounds)
    radius = float(max(np.linalg.norm(hi - lo) / 2, 1e-3))
    for i, rec in enumerate(lights):
        kind = kinds[int(rec["info"][0])]
        p, e1, e2 = (rec[f][:3].astype(np.float64) for f in ("p", "e1", "e2"))
        two_sided = bool(int(rec["info"][1]) & bindings.LIGHT_FLAG_TWO_SIDED)
        intensity = float(np.dot(rec["radiance"][:3], (0.2126, 0.7152, 0.0722)))
        if kind in ("parallelogram", "triangle"):
            corners = [p, p + e1, p + e2] + ([p + e1 + e2] if kind == "parallelogram" else [])
            b.lo[i], b.hi[i] = np.min(corners, axis=0), np.max(corners, axis=0)
            b.phi[i] = weights[i] / (np.pi * (2 if two_sided else 1))
            b.w[i] = rec["n"][:3]
            b.cos_o[i] = 1.0
            b.two_sided[i] = two_sided
        elif kind == "sphere":
            r = float(rec["e1"][3])
            b.lo[i], b.hi[i] = p - r, p + r
            b.phi[i] = weights[i] / (4 * np.pi)
        elif kind in ("point", "spot"):
            b.lo[i] = b.hi[i] = p
            b.phi[i] = intensity
            if kind == "spot":
                cos_cutoff, cos_beam = (float(c) for c in rec["params"][:2])
                b.w[i] = rec["n"][:3]
                b.cos_o[i] = cos_beam
                b.cos_e[i] = np.cos(max(np.arccos(np.clip(cos_cutoff, -1, 1)) - np.arccos(np.clip(cos_beam, -1, 1)), 0.0))
        else:
            b.infinite[i] = True
            if kind == "directional":
                b.phi[i] = weights[i] / (np.pi * radius ** 2)
                b.w[i] = rec["n"][:3]
                b.cos_o[i] = 1.0
            else:   # constant, envmap
                b.phi[i] = weights[i] / (4 * np.pi * radius ** 2)
    return b
