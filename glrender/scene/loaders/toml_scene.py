"""The native scene format (TOML): validated field by field.

Every error names the file, the key path and what was expected, e.g.
``scenes/x.toml: materials.floor.reflectance: expected 3 numbers, got "red"``.
See docs/scene-format.md for the fields. Beyond the sections: ``include`` (other TOML
files merged first, depth-bounded, cycles refused), ``[params]`` (defaults for
``$name`` substitution in string values, overridden by ``load(path, name=value)``)
and ``[textures]`` (bitmaps and checkerboards that colour fields can name).
"""
from __future__ import annotations

import math
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import SceneError
from .. import model as m
from .diagnostics import cause, excerpt, read_image_checked, warn
from .scene_files import MissingFile, SceneFiles, read_bytes

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

MAX_INCLUDE_DEPTH = 16
MAX_FILE_BYTES = 64 << 20


class _Ctx:
    def __init__(self, path: Path, params: dict[str, Any], files: SceneFiles | None = None):
        self.path, self.params = path, params
        self.files = files or SceneFiles(path.parent)
        self.textures: dict[str, m.Texture] = {}

    def fail(self, key: str, message: str):
        raise SceneError(f"{self.path}: {excerpt(key, 120, quote=False)}: {message}")

    # -- typed getters ----------------------------------------------------------------
    def table(self, value, key: str) -> dict:
        if not isinstance(value, dict):
            self.fail(key, f"expected a table, got {_show(value)}")
        return value

    def number(self, value, key: str, lo=-math.inf, hi=math.inf, integer=False):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        if integer:
            ok = isinstance(value, int) and not isinstance(value, bool)
        if not ok or not math.isfinite(value) or not lo <= value <= hi:
            kind = "an integer" if integer else "a number"
            bounds = "" if (lo == -math.inf and hi == math.inf) else f" in [{lo}, {hi}]"
            self.fail(key, f"expected {kind}{bounds}, got {_show(value)}")
        return int(value) if integer else float(value)

    def boolean(self, value, key: str) -> bool:
        if not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_show(value)}")
        return value

    def string(self, value, key: str, choices=None) -> str:
        if not isinstance(value, str) or (choices and value not in choices):
            want = f"one of {', '.join(map(repr, choices))}" if choices else "a string"
            self.fail(key, f"expected {want}, got {_show(value)}")
        return value

    def vector(self, value, key: str, n: int = 3, allow_scalar: bool = False) -> tuple:
        if allow_scalar and isinstance(value, (int, float)) and not isinstance(value, bool):
            return tuple([self.number(value, key)] * n)
        if not isinstance(value, list) or len(value) != n or \
                not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                        for v in value):
            self.fail(key, f"expected {n} numbers, got {_show(value)}")
        return tuple(float(v) for v in value)

    def color(self, value, key: str) -> tuple:
        rgb = self.vector(value, key, 3, allow_scalar=True)
        if min(rgb) < 0:
            self.fail(key, f"expected non-negative colour values, got {_show(value)}")
        return rgb

    def file(self, value, key: str) -> Path:
        name = self.string(value, key)
        try:
            return self.files.resolve(name, self.path, what="file", field=excerpt(key, 120, quote=False))
        except MissingFile:
            self.fail(key, f"no such file {excerpt(name)} (relative to {self.path.parent})")

    def spectrum(self, value, key: str):
        """A colour field: a number, 3 numbers, a texture table, or the name of a texture
        of the [textures] section."""
        if isinstance(value, str):
            if value not in self.textures:
                self.fail(key, f"no texture named {excerpt(value)} (defined: "
                          f"{excerpt(', '.join(self.textures), quote=False) or 'none'})")
            return self.textures[value]
        if isinstance(value, dict):
            return _texture(self, key, value)
        return self.color(value, key)


def _show(value) -> str:
    """A value from the file, for a message: escaped and cut (diagnostics.excerpt)."""
    return f'"{excerpt(value, 58, quote=False)}"' if isinstance(value, str) else excerpt(value, 60)


def _check_keys(ctx: _Ctx, table: dict, key: str, allowed: set[str]):
    for name in table:
        if name not in allowed:
            where = f"{key}.{name}" if key else str(name)
            ctx.fail(where, f"unknown field (expected one of {', '.join(sorted(allowed))})")


# -- transforms --------------------------------------------------------------------------
def _transform(ctx: _Ctx, value, key: str) -> np.ndarray:
    """A matrix (16 numbers, row-major), one operation table, or a list of them applied in order."""
    if isinstance(value, list) and value and all(isinstance(v, (int, float)) for v in value):
        if len(value) != 16:
            ctx.fail(key, f"expected 16 numbers (a row-major 4x4 matrix), got {len(value)}")
        return np.array(ctx.vector(value, key, 16)).reshape(4, 4)
    ops = value if isinstance(value, list) else [value]
    M = np.eye(4)
    for i, op in enumerate(ops):
        k = f"{key}[{i}]" if isinstance(value, list) else key
        op = ctx.table(op, k)
        if len(op) != 1:
            ctx.fail(k, "expected one operation per table: translate, rotate, scale, matrix or look_at")
        (name, arg), = op.items()
        if name == "translate":
            T = m.translate(ctx.vector(arg, f"{k}.translate"))
        elif name == "scale":
            T = m.scale(ctx.vector(arg, f"{k}.scale", allow_scalar=True))
        elif name == "rotate":
            arg = ctx.table(arg, f"{k}.rotate")
            _check_keys(ctx, arg, f"{k}.rotate", {"axis", "angle"})
            T = m.rotate(ctx.vector(arg.get("axis"), f"{k}.rotate.axis"),
                         ctx.number(arg.get("angle"), f"{k}.rotate.angle"))
        elif name == "matrix":
            T = np.array(ctx.vector(arg, f"{k}.matrix", 16)).reshape(4, 4)
        elif name == "look_at":
            T = _look_at(ctx, arg, f"{k}.look_at")
        else:
            ctx.fail(k, f"unknown transform {excerpt(name)} (expected translate, rotate, scale, matrix, look_at)")
        M = T @ M
    return M


