"""Turn a :class:`~glrender.scene.model.Scene` into what the device reads.

Geometry splits two ways, decided per shape:

- *Compiled primitives*: rectangles and cube faces (intersected as parallelograms,
  1.8x faster than two triangles on llvmpipe), spheres, and the triangles of small
  flat meshes become constants in generated GLSL (``glrender/gpu/codegen.py``):
  the compiler folds the zero components of axis-aligned quads, which measured up
  to 8x faster than fetching the same data from a buffer.
- *BVH triangles*: every other mesh, flattened into world space, with per-triangle
  shading data in BVH order. A mesh placed several times (``Shape.instances``) whose copies
  beyond the first hold :data:`INSTANCE_MIN_TRIANGLES` triangles or more keeps one copy of
  its triangles, which the copies share through a two-level BVH
  (:mod:`glrender.accel.instances`); smaller ones are flattened.

Materials and lights become std430 arrays (``glrender/gpu/layout.py``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from ..scene import model as m
from . import bindings, layout
from .mesh_cache import DeviceMesh, MeshSlot, lookup
from .textures import TextureTable

NO_PRIMITIVE = 0xFFFFFFFF        # geometry/surface.glsl kNoPrimitive
MAX_COMPILED_TRIANGLES_PER_MESH = 32
MAX_COMPILED_PRIMITIVES = 96
# The version of the BVH triangles' arrays (MeshSoup, and the texels device_scene.py gathers
# from them): the device-ready mesh cache (gpu/mesh_cache.py) keys its entries by it, so bump
# it with any change that alters a bit of them.
PACKER_VERSION = 1
# The copies of an instanced mesh share one bottom-level tree instead of being flattened when
# the copies beyond the first hold this many triangles or more. benchmarks/instancing.py
# measured the second level's traversal cost within the noise (2 to 32 trees of 104,448
# triangles), while each flattened copy costs its BVH build (~0.2 s per 100k triangles) and
# ~170 device bytes per triangle: below this count those costs are negligible (as for the
# BVH cache, accel/bvh_cache.py MIN_TRIANGLES), and small meshes keep the one-level tree
# (and the compiled primitives for the smallest).
INSTANCE_MIN_TRIANGLES = 1 << 15

# The six faces of Mitsuba's cube [-1, 1]^3 as (corner, e1, e2): corner + u e1 + v e2 has the
# texture coordinates (u, v) of Mitsuba's cube mesh; on every face e1 x e2 points inward
# (the outward normal is -(e1 x e2)).
_CUBE_FACES = (
    ((-1, -1, -1), (0, 0, 2), (2, 0, 0)), ((1, 1, 1), (-2, 0, 0), (0, 0, -2)),
    ((1, -1, 1), (0, 2, 0), (0, 0, -2)), ((-1, -1, 1), (0, 2, 0), (2, 0, 0)),
    ((-1, -1, -1), (0, 2, 0), (0, 0, 2)), ((-1, 1, -1), (0, -2, 0), (2, 0, 0)),
)


@dataclass
class Parallelogram:
    corner: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    material: int
    light: int = 0          # area light index + 1
    triangle: bool = False  # a triangle corner + a e1 + b e2, a + b <= 1
    uv: np.ndarray | None = None  # 3x2: uv at corner, and its change along e1 and e2
    flip: bool = False      # the front faces -(e1 x e2) (flip_normals, or a mirroring transform)

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.e1, self.e2)
        return (-n if self.flip else n) / np.linalg.norm(n)

    @property
    def area(self) -> float:
        a = float(np.linalg.norm(np.cross(self.e1, self.e2)))
        return 0.5 * a if self.triangle else a


@dataclass
class Sphere:
    center: np.ndarray
    radius: float
    material: int
    light: int = 0
    center_close: np.ndarray | None = None
    flip: bool = False


@dataclass
class MeshSoup:
    """World-space triangles that go into the BVH, with their shading data."""

    positions: list = field(default_factory=list)   # (T, 3, 3)
    normals: list = field(default_factory=list)     # (T, 3, 3) unit vertex normals
    uvs: list = field(default_factory=list)         # (T, 3, 2)
    material: list = field(default_factory=list)    # (T,)
    light: list = field(default_factory=list)       # (T,) light index + 1
    shapes: list = field(default_factory=list)      # the scene's index of each mesh
    bounds: list = field(default_factory=list)      # each mesh's (lo, hi)

    def arrays(self):
        if not self.positions:
            return None
        def cat(parts):       # one mesh: its own arrays, no copy
            return parts[0] if len(parts) == 1 else np.concatenate(parts)
        return (cat(self.positions), cat(self.normals), cat(self.uvs),
                cat(self.material).astype(np.uint32), cat(self.light).astype(np.uint32))


@dataclass
class MovingMesh:
    """A mesh in rigid motion over the shutter: object-space triangles and shading data
    (its own BVH in the renderer) and its transforms at shutter open and close."""

    positions: np.ndarray     # (T, 3, 3) object space
    normals: np.ndarray       # (T, 3, 3) object space
    uvs: np.ndarray           # (T, 3, 2)
    material: int
    world_from_object_open: np.ndarray
    world_from_object_close: np.ndarray


@dataclass
class InstancedMesh:
    """A mesh drawn at many places through one bottom-level tree: its triangles and shading
    data in the space its copies' transforms map to the world (the shape's own transform
    applied), and those transforms."""

    positions: np.ndarray     # (T, 3, 3)
    normals: np.ndarray       # (T, 3, 3)
    uvs: np.ndarray           # (T, 3, 2)
    material: int
    transforms: np.ndarray    # (K, 3, 4) world_from_object of each copy

    def world_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(K, 3) lo and hi: each copy's world box."""
        from ..accel.instances import instance_world_bounds

        return instance_world_bounds(self.transforms, *m.point_bounds(self.positions))


