"""The in-memory scene: what every loader produces and the renderer consumes.

Plain dataclasses and numpy arrays, no GL. Conventions follow Mitsuba 3 so that
its scenes load unchanged:

- Transforms are 4x4 ``world_from_object`` matrices (column vectors: p_world = M p).
- Cameras look along +z of camera space with +y up and +x to the *left* of the
  image (Mitsuba's ``look_at`` builds columns (left, up, dir, origin)).
- ``Integrator.max_depth`` counts path segments: 1 = emitters seen directly,
  2 = direct lighting, -1 = unbounded.
- Colours are linear RGB; emitted radiance in W/(m^2 sr) per channel.
- Shapes: ``rectangle`` spans [-1, 1]^2 at z = 0 facing +z; ``cube`` spans [-1, 1]^3;
  ``disk`` is the unit disk at z = 0 facing +z; ``sphere`` has a centre and radius.
- Motion: a shape or camera may carry ``world_from_object_close``: its transform at
  the shutter's close; vertices move linearly between the two (linear motion blur).
- Media (Mitsuba 3's ``homogeneous`` and ``heterogeneous``): ``sigma_t`` (extinction per
  unit length, times ``scale``) and ``albedo``, constant or a :class:`Volume` (Mitsuba's
  ``gridvolume``: a grid over the unit cube, placed by ``world_from_object``, looked up
  cell-centred); a shape's ``interior`` / ``exterior`` and the camera's ``medium`` index
  ``Scene.media``. A surface with the ``null`` material only bounds media.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional, Union

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SceneError
from ..integrators import names as integrator_names

RGB = tuple[float, float, float]


# -- transforms ---------------------------------------------------------------------------
def translate(v: ArrayLike) -> np.ndarray:
    """4x4 world_from_object matrix moving points by the vector ``v`` (scene units)."""
    m = np.eye(4)
    m[:3, 3] = v
    return m


def scale(v: ArrayLike) -> np.ndarray:
    """4x4 matrix scaling by ``v`` (one factor, or one per axis x, y, z)."""
    v = np.broadcast_to(np.asarray(v, np.float64), (3,))
    return np.diag([v[0], v[1], v[2], 1.0])


def rotate(axis: ArrayLike, angle_degrees: float, normalize: bool = True) -> np.ndarray:
    """Rotation about ``axis`` by ``angle_degrees`` (right-handed). ``normalize=False`` takes
    the axis as given in Rodrigues' formula, as Mitsuba 3's ``rotate`` does: an axis that is
    not a unit vector then scales and shears as well (Mitsuba XML scenes)."""
    a = np.asarray(axis, np.float64)
    n = np.linalg.norm(a)
    if n == 0:
        raise SceneError("rotate: the axis has zero length")
    x, y, z = a / n if normalize else a
    t = math.radians(angle_degrees)
    c, s = math.cos(t), math.sin(t)
    m = np.eye(4)
    m[:3, :3] = [[c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
                 [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
                 [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)]]
    return m


def look_at(origin: ArrayLike, target: ArrayLike, up: ArrayLike) -> np.ndarray:
    """Mitsuba's look_at: columns (left, up, dir, origin) of world_from_camera."""
    o, t, u = (np.asarray(v, np.float64) for v in (origin, target, up))
    d = t - o
    if np.linalg.norm(d) == 0:
        raise SceneError("look_at: origin and target coincide")
    d /= np.linalg.norm(d)
    left = np.cross(u, d)
    if np.linalg.norm(left) < 1e-12:
        raise SceneError("look_at: the up vector is parallel to the view direction")
    left /= np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, o
    return m


def _translation_only(m: np.ndarray) -> bool:
    return bool((m[:3, :3] == np.eye(3)).all())


def _times_identity(p: np.ndarray) -> np.ndarray:
    """``p @ I`` without the product (10x faster), bit for bit: the product's sums start
    from +0, so a zero component comes out +0, as ``p + 0.0`` gives."""
    return p + 0.0