def _look_at(ctx: _Ctx, arg, key: str) -> np.ndarray:
    arg = ctx.table(arg, key)
    _check_keys(ctx, arg, key, {"origin", "target", "up"})
    try:
        return m.look_at(ctx.vector(arg.get("origin"), f"{key}.origin"),
                         ctx.vector(arg.get("target"), f"{key}.target"),
                         ctx.vector(arg.get("up", [0, 1, 0]), f"{key}.up"))
    except SceneError as exc:
        ctx.fail(key, str(exc).split(": ", 1)[-1])


# -- sections ------------------------------------------------------------------------------
def _film(ctx, t) -> m.Film:
    t = ctx.table(t, "film")
    _check_keys(ctx, t, "film", {"width", "height", "filter", "filter_radius", "stddev", "b", "c"})
    f = m.Film()
    f.width = ctx.number(t.get("width", f.width), "film.width", 1, 65536, integer=True)
    f.height = ctx.number(t.get("height", f.height), "film.height", 1, 65536, integer=True)
    f.filter = ctx.string(t.get("filter", f.filter), "film.filter", m.FILTERS)
    if "filter_radius" in t:
        f.filter_radius = ctx.number(t["filter_radius"], "film.filter_radius", 1e-3, 16)
    f.gaussian_stddev = ctx.number(t.get("stddev", f.gaussian_stddev), "film.stddev", 1e-3, 8)
    f.mitchell_b = ctx.number(t.get("b", f.mitchell_b), "film.b")
    f.mitchell_c = ctx.number(t.get("c", f.mitchell_c), "film.c")
    return f


def _camera(ctx, t, media: dict[str, int]) -> m.Camera:
    t = ctx.table(t, "camera")
    _check_keys(ctx, t, "camera", {"kind", "fov", "fov_axis", "half_extent", "look_at", "transform",
                                   "transform_close", "aperture_radius", "focus_distance",
                                   "near_clip", "far_clip", "medium"})
    c = m.Camera()
    if "medium" in t:
        c.medium = _medium_ref(ctx, t["medium"], "camera.medium", media)
    c.kind = ctx.string(t.get("kind", c.kind), "camera.kind", m.CAMERA_KINDS)
    # each kind's own keys: another kind's are refused, not ignored
    foreign = {"orthographic": {"fov": "its view is half_extent wide on either side of the axis",
                                "aperture_radius": "it has no lens", "focus_distance": "it has no lens"},
               "perspective": {"half_extent": "its view is set by fov (or give kind = \"orthographic\")"}}
    for key, why in foreign[c.kind].items():
        if key in t:
            article = "an" if c.kind == "orthographic" else "a"
            ctx.fail(f"camera.{key}", f"{article} {c.kind} camera has no {key}: {why}")
    if "half_extent" in t:
        c.half_extent = ctx.number(t["half_extent"], "camera.half_extent", 0)
        if not c.half_extent > 0:
            ctx.fail("camera.half_extent", f"expected a positive length, got {c.half_extent}")
    if "look_at" in t and "transform" in t:
        ctx.fail("camera", "give look_at or transform, not both")
    if "look_at" in t:
        c.world_from_camera = _look_at(ctx, t["look_at"], "camera.look_at")
    elif "transform" in t:
        c.world_from_camera = _transform(ctx, t["transform"], "camera.transform")
    if "transform_close" in t:
        c.world_from_camera_close = _transform(ctx, t["transform_close"], "camera.transform_close")
    c.fov = ctx.number(t.get("fov", c.fov), "camera.fov", 1e-3, 179.9)
    c.fov_axis = ctx.string(t.get("fov_axis", c.fov_axis), "camera.fov_axis",
                            ("x", "y", "smaller", "larger", "diagonal"))
    c.aperture_radius = ctx.number(t.get("aperture_radius", 0.0), "camera.aperture_radius", 0)
    c.focus_distance = ctx.number(t.get("focus_distance", c.focus_distance), "camera.focus_distance", 1e-6)
    c.near_clip = ctx.number(t.get("near_clip", c.near_clip), "camera.near_clip", 0)
    c.far_clip = ctx.number(t.get("far_clip", c.far_clip), "camera.far_clip", 0)
    if c.far_clip <= c.near_clip:
        ctx.fail("camera.far_clip", f"expected a value above near_clip ({c.near_clip}), got {c.far_clip}")
    return c