@dataclass
class PackedScene:
    quads: list[Parallelogram]
    spheres: list[Sphere]
    mesh: tuple | None                      # (positions, normals, uvs, material, light) or None
    materials: np.ndarray                   # layout.MATERIAL
    lights: np.ndarray                      # layout.LIGHT
    light_weights: np.ndarray               # selection weights (power), one per light
    bounds: tuple[np.ndarray, np.ndarray]   # world AABB of all geometry
    material_kinds: set[str]
    light_kinds: set[str]
    environment: int                        # index + 1 of the environment light, 0 if none
    env_image: np.ndarray | None = None     # H x W x 3 linear RGB of an envmap light
    moving_meshes: list = field(default_factory=list)   # MovingMesh, for motion blur
    media: np.ndarray | None = None         # layout.MEDIA record; None: no shape or camera names a medium
    media_grids: np.ndarray | None = None   # (N, 4) float32 voxels of heterogeneous media (TEX_MEDIA_GRIDS)
    # the BVH triangles' (lo, hi), moving meshes aside; their place in the device-ready mesh
    # cache (None: not cached), which on a hit holds them instead of ``mesh``; and the
    # scene's indices of the shapes they came from
    mesh_bounds: tuple[np.ndarray, np.ndarray] | None = None
    mesh_slot: MeshSlot | None = None
    mesh_shapes: list[int] = field(default_factory=list)
    instanced_meshes: list = field(default_factory=list)   # InstancedMesh, shared by their copies

    @property
    def has_media(self) -> bool:
        return self.media is not None

    @property
    def has_bvh(self) -> bool:
        return self.mesh is not None or self.cached_mesh is not None or bool(self.moving_meshes) \
            or bool(self.instanced_meshes)

    @property
    def cached_mesh(self) -> DeviceMesh | None:
        """The BVH triangles as the device reads them, when the cache held them."""
        return self.mesh_slot.mesh if self.mesh_slot is not None else None
    textures: TextureTable = field(default_factory=TextureTable)  # materials' textures

    @property
    def sphere_bounds(self) -> tuple[np.ndarray, float]:
        lo, hi = self.bounds
        center = 0.5 * (lo + hi)
        return center, float(max(np.linalg.norm(hi - center), 1e-3))


def _rgb(value, what: str) -> np.ndarray:
    if isinstance(value, m.Texture):
        raise SceneError(f"{what}: textures are not supported here")
    arr = np.asarray(value, np.float64).reshape(-1)
    if arr.size == 1:
        arr = np.repeat(arr, 3)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise SceneError(f"{what}: expected an RGB triple of finite numbers, got {value!r}")
    return arr


def _luminance(rgb) -> float:
    r, g, b = rgb
    return 0.212671 * r + 0.715160 * g + 0.072169 * b


def _spectrum_mean(value) -> float:
    """Mitsuba's Texture::mean(): the average over channels (and texels) of a colour."""
    if isinstance(value, m.Texture):
        if value.kind == "bitmap" and value.image is not None:
            return float(np.mean(np.asarray(value.image, np.float64)[..., :3]))
        return 0.5 * (float(np.mean(value.color0)) + float(np.mean(value.color1)))
    return float(np.mean(np.asarray(value, np.float64)))


def _texture_mean_rgb(texture: m.Texture) -> np.ndarray:
    """The mean colour of a texture over its texels (a checkerboard: of its two colours)."""
    if texture.kind == "bitmap" and texture.image is not None:
        image = np.asarray(texture.image, np.float64)
        image = image.reshape(-1, image.shape[-1]) if image.ndim == 3 else image.reshape(-1, 1)
        return np.resize(image[:, :3].mean(axis=0), 3) if image.shape[1] >= 3 else \
            np.full(3, image.mean())
    return 0.5 * (np.asarray(texture.color0, np.float64) + np.asarray(texture.color1, np.float64))


def _specular_sampling_weight(mat: m.Material) -> float:
    """Mitsuba's plastic lobe weight: mean(specular) / (mean(diffuse) + mean(specular))."""
    s, d = _spectrum_mean(mat.specular_reflectance), _spectrum_mean(mat.reflectance)
    return s / (d + s) if d + s > 0 else 0.5


def _color(value, what: str, textures: TextureTable | None) -> tuple[np.ndarray, int]:
    """(constant RGB, texture index + 1) of a material colour: a texture's constant part
    is its mean (used where a single value is needed), its index goes to the record."""
    if isinstance(value, m.Texture):
        if textures is None:
            raise SceneError(f"{what}: textures are not supported here")
        return np.full(3, _spectrum_mean(value)), textures.index(value, what)
    return _rgb(value, what), 0