def point_bounds(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) over the rows of (N, 3) points, column by column: ``p.min(axis=0)``'s
    values, 4x faster (numpy reduces a C-order (N, 3) array over axis 0 in 3-element steps)."""
    p = np.asarray(p).reshape(-1, 3)
    return (np.array([p[:, k].min() for k in range(3)], p.dtype),
            np.array([p[:, k].max() for k in range(3)], p.dtype))


def triangle_edges(vertices: np.ndarray, triangles: np.ndarray) -> list[list[np.ndarray]]:
    """Edge vectors ``e_k = p_{k+1} - p_k`` (indices mod 3) of every triangle as three
    [x, y, z] lists of (T,) arrays: gathers from the vertex columns, never a (T, 3, 3)
    array (its gather and strided reads cost twice as much)."""
    columns = np.ascontiguousarray(np.asarray(vertices).T)
    corners = np.ascontiguousarray(np.asarray(triangles).T)
    c = [[np.take(columns[axis], corners[k]) for axis in range(3)] for k in range(3)]
    return [[c[(k + 1) % 3][a] - c[k][a] for a in range(3)] for k in range(3)]


def face_normals(edges: list[list[np.ndarray]]) -> list[np.ndarray]:
    """The unnormalized face normals ``(p1 - p0) x (p2 - p0)`` from :func:`triangle_edges`,
    as an [x, y, z] list (p2 - p0 is -e_2, exactly)."""
    a, b = edges[0], [-x for x in edges[2]]
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    p = np.asarray(p, np.float64)
    out: np.ndarray
    if _translation_only(m):
        out = _times_identity(p) + m[:3, 3]
    else:
        out = p @ m[:3, :3].T + m[:3, 3]
    return out


def transform_normals(m: np.ndarray, n: np.ndarray) -> np.ndarray:
    if _translation_only(m):
        out = _times_identity(np.asarray(n, np.float64))
    else:
        out = np.asarray(n, np.float64) @ np.linalg.inv(m[:3, :3])
    length = np.linalg.norm(out, axis=-1, keepdims=True)
    return out / np.where(length > 0, length, 1.0)


# -- textures ------------------------------------------------------------------------------
@dataclass
class Texture:
    """A colour that varies over a surface: ``bitmap`` (image, sRGB-decoded unless raw)
    or ``checkerboard`` (two colours, ``scale`` checks per unit of uv)."""

    kind: str                                  # "bitmap" | "checkerboard"
    image: Optional[np.ndarray] = None         # HxWx3 linear float32 (bitmap)
    color0: RGB = (0.4, 0.4, 0.4)              # checkerboard
    color1: RGB = (0.2, 0.2, 0.2)
    uv_transform: np.ndarray = field(default_factory=lambda: np.eye(3))  # uv' = M (u, v, 1)
    filter: str = "bilinear"                   # "bilinear" | "nearest"
    wrap: str = "repeat"                       # "repeat" | "clamp" | "mirror"
    name: str = ""


Spectrum = Union[RGB, Texture]


# -- materials -----------------------------------------------------------------------------
MATERIAL_KINDS = ("diffuse", "conductor", "roughconductor", "dielectric", "roughdielectric",
                  "thindielectric", "plastic", "roughplastic", "null", "metallicroughness")


@dataclass
class Material:
    """One BSDF. ``kind`` picks the model; unused fields are ignored.

    - diffuse: ``reflectance``
    - conductor / roughconductor: complex IOR ``eta`` + i ``k`` (per channel),
      ``specular_reflectance`` tint, ``alpha`` (u, v) and ``distribution`` (ggx | beckmann)
    - dielectric / roughdielectric / thindielectric: ``int_ior`` / ``ext_ior``,
      ``specular_reflectance`` / ``specular_transmittance``, ``alpha``
    - plastic / roughplastic: ``reflectance`` (diffuse base), ``specular_reflectance``,
      ``int_ior`` / ``ext_ior``, ``alpha``, ``nonlinear``
    - metallicroughness: glTF's metallic-roughness model with the BSDF chosen per surface
      point: ``metallic_roughness``'s blue channel is the metallic value there and its
      green channel the roughness (a raw texture with glTF's factors multiplied in, or an
      RGB), ``reflectance`` the base colour; the rule of :mod:`.loaders.pbr` picks a
      (rough) conductor reflecting the base colour or a (rough) plastic over it
    ``two_sided``: the BSDF answers on both sides of the surface (Mitsuba's twosided).
    Any kind may also have a tangent-space ``normal_map`` (a raw bitmap: n = 2 c - 1 in
    the frame x = dp/du, y = n x x, z = the shading normal, the glTF / OpenGL convention
    of +Y up in the image; ``normal_scale`` scales its x and y) and an ``opacity`` bitmap
    (its mean of RGB; BVH meshes only): where it is below ``alpha_cutoff`` the surface is
    a hole for every ray, camera, path and shadow rays alike (glTF's MASK mode).
    With a normal map, ``normal_shadowing`` multiplies the BSDF by the shadowing term of
    Conty Estevez et al. 2019 and ``normal_flip`` turns a map normal that hides the
    arriving ray back round the unperturbed normal (Mitsuba's use_shadowing_function and
    flip_invalid_normals; both off unless a scene asks).
    """

    kind: str = "diffuse"
    reflectance: Spectrum = (0.5, 0.5, 0.5)
    specular_reflectance: Spectrum = (1.0, 1.0, 1.0)
    specular_transmittance: Spectrum = (1.0, 1.0, 1.0)
    eta: RGB = (0.0, 0.0, 0.0)
    k: RGB = (1.0, 1.0, 1.0)
    int_ior: float = 1.5046
    ext_ior: float = 1.000277
    alpha: tuple[float, float] = (0.1, 0.1)
    distribution: str = "beckmann"
    nonlinear: bool = False
    two_sided: bool = False
    name: str = ""
    normal_map: Optional[Texture] = None
    normal_scale: float = 1.0
    normal_shadowing: bool = False
    normal_flip: bool = False
    opacity: Optional[Texture] = None
    alpha_cutoff: float = 0.5
    metallic_roughness: Spectrum = (0.0, 1.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind not in MATERIAL_KINDS:
            raise SceneError(f"material {self.name or '?'}: unknown kind {self.kind!r} "
                             f"(expected one of {', '.join(MATERIAL_KINDS)})")
        if self.distribution not in ("ggx", "beckmann"):
            raise SceneError(f"material {self.name or '?'}: distribution must be ggx or "
                             f"beckmann, got {self.distribution!r}")


# -- shapes ------------------------------------------------------------------------------
@dataclass
class Emission:
    """An area light attached to a shape: radiance on its front side, uniform, or with a
    ``texture`` (meshes and rectangles) ``radiance`` times the texture at the surface uv."""

    radiance: RGB = (1.0, 1.0, 1.0)
    two_sided: bool = False
    texture: Optional[Texture] = None


@dataclass
class Shape:
    """A surface. ``kind``: mesh | rectangle | cube | disk | sphere.

    Meshes carry ``vertices`` (V,3), ``triangles`` (T,3) and optionally ``normals`` (V,3)
    and ``uvs`` (V,2), in object space; ``world_from_object`` places them.
    Spheres use ``center`` and ``radius`` in object space.
    ``instances`` (meshes): (K, 4, 4) transforms placing K copies, copy k at
    ``instances[k] @ world_from_object`` (glTF nodes sharing a mesh, Mitsuba
    ``shapegroup``/``instance``, TOML ``instances``); the shape itself is not drawn.
    """

    kind: str
    material: int = 0                             # index into Scene.materials
    world_from_object: np.ndarray = field(default_factory=lambda: np.eye(4))
    world_from_object_close: Optional[np.ndarray] = None
    vertices: Optional[np.ndarray] = None
    triangles: Optional[np.ndarray] = None
    normals: Optional[np.ndarray] = None
    uvs: Optional[np.ndarray] = None
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 1.0
    emission: Optional[Emission] = None
    flip_normals: bool = False
    face_normals: bool = False                    # ignore vertex normals (flat shading)
    name: str = ""
    interior: Optional[int] = None                # index into Scene.media: behind the surface
    exterior: Optional[int] = None                # and on the side its normal faces
    instances: Optional[np.ndarray] = None        # (K, 4, 4): copies of a mesh (see above)

    @property
    def moving(self) -> bool:
        return self.world_from_object_close is not None and not np.allclose(
            self.world_from_object_close, self.world_from_object)


# -- participating media ---------------------------------------------------------------------------
@dataclass
class Volume:
    """A grid of values over the unit cube [0, 1]^3 of object space (Mitsuba 3's
    ``gridvolume``), placed by ``world_from_object``. ``data``: float32 (Z, Y, X, C) with C
    in {1, 3, 6} channels, x fastest in memory as in Mitsuba's ``.vol`` files; a lookup at
    object point p reads voxel coordinates p * resolution - 0.5 (cell-centred), clamped,
    ``filter`` ``trilinear`` or ``nearest``."""

    data: np.ndarray
    world_from_object: np.ndarray = field(default_factory=lambda: np.eye(4))
    filter: str = "trilinear"
    name: str = ""

    @property
    def resolution(self) -> tuple[int, int, int]:
        """(x, y, z) voxels."""
        z, y, x = self.data.shape[:3]
        return x, y, z


MediumValue = Union[RGB, Volume]


@dataclass
class Medium:
    """A participating medium (Mitsuba 3's conventions). ``kind``: ``homogeneous`` (constant
    ``sigma_t`` and ``albedo``) or ``heterogeneous`` (either may be a :class:`Volume`; the
    medium is bounded by its ``sigma_t`` grid's box). ``sigma_t`` is the extinction per unit
    length before ``scale``; ``albedo`` = sigma_s / sigma_t per channel. ``phase``:
    ``isotropic`` or ``hg`` (Henyey-Greenstein, mean cosine ``g`` in (-1, 1)).
    ``sample_emitters``: next-event estimation from inside the medium (Mitsuba's flag)."""

    kind: str = "homogeneous"
    sigma_t: MediumValue = (1.0, 1.0, 1.0)
    albedo: MediumValue = (0.75, 0.75, 0.75)
    scale: float = 1.0
    phase: str = "isotropic"
    g: float = 0.0
    sample_emitters: bool = True
    name: str = ""


# -- lights that are not shapes ------------------------------------------------------------------
@dataclass
class Light:
    """A light without a surface.

    - point: ``position``, ``intensity`` (W/sr); or ``power`` Φ (W), I = Φ / 4π
    - spot: ``world_from_light`` (+z is the axis), ``intensity``, ``cutoff_angle`` and
      ``beam_width`` in degrees (Mitsuba's smooth falloff between them)
    - directional: ``direction`` (light travels along it), ``irradiance`` (W/m^2)
    - constant: uniform environment ``radiance``
    - envmap: lat-long ``image`` (HxWx3 linear) times ``scale``, oriented by ``world_from_light``
      (Mitsuba's convention: +y up, u = 0 at -x... see glrender/lights)
    """

    kind: str
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    intensity: RGB = (1.0, 1.0, 1.0)
    power: Optional[RGB] = None
    world_from_light: np.ndarray = field(default_factory=lambda: np.eye(4))
    cutoff_angle: float = 20.0
    beam_width: float = 15.0
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    irradiance: RGB = (1.0, 1.0, 1.0)
    radiance: RGB = (1.0, 1.0, 1.0)
    image: Optional[np.ndarray] = None
    scale: float = 1.0
    name: str = ""

    KINDS = ("point", "spot", "directional", "constant", "envmap")

    def __post_init__(self) -> None:
        if self.kind not in self.KINDS:
            raise SceneError(f"light {self.name or '?'}: unknown kind {self.kind!r} "
                             f"(expected one of {', '.join(self.KINDS)})")


# -- camera, film, settings ------------------------------------------------------------------------
CAMERA_KINDS = ("perspective", "orthographic")


@dataclass
class Camera:
    """A perspective camera (a thin lens when ``aperture_radius`` > 0) or an orthographic one.

    ``world_from_camera``: 4x4, camera space looks along +z with +y up and +x to the image's
    left (build it with :func:`look_at`); ``aperture_radius``, ``focus_distance``,
    ``near_clip``, ``far_clip`` in scene units.
    ``world_from_camera_close``: the transform at the shutter's close (motion blur).
    ``kind``: ``perspective`` sees ``fov`` degrees along ``fov_axis``; ``orthographic`` sends
    every ray along camera +z from the plane z = 0, and sees ``half_extent`` camera-space
    units on either side of the axis along ``fov_axis`` (glTF's xmag / ymag; Mitsuba's
    orthographic sensor is ``half_extent`` 1 along x, its to_world scale applied by
    ``world_from_camera``). The other axis follows the film's aspect ratio, as the field of
    view's does. An orthographic camera has no lens (``aperture_radius`` must be 0).
    """

    world_from_camera: np.ndarray = field(default_factory=lambda: look_at((0, 0, 5), (0, 0, 0), (0, 1, 0)))
    medium: Optional[int] = None      # index into Scene.media: the medium around the camera
    world_from_camera_close: Optional[np.ndarray] = None
    fov: float = 40.0                 # degrees, along fov_axis (perspective)
    fov_axis: str = "x"               # x | y | smaller | larger | diagonal
    aperture_radius: float = 0.0
    focus_distance: float = 1.0
    near_clip: float = 1e-2
    far_clip: float = 1e4
    kind: str = "perspective"         # perspective | orthographic
    half_extent: float = 1.0          # camera-space units, along fov_axis (orthographic)

    def __post_init__(self) -> None:
        if self.kind not in CAMERA_KINDS:
            raise SceneError(f"camera.kind: expected perspective or orthographic, got {self.kind!r}")
        if self.fov_axis not in ("x", "y", "smaller", "larger", "diagonal"):
            raise SceneError(f"camera.fov_axis: expected x, y, smaller, larger or diagonal, "
                             f"got {self.fov_axis!r}")
        if not 0.0 < self.fov < 180.0:
            raise SceneError(f"camera.fov: expected degrees in (0, 180), got {self.fov}")
        if not 0.0 < self.half_extent < math.inf:
            raise SceneError(f"camera.half_extent: expected a positive length, got {self.half_extent}")
        if self.kind == "orthographic" and self.aperture_radius > 0:
            raise SceneError(f"camera: an orthographic camera has no lens, but aperture_radius is "
                             f"{self.aperture_radius} (give 0, or a perspective camera for depth of field)")

    @property
    def orthographic(self) -> bool:
        return self.kind == "orthographic"


FILTERS = ("box", "tent", "gaussian", "mitchell")


@dataclass
class Film:
    """The image's size in pixels and its reconstruction filter (``box``, ``tent``,
    ``gaussian``, ``mitchell``; ``filter_radius`` in pixels, default per filter)."""

    width: int = 256
    height: int = 256
    filter: str = "gaussian"
    filter_radius: Optional[float] = None    # pixels; defaults per filter (box 0.5, tent 1, gaussian 2)
    gaussian_stddev: float = 0.5
    mitchell_b: float = 1.0 / 3.0
    mitchell_c: float = 1.0 / 3.0

    def __post_init__(self) -> None:
        if self.filter not in FILTERS:
            raise SceneError(f"film.filter: expected one of {', '.join(FILTERS)}, got {self.filter!r}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or not 1 <= value <= 65536:
                raise SceneError(f"film.{name}: expected an integer in [1, 65536], got {value!r}")

    def resized(self, width: Optional[int] = None, height: Optional[int] = None) -> "Film":
        """This film at another size. Given one of ``width`` and ``height``, the other keeps
        the film's aspect ratio (rounded, at least 1 pixel), so the camera frames the same
        view; given both, they are used as they are."""
        if width is None and height is None:
            return self
        if width is None:
            assert height is not None
            width = min(65536, max(1, round(int(height) * self.width / self.height)))
        elif height is None:
            height = min(65536, max(1, round(int(width) * self.height / self.width)))
        return replace(self, width=int(width), height=int(height))

    @property
    def radius(self) -> float:
        if self.filter_radius is not None:
            return float(self.filter_radius)
        return {"box": 0.5, "tent": 1.0, "gaussian": 4.0 * self.gaussian_stddev, "mitchell": 2.0}[self.filter]


INTEGRATORS = integrator_names()   # glrender/integrators.py: the one table of integrators
STRATEGIES = ("light", "bsdf", "mis-balance", "mis-power")
# how next-event estimation chooses a light: by the scene's light count (auto: see
# glrender/render/params.py choose_light_selection), uniformly, by power, or by a light BVH at
# the shading point (glrender/sampling/light_tree.py)
LIGHT_SELECTIONS = ("auto", "uniform", "power", "bvh")
SPLIT_LIMIT = 16   # light samples per vertex and first-vertex branches of the path tracer
# ... and their product: one invocation renders a whole sample with all its branches and
# light samples, and llvmpipe stops an invocation silently after ~65,535 loop iterations of
# its SIMD vector. At 16 x 16 the worst vector of a 48x48 bunny render took 57,771 (an
# image of a million pixels would pass the cap); at 64 (16 x 4, 8 x 8, 4 x 16) at most
# 20,385 (tests/render/test_splitting.py).
SPLIT_WORK_LIMIT = 64


def parse_rr(rule: str) -> tuple[str, float]:
    """The Russian roulette rule of path, lighttrace and bdpt (integrators/roulette.glsl) ->
    (kind, survival probability): ``throughput`` (survive with min(max(beta) eta^2, 0.95),
    Mitsuba's), ``fixed:<q>`` (survive with q in (0, 1]) or ``off`` (no roulette)."""
    text = str(rule).strip()
    if text in ("throughput", "off"):
        return text, 1.0
    kind, sep, value = text.partition(":")
    if kind == "fixed" and sep:
        try:
            q = float(value)
        except ValueError:
            q = float("nan")
        if 0.0 < q <= 1.0:
            return "fixed", q
    raise SceneError(f"integrator.rr: expected throughput, off or fixed:<q> with q in (0, 1], "
                     f"got {rule!r}")


@dataclass
class Integrator:
    """How radiance is estimated: ``kind`` path | direct | ao; ``max_depth`` in path
    segments (1 = emitters seen directly, 2 = direct lighting, -1 = unbounded); Russian
    roulette from ``rr_depth`` segments by the rule ``rr`` (:func:`parse_rr`); ``strategy``
    weights light and BSDF samples; the path tracer takes ``light_samples`` light samples
    at every vertex and splits the path into ``split`` BSDF branches at its first vertex;
    ``ao_distance`` in scene units (ambient occlusion)."""

    kind: str = "path"
    max_depth: int = -1
    rr_depth: int = 5
    rr: str = "throughput"             # throughput | fixed:<q> | off (path, lighttrace, bdpt)
    light_samples: int = 1             # path tracer: light samples per vertex
    split: int = 1                     # path tracer: BSDF branches at the first vertex
    strategy: str = "mis-power"        # direct lighting / NEE weighting
    emitter_samples: int = 1           # direct integrator only
    bsdf_samples: int = 1
    light_selection: str = "auto"      # auto (by light count) | uniform (as Mitsuba) | power
                                       # (alias table) | bvh (light tree)
    area_sampling: str = "solid-angle"  # area | solid-angle (triangle/rectangle lights that look
                                        # large; small ones by area either way: lights/light.glsl)
    hide_emitters: bool = False
    ao_distance: float = float("inf")

    def __post_init__(self) -> None:
        if self.kind not in INTEGRATORS:
            raise SceneError(f"integrator: expected one of {', '.join(INTEGRATORS)}, got {self.kind!r}")
        if self.strategy not in STRATEGIES:
            raise SceneError(f"integrator.strategy: expected one of {', '.join(STRATEGIES)}, "
                             f"got {self.strategy!r}")
        if self.light_selection not in LIGHT_SELECTIONS:
            raise SceneError(f"integrator.light_selection: expected auto, uniform, power or bvh, "
                             f"got {self.light_selection!r}")
        if self.area_sampling not in ("area", "solid-angle"):
            raise SceneError(f"integrator.area_sampling: expected area or solid-angle, "
                             f"got {self.area_sampling!r}")
        parse_rr(self.rr)
        for name in ("light_samples", "split"):
            value = getattr(self, name)
            if not isinstance(value, int) or not 1 <= value <= SPLIT_LIMIT:
                raise SceneError(f"integrator.{name}: expected an integer in 1..{SPLIT_LIMIT}, "
                                 f"got {value!r}")
        if self.split * self.light_samples > SPLIT_WORK_LIMIT:
            raise SceneError(f"integrator.split x integrator.light_samples: at most "
                             f"{SPLIT_WORK_LIMIT} (a sample's branches and light samples run in one "
                             f"invocation), got {self.split} x {self.light_samples}")
        if not isinstance(self.max_depth, int) or (self.max_depth < 1 and self.max_depth != -1):
            raise SceneError(f"integrator.max_depth: expected -1 (unbounded) or an integer >= 1, "
                             f"got {self.max_depth!r}")


SAMPLER_KINDS = ("independent", "stratified", "sobol")


@dataclass
class Sampler:
    """Random numbers: ``kind`` independent | stratified | sobol (Owen-scrambled),
    ``spp`` samples per pixel, ``seed`` (the same seed gives the same image)."""

    kind: str = "sobol"
    spp: int = 64
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in SAMPLER_KINDS:
            raise SceneError(f"sampler: expected one of {', '.join(SAMPLER_KINDS)}, got {self.kind!r}")


@dataclass
class Shutter:
    """Exposure interval in seconds (motion blur when ``close`` > ``open``), with a
    ``box`` or ``tent`` weighting over time."""

    open: float = 0.0
    close: float = 0.0
    function: str = "box"              # box | tent

    @property
    def active(self) -> bool:
        return self.close > self.open


@dataclass
class Scene:
    """Everything to render: camera, film, settings, materials, shapes and lights.

    Build one in code or get one from :func:`glrender.load`; edit the fields freely
    between renders. ``Shape.material`` indexes ``materials`` (:meth:`add_material`
    returns the index)."""

    camera: Camera = field(default_factory=Camera)
    film: Film = field(default_factory=Film)
    integrator: Integrator = field(default_factory=Integrator)
    sampler: Sampler = field(default_factory=Sampler)
    shutter: Shutter = field(default_factory=Shutter)
    materials: list[Material] = field(default_factory=list)
    shapes: list[Shape] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    media: list[Medium] = field(default_factory=list)
    source: str = "<scene>"            # file it came from, for messages
    animation: Optional[object] = None  # keyed motion over frames: glrender.scene.animation.Animation
    files: dict[str, str] = field(default_factory=dict)   # absolute path -> SHA-256 of every file the
                                                         # loader read (scene, includes, meshes, images)

    def add_material(self, material: Material) -> int:
        """Append ``material``; returns its index for ``Shape.material``."""
        self.materials.append(material)
        return len(self.materials) - 1

    @property
    def has_media(self) -> bool:
        """Whether a shape or the camera names a medium (what the renderer must render)."""
        return self.camera.medium is not None or any(
            s.interior is not None or s.exterior is not None for s in self.shapes)

    def add_medium(self, medium: Medium) -> int:
        """Append ``medium``; returns its index for ``Shape.interior`` / ``exterior`` and
        ``Camera.medium``."""
        self.media.append(medium)
        return len(self.media) - 1

    def validate(self) -> None:
        """Cross-checks that loaders cannot do alone."""
        for i, shape in enumerate(self.shapes):
            if not 0 <= shape.material < len(self.materials):
                raise SceneError(f"{self.source}: shape {shape.name or i}: material index "
                                 f"{shape.material} out of range")
            for side in ("interior", "exterior"):
                k = getattr(shape, side)
                if k is not None and not 0 <= k < len(self.media):
                    raise SceneError(f"{self.source}: shape {shape.name or i}: {side} medium index "
                                     f"{k} out of range")
            if shape.instances is not None:
                where = f"{self.source}: shape {shape.name or i}: instances"
                t = np.asarray(shape.instances)
                if shape.kind != "mesh":
                    raise SceneError(f"{where}: only meshes are instanced, this is a {shape.kind}")
                if t.ndim != 3 or t.shape[1:] != (4, 4) or not np.issubdtype(t.dtype, np.number):
                    raise SceneError(f"{where}: expected K 4x4 transforms, got shape {t.shape}")
                if not np.all(np.isfinite(t)) or not np.allclose(t[:, 3], [0, 0, 0, 1]):
                    raise SceneError(f"{where}: transforms must be finite with last row (0, 0, 0, 1)")
                if shape.moving:
                    raise SceneError(f"{where}: instanced meshes cannot move over the shutter")
        if self.camera.medium is not None and not 0 <= self.camera.medium < len(self.media):
            raise SceneError(f"{self.source}: camera: medium index {self.camera.medium} out of range")
        if not self.shapes and not self.lights:
            raise SceneError(f"{self.source}: the scene has no shapes and no lights")