def _integrator(ctx, t) -> m.Integrator:
    t = ctx.table(t, "integrator")
    _check_keys(ctx, t, "integrator", {"type", "max_depth", "rr_depth", "strategy", "emitter_samples",
                                       "bsdf_samples", "light_selection", "area_sampling",
                                       "hide_emitters", "ao_distance", "rr", "light_samples",
                                       "split"})
    i = m.Integrator()
    i.kind = ctx.string(t.get("type", i.kind), "integrator.type", m.INTEGRATORS)
    i.max_depth = ctx.number(t.get("max_depth", i.max_depth), "integrator.max_depth", -1, 1 << 20, integer=True)
    if i.max_depth == 0:
        ctx.fail("integrator.max_depth", "expected -1 (unbounded) or an integer >= 1, got 0")
    i.rr_depth = ctx.number(t.get("rr_depth", i.rr_depth), "integrator.rr_depth", 1, 1 << 20, integer=True)
    i.rr = ctx.string(t.get("rr", i.rr), "integrator.rr")
    try:
        m.parse_rr(i.rr)
    except m.SceneError as exc:
        ctx.fail("integrator.rr", str(exc).split(": ", 1)[1])
    i.light_samples = ctx.number(t.get("light_samples", 1), "integrator.light_samples", 1,
                                 m.SPLIT_LIMIT, integer=True)
    i.split = ctx.number(t.get("split", 1), "integrator.split", 1, m.SPLIT_LIMIT, integer=True)
    i.strategy = ctx.string(t.get("strategy", i.strategy), "integrator.strategy", m.STRATEGIES)
    i.emitter_samples = ctx.number(t.get("emitter_samples", 1), "integrator.emitter_samples", 0, 64, integer=True)
    i.bsdf_samples = ctx.number(t.get("bsdf_samples", 1), "integrator.bsdf_samples", 0, 64, integer=True)
    i.light_selection = ctx.string(t.get("light_selection", i.light_selection),
                                   "integrator.light_selection", m.LIGHT_SELECTIONS)
    i.area_sampling = ctx.string(t.get("area_sampling", i.area_sampling), "integrator.area_sampling",
                                 ("area", "solid-angle"))
    i.hide_emitters = ctx.boolean(t.get("hide_emitters", False), "integrator.hide_emitters")
    i.ao_distance = ctx.number(t.get("ao_distance", 1e30), "integrator.ao_distance", 0)
    return i


def _sampler(ctx, t) -> m.Sampler:
    t = ctx.table(t, "sampler")
    _check_keys(ctx, t, "sampler", {"type", "spp", "seed"})
    s = m.Sampler()
    s.kind = ctx.string(t.get("type", s.kind), "sampler.type", m.SAMPLER_KINDS)
    s.spp = ctx.number(t.get("spp", s.spp), "sampler.spp", 1, 1 << 30, integer=True)
    s.seed = ctx.number(t.get("seed", s.seed), "sampler.seed", 0, 2 ** 32 - 1, integer=True)
    return s


def _shutter(ctx, t) -> m.Shutter:
    t = ctx.table(t, "shutter")
    _check_keys(ctx, t, "shutter", {"open", "close", "function"})
    s = m.Shutter(ctx.number(t.get("open", 0.0), "shutter.open"),
                  ctx.number(t.get("close", 0.0), "shutter.close"),
                  ctx.string(t.get("function", "box"), "shutter.function", ("box", "tent")))
    if s.close < s.open:
        ctx.fail("shutter.close", f"expected a time >= open ({s.open}), got {s.close}")
    return s


_TEXTURE_FIELDS = {"type", "file", "filter", "wrap", "raw", "color0", "color1", "uv_scale",
                   "uv_offset", "uv_transform"}


def _texture(ctx, key: str, t) -> m.Texture:
    """A bitmap or checkerboard; uv' = uv_transform (3x3, row-major) or scale then offset."""
    t = ctx.table(t, key)
    _check_keys(ctx, t, key, _TEXTURE_FIELDS)
    kind = ctx.string(t.get("type", "bitmap"), f"{key}.type", ("bitmap", "checkerboard"))
    tex = m.Texture(kind, name=key.split(".")[-1])
    tex.filter = ctx.string(t.get("filter", "bilinear"), f"{key}.filter", ("bilinear", "nearest"))
    tex.wrap = ctx.string(t.get("wrap", "repeat"), f"{key}.wrap", ("repeat", "mirror", "clamp"))
    if "uv_transform" in t:
        if "uv_scale" in t or "uv_offset" in t:
            ctx.fail(key, "give uv_transform or uv_scale/uv_offset, not both")
        tex.uv_transform = np.array(ctx.vector(t["uv_transform"], f"{key}.uv_transform", 9)).reshape(3, 3)
    else:
        su, sv = ctx.vector(t.get("uv_scale", 1.0), f"{key}.uv_scale", 2, allow_scalar=True)
        ou, ov = ctx.vector(t.get("uv_offset", [0.0, 0.0]), f"{key}.uv_offset", 2)
        tex.uv_transform = np.array([[su, 0, ou], [0, sv, ov], [0, 0, 1]], np.float64)
    if kind == "bitmap":
        path = ctx.file(t.get("file"), f"{key}.file")
        raw = ctx.boolean(t.get("raw", False), f"{key}.raw")
        try:
            image = read_image_checked(path)
        except SceneError as exc:
            ctx.fail(f"{key}.file", f"image {excerpt(t['file'])}: {exc}")
        if raw and path.suffix.lower() in (".png", ".jpg", ".jpeg"):
            from ...film.io import linear_to_srgb

            image = linear_to_srgb(image).astype(np.float32)   # undo the sRGB decode
        tex.image = image
    else:
        tex.color0 = ctx.color(t.get("color0", 0.4), f"{key}.color0")
        tex.color1 = ctx.color(t.get("color1", 0.2), f"{key}.color1")
    return tex