def pack_material(mat: m.Material, textures: TextureTable | None = None) -> np.ndarray:
    """One MaterialData record (scene/layout.glsl) for the BSDFs of shaders/bsdf/.

    Per kind: diffuse (c0 reflectance); conductors (c0 eta, c1 specular reflectance,
    c2 k); dielectrics (c0 specular reflectance, c1 specular transmittance; two-sided
    by nature, so the two_sided flag is dropped, as Mitsuba's twosided rejects them);
    plastics (c0 diffuse reflectance, c1 specular reflectance, c2.x specular sampling
    weight, c2.y internal diffuse reflectance of the coating; roughplastic also the
    transmittance table); metallicroughness (c0 base colour, c1 (-, roughness,
    metallic), c2 as plastic's). params: alpha (clamped to >= 1e-4 as in Mitsuba), eta.
    Textured colours (``m.Texture``) are numbered in ``textures``; info.z and info.w hold
    the texture index + 1 of color0 and color1 (0: the constant colour).
    """
    from .microfacet_tables import external_transmittance, internal_reflectance

    out = np.zeros(1, layout.MATERIAL)[0]
    kind = mat.kind
    transmissive = kind in ("dielectric", "roughdielectric", "thindielectric")
    flags = (bindings.MATERIAL_FLAG_TWO_SIDED if mat.two_sided and not transmissive else 0) | \
        (bindings.MATERIAL_FLAG_GGX if mat.distribution == "ggx" else 0) | \
        (bindings.MATERIAL_FLAG_NONLINEAR if mat.nonlinear else 0)
    if mat.normal_map is not None:
        flags |= (bindings.MATERIAL_FLAG_NORMAL_SHADOWING if mat.normal_shadowing else 0) | \
            (bindings.MATERIAL_FLAG_NORMAL_FLIP if mat.normal_flip else 0)
    what = f"material {mat.name or '?'}"
    if mat.int_ior <= 0 or mat.ext_ior <= 0:
        raise SceneError(f"{what}: int_ior and ext_ior must be positive")
    eta = mat.int_ior / mat.ext_ior
    if kind == "metallicroughness":
        from ..scene.loaders.pbr import PLASTIC_IOR

        eta = PLASTIC_IOR     # the rule's plastic, whose coating the table over alpha holds
    alpha = np.asarray(mat.alpha, np.float64).reshape(-1)
    if alpha.size == 1:
        alpha = np.repeat(alpha, 2)
    if alpha.size != 2 or np.any(alpha <= 0) or np.any(~np.isfinite(alpha)):
        raise SceneError(f"{what}.alpha: expected positive roughness, got {mat.alpha!r}")
    alpha = np.maximum(alpha, 1e-4)
    tex0 = tex1 = 0
    if kind == "diffuse":
        out["color0"][:3], tex0 = _color(mat.reflectance, f"{what}.reflectance", textures)
    elif kind in ("conductor", "roughconductor"):
        out["color0"][:3] = _rgb(mat.eta, f"{what}.eta")
        out["color1"][:3], tex1 = _color(mat.specular_reflectance, f"{what}.specular_reflectance",
                                         textures)
        out["color2"][:3] = _rgb(mat.k, f"{what}.k")
    elif transmissive:
        out["color0"][:3], tex0 = _color(mat.specular_reflectance, f"{what}.specular_reflectance",
                                         textures)
        out["color1"][:3], tex1 = _color(mat.specular_transmittance,
                                         f"{what}.specular_transmittance", textures)
        if kind == "roughdielectric" and eta == 1.0:
            raise SceneError(f"{what}: int_ior and ext_ior must differ for a rough dielectric")
    elif kind in ("plastic", "roughplastic"):
        out["color0"][:3], tex0 = _color(mat.reflectance, f"{what}.reflectance", textures)
        out["color1"][:3], tex1 = _color(mat.specular_reflectance, f"{what}.specular_reflectance",
                                         textures)
        out["color2"][0] = _specular_sampling_weight(mat)
        if kind == "plastic":
            out["color2"][1] = _fresnel_diffuse_reflectance(1.0 / eta)
        else:
            if alpha[0] != alpha[1]:
                raise SceneError(f"{what}.alpha: roughplastic is isotropic (one alpha), as in "
                                 f"Mitsuba; got {mat.alpha!r}")
            if eta == 1.0:
                raise SceneError(f"{what}: int_ior and ext_ior must differ for roughplastic")
            ggx = mat.distribution == "ggx"
            out["table"] = external_transmittance(alpha[0], eta, ggx)
            out["color2"][1] = internal_reflectance(alpha[0], eta, ggx)
    elif kind == "metallicroughness":
        # chosen per surface point (bsdf/metallic_roughness.glsl): color0 the base colour,
        # color1 (-, roughness, metallic), color2 the plastic's sampling weight and Fdr_int
        # (its smooth coating; the rough one's come from the table over alpha)
        out["color0"][:3], tex0 = _color(mat.reflectance, f"{what}.reflectance", textures)
        out["color1"][:3], tex1 = _color(mat.metallic_roughness, f"{what}.metallic_roughness",
                                         textures)
        out["color2"][0] = _specular_sampling_weight(mat)
        out["color2"][1] = _fresnel_diffuse_reflectance(1.0 / eta)
        flags |= bindings.MATERIAL_FLAG_GGX
    out["params"] = (alpha[0], alpha[1], eta)
    out["info"] = (layout.MATERIAL_KINDS[kind], flags, tex0, tex1)
    for name in ("normal_map", "opacity"):
        tex = getattr(mat, name)
        if tex is not None and (textures is None or not isinstance(tex, m.Texture)):
            raise SceneError(f"{what}.{name}: expected a texture")
    if mat.normal_map is not None:
        out["normal_map"] = textures.index(mat.normal_map, f"{what}.normal_map")
        if not np.isfinite(mat.normal_scale):
            raise SceneError(f"{what}.normal_scale: expected a finite number")
        out["normal_scale"] = mat.normal_scale
    if mat.opacity is not None:
        if not 0.0 <= mat.alpha_cutoff <= 1.0:
            raise SceneError(f"{what}.alpha_cutoff: expected a number in [0, 1], "
                             f"got {mat.alpha_cutoff!r}")
        out["opacity_texture"] = textures.index(mat.opacity, f"{what}.opacity")
        out["alpha_cutoff"] = mat.alpha_cutoff
    return out