_MATERIAL_FIELDS = {"type", "reflectance", "specular_reflectance", "specular_transmittance", "eta",
                    "k", "int_ior", "ext_ior", "alpha", "distribution", "nonlinear", "two_sided",
                    "material", "normal_map", "normal_scale", "normal_shadowing", "normal_flip",
                    "opacity", "alpha_cutoff", "metallic_roughness"}
# Mitsuba's default interior IOR per kind ("bk7" for dielectrics, "polypropylene" for plastics)
_DEFAULT_INT_IOR = {"plastic": "polypropylene", "roughplastic": "polypropylene"}


def _ior(ctx, value, key: str) -> float:
    """An IOR given as a number or by Mitsuba's name ("bk7", "water", "air", ...)."""
    from ..materials import dielectric_ior

    if isinstance(value, str):
        try:
            return dielectric_ior(value)
        except SceneError as exc:
            ctx.fail(key, str(exc))
    return ctx.number(value, key, 1e-3, 100)


def _material(ctx, name: str, t) -> m.Material:
    from ..materials import conductor_ior, dielectric_ior

    key = f"materials.{name}"
    t = ctx.table(t, key)
    _check_keys(ctx, t, key, _MATERIAL_FIELDS)
    kind = ctx.string(t.get("type", "diffuse"), f"{key}.type", m.MATERIAL_KINDS)
    mat = m.Material(kind=kind, name=name)
    for field_name in ("reflectance", "specular_reflectance", "specular_transmittance",
                       "metallic_roughness"):
        if field_name in t:
            setattr(mat, field_name, ctx.spectrum(t[field_name], f"{key}.{field_name}"))
    for field_name in ("eta", "k"):
        if field_name in t:
            setattr(mat, field_name, ctx.color(t[field_name], f"{key}.{field_name}"))
    if "material" in t:
        # a named conductor, as Mitsuba's `material` parameter ("Au", "Cu", "none", ...)
        if kind not in ("conductor", "roughconductor"):
            ctx.fail(f"{key}.material", f"named materials are for conductor and roughconductor, "
                     f"not {kind}")
        if "eta" in t or "k" in t:
            ctx.fail(f"{key}.material", "give either eta and k or material, not both")
        try:
            mat.eta, mat.k = conductor_ior(ctx.string(t["material"], f"{key}.material"))
        except SceneError as exc:
            ctx.fail(f"{key}.material", str(exc))
    if kind in _DEFAULT_INT_IOR:
        mat.int_ior = dielectric_ior(_DEFAULT_INT_IOR[kind])
    for field_name in ("int_ior", "ext_ior"):
        if field_name in t:
            setattr(mat, field_name, _ior(ctx, t[field_name], f"{key}.{field_name}"))
    if "alpha" in t:
        a = t["alpha"]
        mat.alpha = (ctx.vector(a, f"{key}.alpha", 2) if isinstance(a, list)
                     else (ctx.number(a, f"{key}.alpha", 1e-4, 10),) * 2)
    mat.distribution = ctx.string(t.get("distribution", "beckmann"), f"{key}.distribution", ("ggx", "beckmann"))
    mat.nonlinear = ctx.boolean(t.get("nonlinear", False), f"{key}.nonlinear")
    mat.two_sided = ctx.boolean(t.get("two_sided", False), f"{key}.two_sided")
    for field_name in ("normal_map", "opacity"):
        if field_name in t:
            value = t[field_name]
            if not isinstance(value, (str, dict)):
                ctx.fail(f"{key}.{field_name}", f"expected a texture (a [textures] name or a "
                         f"table), got {_show(value)}")
            setattr(mat, field_name, ctx.spectrum(value, f"{key}.{field_name}"))
    if "normal_scale" in t:
        mat.normal_scale = ctx.number(t["normal_scale"], f"{key}.normal_scale", -100, 100)
    for field_name in ("normal_shadowing", "normal_flip"):
        if field_name in t:
            if "normal_map" not in t:
                ctx.fail(f"{key}.{field_name}", "applies to a normal map: give normal_map too")
            setattr(mat, field_name, ctx.boolean(t[field_name], f"{key}.{field_name}"))
    if "alpha_cutoff" in t:
        mat.alpha_cutoff = ctx.number(t["alpha_cutoff"], f"{key}.alpha_cutoff", 0, 1)
    return mat


def _shape(ctx, i: int, t, materials: dict[str, int], media: dict[str, int]) -> list[m.Shape]:
    key = f"shapes[{i}]"
    t = ctx.table(t, key)
    _check_keys(ctx, t, key, {"type", "material", "transform", "transform_close", "emission", "file",
                              "center", "radius", "flip_normals", "face_normals", "name",
                              "interior", "exterior", "instances"})
    kind = ctx.string(t.get("type"), f"{key}.type", ("rectangle", "cube", "sphere", "disk", "mesh"))
    mat_name = ctx.string(t.get("material"), f"{key}.material")
    if mat_name not in materials:
        ctx.fail(f"{key}.material", f"no material named {excerpt(mat_name)} (defined: "
                 f"{excerpt(', '.join(materials), quote=False) or 'none'})")
    shape = m.Shape(kind=kind, material=materials[mat_name], name=str(t.get("name", f"shape {i}")))
    if "transform" in t:
        shape.world_from_object = _transform(ctx, t["transform"], f"{key}.transform")
    if "transform_close" in t:
        shape.world_from_object_close = _transform(ctx, t["transform_close"], f"{key}.transform_close")
    if "emission" in t:
        e = ctx.table(t["emission"], f"{key}.emission")
        _check_keys(ctx, e, f"{key}.emission", {"radiance", "two_sided"})
        shape.emission = m.Emission(ctx.color(e.get("radiance"), f"{key}.emission.radiance"),
                                    ctx.boolean(e.get("two_sided", False), f"{key}.emission.two_sided"))
    shape.flip_normals = ctx.boolean(t.get("flip_normals", False), f"{key}.flip_normals")
    for side in ("interior", "exterior"):
        if side in t:
            setattr(shape, side, _medium_ref(ctx, t[side], f"{key}.{side}", media))
    shape.face_normals = ctx.boolean(t.get("face_normals", False), f"{key}.face_normals")
    if kind == "sphere":
        shape.center = ctx.vector(t.get("center", [0, 0, 0]), f"{key}.center")
        shape.radius = ctx.number(t.get("radius", 1.0), f"{key}.radius", 1e-9)
    if kind == "mesh":
        path = ctx.file(t.get("file"), f"{key}.file")
        from .mesh_files import read_mesh

        mesh = read_mesh(path, ctx.files)
        shape.vertices, shape.triangles, shape.normals, shape.uvs = \
            mesh.vertices, mesh.triangles, mesh.normals, mesh.uvs
    if "instances" in t:
        if kind != "mesh":
            ctx.fail(f"{key}.instances", f"only meshes are instanced, this is a {kind}")
        shape.instances = _instances(ctx, t["instances"], f"{key}.instances")
    if kind == "disk":
        from .meshes import disk_shape

        shape = disk_shape(shape)
    return [shape]


def _instances(ctx: _Ctx, value, key: str) -> np.ndarray:
    """(K, 4, 4) transforms: an array of transforms (each as ``transform``), or a ``.npy``
    file of K row-major 4x4 matrices, shape (K, 4, 4) or (K, 16)."""
    if isinstance(value, str):
        path = ctx.file(value, key)
        if path.suffix.lower() != ".npy":
            ctx.fail(key, f"expected a .npy file of 4x4 matrices, got {excerpt(value)}")
        try:
            data = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            ctx.fail(key, f"cannot read {excerpt(value)} as a numpy array ({cause(exc)})")
        if data.dtype.kind not in "fiu" or data.ndim not in (2, 3) or not len(data) or \
                data.shape[1:] not in ((4, 4), (16,)):
            ctx.fail(key, f"{excerpt(value)}: expected K row-major 4x4 matrices, shape (K, 4, 4) or "
                          f"(K, 16), got {data.dtype} {tuple(data.shape)}")
        data = np.asarray(data, np.float64).reshape(-1, 4, 4)
        bad = np.flatnonzero(~np.isfinite(data).all(axis=(1, 2)) |
                             ~np.isclose(data[:, 3], [0, 0, 0, 1]).all(axis=1))
        if len(bad):
            ctx.fail(key, f"{excerpt(value)}: matrix {bad[0]} is not finite with last row (0, 0, 0, 1)")
        return data
    if not isinstance(value, list) or not value:
        ctx.fail(key, f"expected an array of transforms or a .npy file name, got {_show(value)}")
    return np.stack([_transform(ctx, v, f"{key}[{i}]") for i, v in enumerate(value)])


# -- participating media ----------------------------------------------------------------------
_MEDIUM_FIELDS = {"type", "sigma_t", "albedo", "sigma_a", "sigma_s", "scale", "sample_emitters",
                  "phase"}
_GRID_FIELDS = {"file", "transform", "filter", "use_grid_bbox"}