def material_kinds(materials: list[m.Material]) -> set[str]:
    """The material kinds the device meets: each material's, and for a metallicroughness
    material every kind its metallic and roughness values can pick (bilinear filtering
    stays within the texels' range; the range of the half floats the device reads)."""
    from ..scene.loaders.pbr import metallic_roughness_kinds

    kinds = {mat.kind for mat in materials}
    for mat in materials:
        if mat.kind != "metallicroughness":
            continue
        value = mat.metallic_roughness
        if isinstance(value, m.Texture):
            if value.kind == "bitmap" and value.image is not None:
                texels = np.asarray(value.image, np.float32).reshape(-1, np.shape(value.image)[-1])
            else:
                texels = np.array([value.color0, value.color1], np.float32)
            texels = texels.astype(np.float16).astype(np.float64)
        else:
            texels = np.asarray(value, np.float64).reshape(1, -1)
        if texels.shape[-1] < 3:
            texels = np.repeat(texels[:, :1], 3, axis=1)
        kinds |= metallic_roughness_kinds((texels[:, 2].min(), texels[:, 2].max()),
                                          (texels[:, 1].min(), texels[:, 1].max()))
    return kinds


def _fresnel_diffuse_reflectance(eta: float) -> float:
    """Fdr: the hemispherical (cosine-weighted) average of the dielectric Fresnel
    reflectance on the side of relative IOR eta, by Mitsuba's fits: Egan & Hilgeman
    (1973) for eta < 1, d'Eon & Irving (2011) otherwise (within 0.6% of the integral
    for eta in [1/2, 1/1.05] and [1.05, 3]: tests/bsdf/test_materials.py)."""
    if eta < 1.0:
        return 0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
    x = 1.0 / eta
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 + x * -1.36881))))


def _grid_texels(volume: m.Volume, what: str) -> np.ndarray:
    """A grid's voxels as RGBA texels, x fastest (a one-channel grid repeats its value)."""
    data = np.asarray(volume.data, np.float32)
    if data.ndim != 4 or data.shape[3] not in (1, 3):
        raise SceneError(f"{what}: expected a grid of 1 or 3 channels, got shape {data.shape}")
    flat = data.reshape(-1, data.shape[3])
    texels = np.zeros((len(flat), 4), np.float32)
    texels[:, :3] = flat if flat.shape[1] == 3 else np.repeat(flat, 3, axis=1)
    return texels