def _medium(ctx, name: str, t) -> m.Medium:
    """[media.NAME]: Mitsuba's homogeneous and heterogeneous media; sigma_a / sigma_s (constants)
    stand for sigma_t and albedo."""
    from .media import MEDIUM_KINDS, absorption_scattering, check_scale

    key = f"media.{name}"
    t = ctx.table(t, key)
    _check_keys(ctx, t, key, _MEDIUM_FIELDS)
    kind = ctx.string(t.get("type", "homogeneous"), f"{key}.type", MEDIUM_KINDS)
    medium = m.Medium(kind, name=name)
    if "sigma_a" in t or "sigma_s" in t:
        given = sorted({"sigma_t", "albedo"} & set(t))
        if given:
            ctx.fail(f"{key}.{given[0]}", "give sigma_t and albedo, or sigma_a and sigma_s, not both")
        if kind == "heterogeneous":
            ctx.fail(key, "sigma_a and sigma_s are constants; a heterogeneous medium's sigma_t is "
                     "a grid (give sigma_t = { file = ... } and albedo)")
        a, s = (_medium_constant(ctx, t.get(k, 0.0), f"{key}.{k}", "sigma_t")
                for k in ("sigma_a", "sigma_s"))
        medium.sigma_t, medium.albedo = absorption_scattering(a, s)
    else:
        if kind == "heterogeneous" and not isinstance(t.get("sigma_t"), dict):
            got = f", got {_show(t['sigma_t'])}" if "sigma_t" in t else ""
            ctx.fail(f"{key}.sigma_t", f"a heterogeneous medium's sigma_t is a grid: expected "
                     f"{{ file = ... }}{got}")
        if kind == "homogeneous" and isinstance(t.get("sigma_t"), dict):
            ctx.fail(f"{key}.sigma_t", "a homogeneous medium's sigma_t is a constant (a grid "
                     "needs type = \"heterogeneous\")")
        for field_name in ("sigma_t", "albedo"):
            if field_name in t:
                setattr(medium, field_name, _medium_value(ctx, t[field_name], f"{key}.{field_name}",
                                                          field_name))
    if "scale" in t:
        scale = ctx.number(t["scale"], f"{key}.scale")
        try:
            medium.scale = check_scale(scale)
        except SceneError as exc:
            ctx.fail(f"{key}.scale", str(exc))
    medium.sample_emitters = ctx.boolean(t.get("sample_emitters", True), f"{key}.sample_emitters")
    if "phase" in t:
        medium.phase, medium.g = _phase(ctx, t["phase"], f"{key}.phase")
    return medium


def _phase(ctx, value, key: str) -> tuple[str, float]:
    """``"isotropic"``, ``"hg"`` (g = 0.8, Mitsuba's default) or ``{ type = "hg", g = ... }``."""
    from .media import HG_DEFAULT_G, PHASES, check_g

    t = {"type": value} if isinstance(value, str) else ctx.table(value, key)
    _check_keys(ctx, t, key, {"type", "g"})
    kind = ctx.string(t.get("type"), f"{key}.type", PHASES)
    if kind == "isotropic":
        if "g" in t:
            ctx.fail(f"{key}.g", "an isotropic phase function has no g (give type = \"hg\")")
        return kind, 0.0
    g = ctx.number(t.get("g", HG_DEFAULT_G), f"{key}.g")
    try:
        return kind, check_g(g)
    except SceneError as exc:
        ctx.fail(f"{key}.g", str(exc))


def _medium_constant(ctx, value, key: str, role: str) -> m.RGB:
    from .media import check_value

    rgb = ctx.vector(value, key, 3, allow_scalar=True)
    try:
        return check_value(rgb, role)
    except SceneError as exc:
        ctx.fail(key, str(exc))


def _medium_value(ctx, value, key: str, role: str) -> m.MediumValue:
    """A number, [r, g, b], or a grid table { file, transform, filter, use_grid_bbox }."""
    from .media import check_value
    from .volumes import grid_volume, read_grid

    if not isinstance(value, dict):
        return _medium_constant(ctx, value, key, role)
    _check_keys(ctx, value, key, _GRID_FIELDS)
    path = ctx.file(value.get("file"), f"{key}.file")
    to_world = _transform(ctx, value["transform"], f"{key}.transform") if "transform" in value else None
    filt = ctx.string(value.get("filter", "trilinear"), f"{key}.filter", ("trilinear", "nearest"))
    use_grid_bbox = ctx.boolean(value.get("use_grid_bbox", False), f"{key}.use_grid_bbox")
    try:
        grid = read_grid(path)
    except SceneError as exc:
        ctx.fail(f"{key}.file", f"volume {excerpt(value['file'])}: {exc}")
    try:
        volume = grid_volume(grid, to_world, filt, use_grid_bbox, name=path.name)
    except SceneError as exc:
        ctx.fail(key, str(exc))
    try:
        return check_value(volume, role)
    except SceneError as exc:
        ctx.fail(f"{key}.file", f"volume {excerpt(value['file'])}: {exc}")


def _medium_ref(ctx, value, key: str, media: dict[str, int]) -> int:
    name = ctx.string(value, key)
    if name not in media:
        ctx.fail(key, f"no medium named {excerpt(name)} (defined: "
                 f"{excerpt(', '.join(media), quote=False) or 'none'})")
    return media[name]


_LIGHT_FIELDS = {"type", "position", "intensity", "power", "transform", "cutoff_angle", "beam_width",
                 "direction", "irradiance", "radiance", "file", "scale", "name"}


def _light(ctx, i: int, t) -> m.Light:
    key = f"lights[{i}]"
    t = ctx.table(t, key)
    _check_keys(ctx, t, key, _LIGHT_FIELDS)
    kind = ctx.string(t.get("type"), f"{key}.type", m.Light.KINDS)
    light = m.Light(kind=kind, name=str(t.get("name", f"light {i}")))
    if kind in ("point", "spot"):
        if "power" in t and "intensity" in t:
            ctx.fail(key, "give intensity or power, not both")
        if "power" in t:
            light.power = ctx.color(t["power"], f"{key}.power")
        else:
            light.intensity = ctx.color(t.get("intensity", [1, 1, 1]), f"{key}.intensity")
    if kind == "point":
        light.position = ctx.vector(t.get("position", [0, 0, 0]), f"{key}.position")
    if kind == "spot":
        if "transform" in t:
            light.world_from_light = _transform(ctx, t["transform"], f"{key}.transform")
        light.cutoff_angle = ctx.number(t.get("cutoff_angle", 20.0), f"{key}.cutoff_angle", 0.01, 90)
        light.beam_width = ctx.number(t.get("beam_width", light.cutoff_angle * 0.75), f"{key}.beam_width", 0, 90)
    if kind == "directional":
        light.direction = ctx.vector(t.get("direction", [0, 0, -1]), f"{key}.direction")
        if np.linalg.norm(light.direction) == 0:
            ctx.fail(f"{key}.direction", "expected a non-zero vector")
        light.irradiance = ctx.color(t.get("irradiance", [1, 1, 1]), f"{key}.irradiance")
    if kind == "constant":
        light.radiance = ctx.color(t.get("radiance", [1, 1, 1]), f"{key}.radiance")
    if kind == "envmap":
        path = ctx.file(t.get("file"), f"{key}.file")
        try:
            light.image = read_image_checked(path, environment=True)
        except SceneError as exc:
            ctx.fail(f"{key}.file", f"image {excerpt(t['file'])}: {exc}")
        light.scale = ctx.number(t.get("scale", 1.0), f"{key}.scale", 0)
        if "transform" in t:
            light.world_from_light = _transform(ctx, t["transform"], f"{key}.transform")
    return light


_TOP = {"film", "camera", "integrator", "sampler", "shutter", "materials", "shapes", "lights",
        "textures", "media", "include", "params", "animation"}
_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


def _read(path: Path) -> dict:
    try:
        text = read_bytes(path, MAX_FILE_BYTES).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: cannot read ({exc})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: invalid TOML: {cause(exc)}") from None
    except RecursionError:
        raise SceneError(f"{path}: invalid TOML: nested too deeply") from None


def _convert(value, default, ctx: _Ctx, name: str):
    """A parameter given from outside (often a string from the command line) in the type
    of its default."""
    if not isinstance(value, str) or isinstance(default, str):
        return value
    try:
        if isinstance(default, bool):
            if value.lower() not in ("true", "false"):
                raise ValueError
            return value.lower() == "true"
        if isinstance(default, int):
            return int(value)
        if isinstance(default, float):
            return float(value)
        if default is None:
            return tomllib.loads(f"x = {value}")["x"]
    except (ValueError, tomllib.TOMLDecodeError):
        if default is None:
            return value
        ctx.fail(f"params.{name}", f"expected a value like {_show(default)}, got {_show(value)}")
    return value


def _substitute(ctx: _Ctx, value, key: str, used: set):
    """Replace $name in strings: a whole-string reference takes the parameter's value and
    type, a reference inside a longer string its text. Nothing is evaluated."""
    if isinstance(value, dict):
        return {k: _substitute(ctx, v, f"{key}.{k}" if key else k, used) for k, v in value.items()}
    if isinstance(value, list):
        return [_substitute(ctx, v, f"{key}[{i}]", used) for i, v in enumerate(value)]
    if not isinstance(value, str) or "$" not in value:
        return value

    def lookup(name):
        if name not in ctx.params:
            ctx.fail(key, f"unknown parameter ${name} (declare it in [params] or pass it in)")
        used.add(name)
        return ctx.params[name]

    whole = _PARAM.fullmatch(value)
    if whole:
        return lookup(whole.group(1))
    return _PARAM.sub(lambda mt: str(lookup(mt.group(1))), value)


class _State:
    def __init__(self, scene: m.Scene, files: SceneFiles):
        self.scene, self.files = scene, files
        self.materials: dict[str, int] = {}
        self.textures: dict[str, m.Texture] = {}
        self.media: dict[str, int] = {}
        self.has_camera = False
        self.used: set[str] = set()
        self.animation = None          # (ctx, table) of the last [animation], read at the end