def supervoxel_majorants(values: np.ndarray, scale: float) -> np.ndarray:
    """Per supervoxel (layout.SUPERVOXEL voxels a side) of a grid of (Z, Y, X) voxel values
    (each its largest channel): a bound on what a lookup inside it returns, times ``scale``.
    A trilinear lookup reads voxels half a voxel beyond the supervoxel, so each bound takes
    the largest value of its voxels and a one-voxel apron around them (clamped at the
    grid's edges, as the lookups are). Returns (SZ, SY, SX)."""
    v = np.asarray(values, np.float64)
    for axis in range(3):    # the apron: the largest of each voxel's neighbours along each axis
        padded = np.concatenate([np.take(v, [0], axis), v, np.take(v, [-1], axis)], axis=axis)
        n = v.shape[axis]
        v = np.maximum(np.maximum(np.take(padded, range(0, n), axis), np.take(padded, range(1, n + 1), axis)),
                       np.take(padded, range(2, n + 2), axis))
    s = layout.SUPERVOXEL
    counts = [-(-n // s) for n in v.shape]
    v = np.pad(v, [(0, c * s - n) for c, n in zip(counts, v.shape)], mode="edge")
    blocks = v.reshape(counts[0], s, counts[1], s, counts[2], s).max(axis=(1, 3, 5))
    return blocks * scale


def pack_medium(med: m.Medium, where: str, grids: list[np.ndarray]) -> np.ndarray:
    """One layout.MEDIUM record: extinction (times scale), scattering, phase function; a
    heterogeneous medium's grids are appended to ``grids`` (their texels' offsets counted
    from the texels already there) with its majorant."""
    rec = np.zeros(1, layout.MEDIUM)[0]
    g = med.g if med.phase == "hg" else 0.0
    flags = bindings.MEDIUM_FLAG_SAMPLE_EMITTERS if med.sample_emitters else 0
    if med.kind == "homogeneous":
        if isinstance(med.sigma_t, m.Volume) or isinstance(med.albedo, m.Volume):
            raise SceneError(f"{where}: a homogeneous medium with a grid: make it heterogeneous")
        sigma_t = _rgb(med.sigma_t, "sigma_t") * float(med.scale)
        rec["sigma_t"] = (*sigma_t, g)
        rec["sigma_s"][:3] = _rgb(med.albedo, "albedo") * sigma_t
        rec["majorant"][1] = float(np.mean(sigma_t))
    else:
        volume = med.sigma_t
        if not isinstance(volume, m.Volume):
            volume = m.Volume(np.asarray(_rgb(volume, "sigma_t"), np.float32).reshape(1, 1, 1, 3))
        first = sum(len(t) for t in grids)
        texels = _grid_texels(volume, f"{where}: sigma_t")
        grids.append(texels)
        x, y, z = volume.resolution
        rec["sigma_grid"] = (first, x, y, z)
        rec["grid_from_world"] = np.linalg.inv(np.asarray(volume.world_from_object, np.float64)).T
        scale = float(med.scale)
        rec["sigma_t"] = (scale, scale, scale, g)
        rec["majorant"][0] = scale * float(texels[:, :3].max(initial=0.0))
        rec["majorant"][1] = scale * float(texels[:, :3].mean()) if len(texels) else 0.0
        bounds = supervoxel_majorants(texels[:, :3].max(axis=1).reshape(z, y, x), scale)
        first = sum(len(t) for t in grids)
        grids.append(np.repeat(bounds.reshape(-1, 1), 4, axis=1).astype(np.float32))
        sz, sy, sx = bounds.shape
        rec["majorant_grid"] = (first, sx, sy, sz)
        if volume.filter == "nearest":
            flags |= bindings.MEDIUM_FLAG_NEAREST
        if isinstance(med.albedo, m.Volume):
            if med.albedo.resolution != volume.resolution or not np.allclose(
                    med.albedo.world_from_object, volume.world_from_object):
                raise SceneError(f"{where}: the albedo grid must have the sigma_t grid's voxels "
                                 f"and placement (to_world)")
            first = sum(len(t) for t in grids)
            grids.append(_grid_texels(med.albedo, f"{where}: albedo"))
            rec["albedo_grid"] = (first + 1, x, y, z)
        else:
            rec["sigma_s"][:3] = _rgb(med.albedo, "albedo")
    rec["info"] = (layout.MEDIUM_KINDS[med.kind], layout.PHASE_KINDS[med.phase], flags, 0)
    return rec


def _media_variants(scene: m.Scene) -> tuple[m.Scene, np.ndarray | None, list[int], np.ndarray | None]:
    """Scenes whose shapes or camera name media: the scene with a material record of its own
    for each (material, interior, exterior) of the shapes that bound media, the media's
    layout.MEDIA record, each material's medium bits (bindings.MATERIAL_INTERIOR_SHIFT) and
    the heterogeneous media's grid texels (None: no grids). Other scenes: themselves, None,
    no bits and None."""
    if not scene.has_media:
        return scene, None, [], None
    if len(scene.media) > layout.MAX_MEDIA:
        raise SceneError(f"{scene.source}: {len(scene.media)} media, at most {layout.MAX_MEDIA}")
    rec = np.zeros(1, layout.MEDIA)[0]
    grids: list[np.ndarray] = []
    for k, med in enumerate(scene.media):
        rec["media"][k] = pack_medium(med, f"{scene.source}: medium {med.name or k}", grids)
    camera = scene.camera.medium
    rec["media_counts"] = (len(scene.media), 0 if camera is None else camera + 1, 0, 0)
    materials = list(scene.materials)
    bits = [0] * len(materials)
    variants: dict[tuple, int] = {}
    shapes = []
    for shape in scene.shapes:
        if shape.interior is None and shape.exterior is None:
            shapes.append(shape)
            continue
        key = (shape.material, shape.interior, shape.exterior)
        if key not in variants:
            variants[key] = len(materials)
            materials.append(scene.materials[shape.material])
            inside = 0 if shape.interior is None else shape.interior + 1
            outside = 0 if shape.exterior is None else shape.exterior + 1
            bits.append((inside << bindings.MATERIAL_INTERIOR_SHIFT) |
                        (outside << bindings.MATERIAL_EXTERIOR_SHIFT))
        shapes.append(dataclasses.replace(shape, material=variants[key]))
    texels = np.concatenate(grids) if grids else None
    return dataclasses.replace(scene, materials=materials, shapes=shapes), rec, bits, texels


def _transform_mesh(shape: m.Shape, where: str):
    v = np.asarray(shape.vertices, np.float64)
    f = np.asarray(shape.triangles, np.int64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise SceneError(f"{where}: vertices must have shape (V, 3), got {v.shape}")
    if f.size and (f.ndim != 2 or f.shape[1] != 3):
        raise SceneError(f"{where}: triangles must have shape (T, 3), got {f.shape}")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise SceneError(f"{where}: a triangle refers to a vertex index outside [0, {len(v)})")
    if not np.all(np.isfinite(v)):
        raise SceneError(f"{where}: vertices contain NaN or infinite coordinates")
    M = shape.world_from_object
    wv = m.transform_points(M, v)
    flip = shape.flip_normals != (np.linalg.det(M[:3, :3]) < 0)
    if flip:
        f = f[:, [0, 2, 1]]
    # np.take gathers rows 2-3x faster than indexing with an index array (numpy 2.x)
    tri = np.take(wv, f, axis=0)                         # (T, 3, 3)
    ng = np.stack(m.face_normals(m.triangle_edges(wv, f)), axis=1)
    length = np.linalg.norm(ng, axis=1)
    keep = length > 0
    ng = ng / np.where(length > 0, length, 1)[:, None]
    if shape.normals is not None and not shape.face_normals:
        vn = m.transform_normals(M, np.asarray(shape.normals, np.float64))
        if shape.flip_normals:
            vn = -vn
        normals = np.take(vn, f, axis=0)
        # per vertex, then per triangle: the same test as on the (T, 3, 3) corners, 3x less work
        bad_vertex = ~np.isfinite(vn).all(axis=1) | (np.linalg.norm(vn, axis=1) < 0.5)
        if bad_vertex.any():
            bad = np.take(bad_vertex, f).any(axis=1)
            normals[bad] = ng[bad][:, None, :]
    else:
        normals = np.repeat(ng[:, None, :], 3, axis=1)
    if shape.uvs is not None:
        uvs = np.take(np.asarray(shape.uvs, np.float64), f, axis=0)
    else:
        uvs = np.broadcast_to(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), (len(f), 3, 2))
    if keep.all():
        return tri, normals, uvs, ng
    return tri[keep], normals[keep], uvs[keep], ng[keep]


def shares_tree(shape: m.Shape) -> bool:
    """Whether the copies of an instanced mesh share one bottom-level tree: unless it emits
    (each triangle of each copy is a light) or its copies beyond the first hold fewer than
    INSTANCE_MIN_TRIANGLES triangles (they are flattened)."""
    extra = (len(shape.instances) - 1) * (np.size(shape.triangles) // 3)
    return shape.emission is None and extra >= INSTANCE_MIN_TRIANGLES


def _placed_shapes(shapes: list[m.Shape]):
    """(scene index, shape) of every shape to pack: an instanced mesh whose copies do not
    share a tree (:func:`shares_tree`) as its copies, each a shape of its own; other shapes
    as they are."""
    for index, shape in enumerate(shapes):
        if shape.instances is not None and not shares_tree(shape):
            for t in np.asarray(shape.instances, np.float64):
                yield index, dataclasses.replace(shape, instances=None,
                                                 world_from_object=t @ shape.world_from_object)
        else:
            yield index, shape


def pack_scene(scene: m.Scene) -> PackedScene:
    """Flatten a scene into compiled primitives, BVH triangles, materials and lights."""
    scene.validate()
    scene, media, medium_bits, media_grids = _media_variants(scene)
    slot = lookup(scene, PACKER_VERSION)
    cached = slot.shapes if slot is not None and slot.mesh is not None else frozenset()
    quads: list[Parallelogram] = []
    spheres: list[Sphere] = []
    soup = MeshSoup()
    lights: list[np.ndarray] = []
    weights: list[float] = []
    textures = TextureTable()
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)

    def grow(points):
        nonlocal lo, hi
        p = np.asarray(points, np.float64).reshape(-1, 3)
        if len(p):
            p_lo, p_hi = m.point_bounds(p)
            lo, hi = np.minimum(lo, p_lo), np.maximum(hi, p_hi)

    def add_area_light(kind, emission: m.Emission, uv=None, **fields):
        """uv: 3x2, the uv at p and its change along e1 and e2 (textured emission)."""
        rec = np.zeros(1, layout.LIGHT)[0]
        radiance = _rgb(emission.radiance, "emission.radiance")
        for key, value in fields.items():
            rec[key][:len(value)] = value
        rec["radiance"][:3] = radiance
        flags = bindings.LIGHT_FLAG_TWO_SIDED if emission.two_sided else 0
        rec["info"] = (layout.LIGHT_KINDS[kind], flags, NO_PRIMITIVE, 0)
        area = float(rec["n"][3])
        power_radiance = radiance
        if emission.texture is not None:
            # the radiance at a point is the texel's there (lights/light.glsl); selection by
            # power takes the texture's mean over its texels
            if kind == "sphere":
                raise SceneError(f"{scene.source}: textured emission applies to meshes and "
                                 f"rectangles, not to spheres")
            rec["emission_texture"] = textures.index(emission.texture, "emission.texture")
            rec["uv0"], rec["uv_e1"], rec["uv_e2"] = (np.array([[0, 0], [1, 0], [0, 1]])
                                                      if uv is None else np.asarray(uv))
            power_radiance = radiance * _texture_mean_rgb(emission.texture)
        weights.append(math.pi * area * _luminance(power_radiance) * (2 if emission.two_sided else 1))
        lights.append(rec)
        return len(lights)  # index + 1

    def add_quad(q: Parallelogram, emission):
        if emission is not None:
            q.light = add_area_light("triangle" if q.triangle else "parallelogram", emission,
                                     uv=q.uv, p=q.corner, e1=q.e1, e2=q.e2,
                                     n=(*q.normal, q.area))
            lights[-1]["info"][2] = len(quads)   # its primitive id
        quads.append(q)
        grow([q.corner, q.corner + q.e1, q.corner + q.e2, q.corner + q.e1 + q.e2])

    compiled_budget = MAX_COMPILED_PRIMITIVES
    sphere_lights: list[tuple[int, int]] = []   # (light index, sphere index)
    moving: list[MovingMesh] = []
    instanced: list[InstancedMesh] = []
    for index, shape in _placed_shapes(scene.shapes):
        where = f"{scene.source}: shape {shape.name or index}"
        M = shape.world_from_object
        flip = shape.flip_normals != (np.linalg.det(M[:3, :3]) < 0)
        if shape.kind != "mesh" and 0 <= shape.material < len(scene.materials) and \
                scene.materials[shape.material].opacity is not None:
            # cutouts are tested in the BVH traversal: a rectangle becomes its two triangles
            # (Mitsuba's uv: u along +x, v along +y)
            if shape.kind != "rectangle" or shape.emission is not None:
                raise SceneError(f"{where}: opacity cutouts apply to meshes and rectangles that "
                                 f"are not lights, not to a {shape.kind}"
                                 f"{' light' if shape.emission is not None else ''}")
            shape = dataclasses.replace(
                shape, kind="mesh", vertices=np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0],
                                                       [-1, 1, 0]], np.float64),
                triangles=np.array([[0, 1, 2], [0, 2, 3]]), normals=None,
                uvs=np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float64), face_normals=True)
        if shape.kind in ("rectangle", "cube"):
            if shape.moving:
                raise SceneError(f"{where}: motion is supported for spheres and meshes; "
                                 f"make the {shape.kind} a mesh to move it")
            faces = _CUBE_FACES if shape.kind == "cube" else (((-1, -1, 0), (2, 0, 0), (0, 2, 0)),)
            inward = shape.kind == "cube"   # see _CUBE_FACES
            for corner, e1, e2 in faces:
                c = m.transform_points(M, np.array(corner, np.float64))
                a = M[:3, :3] @ np.array(e1, np.float64)
                b = M[:3, :3] @ np.array(e2, np.float64)
                if np.linalg.norm(np.cross(a, b)) == 0:
                    raise SceneError(f"{where}: the transform collapses the {shape.kind} to zero area")
                # flipping turns the normal, not the parametrization: uv stay as Mitsuba's
                add_quad(Parallelogram(c, a, b, shape.material, flip=flip != inward), shape.emission)
                compiled_budget -= 1
        elif shape.kind == "sphere":
            center = m.transform_points(M, np.array(shape.center, np.float64))
            scales = np.linalg.norm(M[:3, :3], axis=0)
            if not np.allclose(scales, scales[0], rtol=1e-5):
                raise SceneError(f"{where}: spheres support uniform scaling only")
            radius = float(shape.radius * scales[0])
            if not radius > 0:
                raise SceneError(f"{where}: radius must be positive, got {radius}")
            sph = Sphere(center, radius, shape.material, flip=shape.flip_normals)
            if shape.moving:
                sph.center_close = m.transform_points(shape.world_from_object_close,
                                                      np.array(shape.center, np.float64))
                grow([sph.center_close - radius, sph.center_close + radius])
            if shape.emission is not None:
                sph.light = add_area_light("sphere", shape.emission, p=center, e1=(0, 0, 0, radius),
                                           n=(0, 0, 1, 4 * math.pi * radius * radius))
                sphere_lights.append((len(lights) - 1, len(spheres)))
            spheres.append(sph)
            compiled_budget -= 1
            grow([center - radius, center + radius])
        elif shape.kind == "disk":
            raise SceneError(f"{where}: disk shapes are not supported yet; use a mesh")
        elif shape.kind == "mesh" and shape.moving:
            if shape.emission is not None:
                raise SceneError(f"{where}: a moving mesh cannot be an area light")
            open_, close = shape.world_from_object, shape.world_from_object_close
            if np.linalg.det(open_[:3, :3]) * np.linalg.det(close[:3, :3]) <= 0:
                raise SceneError(f"{where}: the transforms at shutter open and close must both "
                                 f"keep or both flip orientation")
            object_shape = dataclasses.replace(shape, world_from_object=np.eye(4))
            tri, normals, uvs, _ = _transform_mesh(object_shape, where)
            if np.linalg.det(open_[:3, :3]) < 0:   # the winding that faces out in world space
                tri, normals, uvs = tri[:, [0, 2, 1]], normals[:, [0, 2, 1]], uvs[:, [0, 2, 1]]
            if len(tri):
                moving.append(MovingMesh(tri, normals, uvs, shape.material, open_, close))
                for W in (open_, close):
                    grow(m.transform_points(W, tri.reshape(-1, 3)))
        elif shape.kind == "mesh" and shape.instances is not None:
            tri, normals, uvs, _ = _transform_mesh(shape, where)
            if len(tri):
                copies = np.asarray(shape.instances, np.float64)[:, :3]
                instanced.append(InstancedMesh(tri, normals, uvs, shape.material, copies))
                grow(np.concatenate(instanced[-1].world_bounds()))
        elif shape.kind == "mesh":
            if index in cached:
                continue        # in the cached device arrays; their bounds are grown below
            tri, normals, uvs, ng = _transform_mesh(shape, where)
            if len(tri) == 0:
                continue
            tri_bounds = m.point_bounds(tri)
            grow(tri_bounds)
            # opacity cutouts are tested in the BVH traversal: such meshes always go there
            cutout = 0 <= shape.material < len(scene.materials) and \
                scene.materials[shape.material].opacity is not None
            if len(tri) <= MAX_COMPILED_TRIANGLES_PER_MESH and len(tri) <= compiled_budget and \
                    not cutout and np.allclose(normals, ng[:, None, :], atol=1e-4):
                for k in range(len(tri)):
                    uv = np.array([uvs[k, 0], uvs[k, 1] - uvs[k, 0], uvs[k, 2] - uvs[k, 0]])
                    add_quad(Parallelogram(tri[k, 0], tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0],
                                           shape.material, triangle=True, uv=uv), shape.emission)
                compiled_budget -= len(tri)
                continue
            light_ids = np.zeros(len(tri), np.uint32)
            if shape.emission is not None:
                for k in range(len(tri)):
                    e1, e2 = tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0]
                    n = np.cross(e1, e2)
                    area = 0.5 * np.linalg.norm(n)
                    uv = (uvs[k, 0], uvs[k, 1] - uvs[k, 0], uvs[k, 2] - uvs[k, 0])
                    light_ids[k] = add_area_light("triangle", shape.emission, uv=uv, p=tri[k, 0],
                                                  e1=e1, e2=e2, n=(*(n / (2 * area)), area))
            soup.positions.append(tri)
            soup.normals.append(normals)
            soup.uvs.append(uvs)
            soup.material.append(np.full(len(tri), shape.material))
            soup.light.append(light_ids)
            soup.shapes.append(index)
            soup.bounds.append(tri_bounds)
        else:
            raise SceneError(f"{where}: unknown shape kind {shape.kind!r}")
    mesh_bounds = m.point_bounds(np.concatenate(soup.bounds)) if soup.bounds else None
    if cached:
        mesh_bounds = slot.bounds
        grow(mesh_bounds)
    if compiled_budget < 0:
        raise SceneError(f"{scene.source}: more than {MAX_COMPILED_PRIMITIVES} rectangles, cube "
                         f"faces and spheres; make some of them meshes")

    # primitive ids: planar primitives first, then spheres, then BVH triangles (the
    # renderer sets those after the BVH orders them); non-area lights ignore nothing
    for light_index, sphere_index in sphere_lights:
        lights[light_index]["info"][2] = len(quads) + sphere_index
    if not np.all(np.isfinite(lo)):
        lo, hi = np.zeros(3), np.zeros(3)
    environment = 0
    env_image = None
    radius = float(max(np.linalg.norm(hi - lo) / 2, 1e-3))
    for light in scene.lights:
        rec = np.zeros(1, layout.LIGHT)[0]
        rec["info"][0] = layout.LIGHT_KINDS[light.kind]
        rec["info"][2] = NO_PRIMITIVE
        if light.kind in ("point", "spot"):
            intensity = (_rgb(light.power, "light.power") / (4 * math.pi) if light.power is not None
                         else _rgb(light.intensity, "light.intensity"))
            rec["radiance"][:3] = intensity
            if light.kind == "point":
                rec["p"][:3] = light.position
                weight = 4 * math.pi * _luminance(intensity)
            else:
                W = light.world_from_light
                rec["p"][:3] = W[:3, 3]
                axis = W[:3, :3] @ np.array([0.0, 0.0, 1.0])
                rec["n"][:3] = axis / np.linalg.norm(axis)
                cos_cutoff = math.cos(math.radians(light.cutoff_angle))
                cos_beam = math.cos(math.radians(min(light.beam_width, light.cutoff_angle)))
                rec["params"][:2] = (cos_cutoff, cos_beam)
                weight = 2 * math.pi * (1 - 0.5 * (cos_cutoff + cos_beam)) * _luminance(intensity)
        elif light.kind == "directional":
            d = np.asarray(light.direction, np.float64)
            rec["n"][:3] = d / np.linalg.norm(d)
            rec["radiance"][:3] = _rgb(light.irradiance, "light.irradiance")
            weight = math.pi * radius ** 2 * _luminance(rec["radiance"][:3])
        elif light.kind in ("constant", "envmap"):
            if environment:
                raise SceneError(f"{scene.source}: more than one environment light")
            if light.kind == "constant":
                rec["radiance"][:3] = _rgb(light.radiance, "light.radiance")
                average = _luminance(rec["radiance"][:3])
            else:
                image = np.asarray(light.image, np.float32)
                if image.ndim != 3 or image.shape[2] < 3 or min(image.shape[:2]) < 1 or \
                        not np.all(np.isfinite(image)) or image.min() < 0:
                    raise SceneError(f"{scene.source}: light {light.name}: the environment image must "
                                     f"be H x W x 3 with finite, non-negative values")
                env_image = np.ascontiguousarray(image[..., :3])
                R = light.world_from_light[:3, :3]
                frame = R / np.linalg.norm(R, axis=0)
                rec["e1"][:3], rec["e2"][:3], rec["n"][:3] = frame[:, 0], frame[:, 1], frame[:, 2]
                rec["params"][0] = light.scale
                rows = np.sin((np.arange(env_image.shape[0]) + 0.5) / env_image.shape[0] * math.pi)
                average = float((_luminance(env_image.reshape(-1, 3).T).reshape(env_image.shape[:2])
                                 * rows[:, None]).sum() / rows.sum() / env_image.shape[1]) * light.scale
            weight = 4 * math.pi * math.pi * radius ** 2 * average
            environment = len(lights) + 1
        lights.append(rec)
        weights.append(weight)

    materials = np.array([pack_material(mat, textures) for mat in scene.materials], layout.MATERIAL) \
        if scene.materials else layout.zeros(layout.MATERIAL)
    if medium_bits:
        materials["info"][:, 1] |= np.asarray(medium_bits, np.uint32)
    light_arr = np.array(lights, layout.LIGHT) if lights else np.zeros(0, layout.LIGHT)
    return PackedScene(
        quads=quads, spheres=spheres, mesh=soup.arrays(), materials=materials,
        lights=light_arr, light_weights=np.asarray(weights, np.float64),
        bounds=(lo, hi), material_kinds=material_kinds(scene.materials),
        light_kinds={k for k, v in layout.LIGHT_KINDS.items()
                     if len(light_arr) and (light_arr["info"][:, 0] == v).any()},
        environment=environment, env_image=env_image, textures=textures, moving_meshes=moving,
        media=media, media_grids=media_grids, mesh_bounds=mesh_bounds, mesh_slot=slot,
        mesh_shapes=soup.shapes, instanced_meshes=instanced)