def _load_file(path: Path, params: dict, state: _State, stack: tuple) -> None:
    if len(stack) >= MAX_INCLUDE_DEPTH:
        raise SceneError(f"{stack[-1]}: includes nest deeper than {MAX_INCLUDE_DEPTH} levels")
    resolved = path.resolve()
    if resolved in stack:
        chain = " -> ".join(str(p) for p in stack + (resolved,))
        raise SceneError(f"{path}: include cycle: {chain}")
    data = _read(path)
    ctx = _Ctx(path, {}, state.files)
    ctx.textures = state.textures
    _check_keys(ctx, data, "", _TOP)
    declared = ctx.table(data.pop("params", {}), "params")
    for name, default in declared.items():
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            ctx.fail(f"params.{name}", "expected a name of letters, digits and underscores")
        ctx.params[name] = _convert(params[name], default, ctx, name) if name in params else default
    for name, value in params.items():
        ctx.params.setdefault(name, value if not isinstance(value, str) else _convert(value, None, ctx, name))
    data = _substitute(ctx, data, "", state.used)
    scene = state.scene
    includes = data.get("include", [])
    if isinstance(includes, str):
        includes = [includes]
    if not isinstance(includes, list):
        ctx.fail("include", f"expected a file name or a list of them, got {_show(includes)}")
    for i, name in enumerate(includes):
        inc = ctx.file(name, f"include[{i}]")
        _load_file(inc, ctx.params, state, stack + (resolved,))
    if "film" in data:
        scene.film = _film(ctx, data["film"])
    for name, t in ctx.table(data.get("media", {}), "media").items():
        state.media[name] = scene.add_medium(_medium(ctx, name, t))
    if "camera" in data:
        scene.camera = _camera(ctx, data["camera"], state.media)
        state.has_camera = True
    if "integrator" in data:
        scene.integrator = _integrator(ctx, data["integrator"])
    if "sampler" in data:
        scene.sampler = _sampler(ctx, data["sampler"])
    if "shutter" in data:
        scene.shutter = _shutter(ctx, data["shutter"])
    for name, t in ctx.table(data.get("textures", {}), "textures").items():
        state.textures[name] = _texture(ctx, f"textures.{name}", t)
    for name, t in ctx.table(data.get("materials", {}), "materials").items():
        state.materials[name] = scene.add_material(_material(ctx, name, t))
    shapes = data.get("shapes", [])
    if not isinstance(shapes, list):
        ctx.fail("shapes", "expected an array of tables ([[shapes]])")
    for i, t in enumerate(shapes):
        scene.shapes.extend(_shape(ctx, i, t, state.materials, state.media))
    lights = data.get("lights", [])
    if not isinstance(lights, list):
        ctx.fail("lights", "expected an array of tables ([[lights]])")
    for i, t in enumerate(lights):
        scene.lights.append(_light(ctx, i, t))
    if "animation" in data:
        state.animation = (ctx, data["animation"])


def _animation(ctx: _Ctx, t, scene: m.Scene):
    """[animation]: fps, the default frame range, [[animation.camera]] keys (time and
    look_at or transform) and [[animation.shapes]] (a shape's name and its keys), read
    once every file is loaded so that keys may name shapes of any file."""
    from ..animation import Animation, Track

    t = ctx.table(t, "animation")
    _check_keys(ctx, t, "animation", {"fps", "frames", "camera", "shapes"})
    fps = ctx.number(t.get("fps", 24.0), "animation.fps", 1e-6, 1e6)
    frames = None
    if "frames" in t:
        first, last = ctx.vector(t["frames"], "animation.frames", 2)
        if first != int(first) or last != int(last) or not 0 <= first <= last:
            ctx.fail("animation.frames", f"expected [first, last] integers with 0 <= first <= "
                     f"last, got {_show(t['frames'])}")
        frames = (int(first), int(last))

    def track(keys, key: str, camera: bool) -> Track:
        if not isinstance(keys, list) or not keys:
            ctx.fail(key, "expected an array of key tables ({time = ..., transform = ...})")
        times, matrices = [], []
        for i, k in enumerate(keys):
            kk = f"{key}[{i}]"
            k = ctx.table(k, kk)
            _check_keys(ctx, k, kk, {"time", "transform", "look_at"} if camera else {"time", "transform"})
            times.append(ctx.number(k.get("time"), f"{kk}.time"))
            if camera and "look_at" in k:
                if "transform" in k:
                    ctx.fail(kk, "give look_at or transform, not both")
                matrices.append(_look_at(ctx, k["look_at"], f"{kk}.look_at"))
            elif "transform" in k:
                matrices.append(_transform(ctx, k["transform"], f"{kk}.transform"))
            else:
                ctx.fail(kk, "expected a transform" + (" or look_at" if camera else ""))
        try:
            return Track(tuple(times), tuple(matrices), name=key)
        except SceneError as exc:
            ctx.fail(key, str(exc).split(": ", 1)[-1])

    camera = track(t["camera"], "animation.camera", True) if "camera" in t else None
    shapes = {}
    entries = t.get("shapes", [])
    if not isinstance(entries, list):
        ctx.fail("animation.shapes", "expected an array of tables ([[animation.shapes]])")
    for i, e in enumerate(entries):
        key = f"animation.shapes[{i}]"
        e = ctx.table(e, key)
        _check_keys(ctx, e, key, {"shape", "keys"})
        name = ctx.string(e.get("shape"), f"{key}.shape")
        found = [j for j, shape in enumerate(scene.shapes) if shape.name == name]
        if len(found) != 1:
            ctx.fail(f"{key}.shape", f"names {len(found)} shapes ({excerpt(name)}); key exactly one "
                     f"shape, by a unique name")
        if found[0] in shapes:
            ctx.fail(f"{key}.shape", f"{excerpt(name)} is keyed twice")
        shapes[found[0]] = track(e.get("keys"), f"{key}.keys", False)
    try:
        return Animation(fps, frames, camera, shapes)
    except SceneError as exc:
        ctx.fail("animation", str(exc).split(": ", 1)[-1])


def load_toml(path, **params) -> m.Scene:
    """Load a native TOML scene; ``params`` override its [params] defaults."""
    from .finish import finish_scene

    path = Path(path)
    scene = m.Scene(source=str(path))
    state = _State(scene, SceneFiles(path.parent))
    _load_file(path, params, state, ())
    if state.animation is not None:
        scene.animation = _animation(*state.animation, scene)
    unused = sorted(set(params) - state.used)
    if unused:
        warn(f"{path}: parameters given but not used: {', '.join(unused)}")
    if not scene.shapes and not scene.lights:
        raise SceneError(f"{path}: the scene has no shapes and no lights")
    return finish_scene(scene, state.has_camera)
