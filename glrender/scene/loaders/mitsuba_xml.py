"""Mitsuba 3 scene XML (a subset; docs/scene-format.md lists it).

Parsing goes through defusedxml (entity declarations, and so expansion bombs, are
refused) with a line number kept for every element. The file becomes a tree of
plugin nodes first - ``<include>`` spliced in (depth-bounded, cycles refused),
``$name`` substituted from ``<default>`` and the caller's parameters, ``<ref>`` and
``<alias>`` resolved by id (anywhere in the file, as Mitsuba allows) - and is then
interpreted plugin by plugin. Plugins and tags outside the subset are collected and
reported in one warning with their line numbers; Mitsuba's ``.serialized`` meshes
are an error. Spectra given as ``wavelength:value`` lists become RGB as Mitsuba's RGB
variants do (``spectrum_list_to_srgb``, with an analytic CIE 1931 fit).
"""
from __future__ import annotations

import dataclasses
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import SceneError
from .. import model as m
from .diagnostics import Notes, cause, excerpt, read_image_checked, warn
from .scene_files import SceneFiles, read_bytes

MAX_INCLUDE_DEPTH = 16
MAX_FILE_BYTES = 64 << 20
_OBJECT_TAGS = {"scene", "integrator", "sensor", "film", "sampler", "rfilter", "shape", "bsdf",
                "texture", "emitter", "medium", "phase", "volume", "spectrum_plugin"}
_PROPERTY_TAGS = {"integer", "float", "boolean", "string", "rgb", "spectrum", "point", "vector",
                  "transform"}
_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")
_BSDF_TYPES = {"twosided", "normalmap", "mask", "bumpmap", "diffuse", "conductor", "roughconductor",
               "dielectric", "roughdielectric", "thindielectric", "plastic", "roughplastic", "null"}
_TEXTURE_TYPES = {"bitmap", "checkerboard"}
_GRID_TYPES = ("gridvolume", "grid")      # Mitsuba's plugin name, and the one its manual shows


@dataclass
class Node:
    tag: str
    type: str
    line: int
    file: Path
    id: str | None = None
    props: dict = field(default_factory=dict)       # name -> (value, line)
    children: list = field(default_factory=list)    # (name or None, Node or ("ref", id, line))

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}"

    def fail(self, message: str):
        raise SceneError(f"{self.where}: <{self.tag} type=\"{excerpt(self.type, quote=False)}\">: "
                         f"{message}")


# ---- XML to nodes ------------------------------------------------------------------------
def _parse_xml(path: Path) -> ET.Element:
    from defusedxml import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden
    from defusedxml.ElementTree import DefusedXMLParser

    data = read_bytes(path, MAX_FILE_BYTES)

    class Builder(ET.TreeBuilder):
        def start(self, tag, attrs):
            attrs = dict(attrs)
            attrs["__line__"] = str(parser.parser.CurrentLineNumber)
            return super().start(tag, attrs)

    parser = DefusedXMLParser(target=Builder(), forbid_dtd=False, forbid_entities=True,
                              forbid_external=True)
    try:
        parser.feed(data)
        return parser.close()
    except (EntitiesForbidden, DTDForbidden, ExternalReferenceForbidden) as exc:
        raise SceneError(f"{path}: refused: the XML declares entities or external references "
                         f"({type(exc).__name__})") from None
    except ET.ParseError as exc:
        raise SceneError(f"{path}: malformed XML: {cause(exc)}") from None
    except (ValueError, RecursionError) as exc:
        raise SceneError(f"{path}: malformed XML: {cause(exc)}") from None


class _Reader:
    def __init__(self, root_path: Path, params: dict):
        self.files = SceneFiles(root_path.parent)
        self.params = {k: str(v) if not isinstance(v, bool) else str(v).lower() for k, v in params.items()}
        self.defaults: dict[str, str] = {}
        self.used: set[str] = set()
        self.ids: dict[str, Node] = {}
        self.aliases: dict[str, str] = {}
        # Mitsuba resolves relative paths against the main scene's folder too (the
        # fragments of an included file name meshes relative to the top file)
        self.search: list[Path] = [root_path.parent.resolve()]
        self.notes = Notes(root_path, "unsupported Mitsuba features (ignored)")

    def subst(self, value: str, path: Path, line: int) -> str:
        if "$" not in value:
            return value

        def lookup(mt):
            name = mt.group(1)
            if name in self.params:
                self.used.add(name)
                return self.params[name]
            if name in self.defaults:
                return self.defaults[name]
            raise SceneError(f"{path}:{line}: unknown parameter ${name} (no <default name=\"{name}\"> "
                             f"and none given)")
        return _PARAM.sub(lookup, value)

    def attrs(self, el: ET.Element, path: Path) -> tuple[dict, int]:
        line = int(el.attrib.get("__line__", 0))
        return {k: self.subst(v, path, line) for k, v in el.attrib.items() if k != "__line__"}, line

    def read_file(self, path: Path, stack: tuple) -> Node:
        resolved = path.resolve()
        if resolved in stack:
            raise SceneError(f"{path}: include cycle: {' -> '.join(map(str, stack + (resolved,)))}")
        if len(stack) >= MAX_INCLUDE_DEPTH:
            raise SceneError(f"{path}: includes nest deeper than {MAX_INCLUDE_DEPTH} levels")
        root = _parse_xml(path)
        if root.tag != "scene":
            raise SceneError(f"{path}:{root.attrib.get('__line__', 1)}: expected <scene> at the top, "
                             f"got <{excerpt(root.tag, quote=False)}>")
        scene = Node("scene", "scene", int(root.attrib.get("__line__", 1)), path)
        self.fill(scene, root, path, stack + (resolved,))
        return scene

    def fill(self, node: Node, el: ET.Element, path: Path, stack: tuple) -> None:
        for child in el:
            if not isinstance(child.tag, str):
                continue
            a, line = self.attrs(child, path)
            tag = child.tag
            if tag == "default":
                name = a.get("name")
                if not name or "value" not in a:
                    raise SceneError(f"{path}:{line}: <default> needs name and value")
                self.defaults.setdefault(name, a["value"])
            elif tag == "include":
                inc = self.files.resolve(a.get("filename", ""), path, line, "included file",
                                         tuple(self.search))
                if inc.suffix.lower() != ".xml":
                    raise SceneError(f"{path}:{line}: only XML files can be included, got "
                                     f"{excerpt(inc.name)}")
                sub = self.read_file(inc, stack)
                node.children.extend(sub.children)
                for k, v in sub.props.items():
                    node.props.setdefault(k, v)
            elif tag == "path":
                # a folder to look in: the files found there pass the same path policy
                folder = path.parent / a.get("value", "")
                if os.path.isdir(folder):
                    self.search.append(folder.resolve())
            elif tag == "alias":
                if "id" not in a or "as" not in a:
                    raise SceneError(f"{path}:{line}: <alias> needs id and as")
                self.aliases[a["as"]] = a["id"]
            elif tag == "ref":
                if "id" not in a:
                    raise SceneError(f"{path}:{line}: <ref> needs an id")
                node.children.append((a.get("name"), ("ref", a["id"], line)))
            elif tag in _OBJECT_TAGS:
                obj = Node(tag, a.get("type", ""), line, path, a.get("id"))
                self.fill(obj, child, path, stack)
                if obj.id:
                    if obj.id in self.ids:
                        raise SceneError(f"{path}:{line}: the id {excerpt(obj.id)} is already used "
                                         f"({self.ids[obj.id].where})")
                    self.ids[obj.id] = obj
                node.children.append((a.get("name"), obj))
            elif tag in _PROPERTY_TAGS:
                name = a.get("name")
                if not name:
                    raise SceneError(f"{path}:{line}: <{tag}> needs a name")
                if tag == "transform":
                    value = self.transform(child, path)
                elif tag in ("point", "vector"):
                    value = _vector(a, path, line, tag)
                else:
                    if "value" not in a:
                        if tag == "spectrum" and "filename" in a:
                            self.notes.add("spectra from files (grey 0.5 used)", line)
                            value = "0.5"
                        else:
                            raise SceneError(f"{path}:{line}: <{tag} name=\"{name}\"> needs a value")
                    else:
                        value = a["value"]
                node.props[name] = (tag, value, line)
            else:
                self.notes.add(f"<{excerpt(tag, quote=False)}>", line)

    def transform(self, el: ET.Element, path: Path) -> np.ndarray:
        M = np.eye(4)
        for op in el:
            if not isinstance(op.tag, str):
                continue
            a, line = self.attrs(op, path)
            where = f"{path}:{line}"
            try:
                if op.tag == "translate":
                    T = m.translate(_xyz(a, 0.0, where))
                elif op.tag == "scale":
                    if "value" in a and len(_numbers(a["value"], where)) == 1:
                        T = m.scale(_numbers(a["value"], where)[0])
                    else:
                        T = m.scale(_xyz(a, 1.0, where))
                elif op.tag == "rotate":
                    # as Mitsuba 3: the axis is not normalised (a longer one scales too)
                    T = m.rotate(_xyz(a, 0.0, where), _number(a.get("angle"), where, "angle"),
                                 normalize=False)
                elif op.tag == "matrix":
                    values = _numbers(a.get("value", ""), where)
                    if len(values) == 9:
                        T = np.eye(4)
                        T[:3, :3] = np.reshape(values, (3, 3))
                    elif len(values) == 16:
                        T = np.reshape(values, (4, 4))
                    else:
                        raise SceneError(f"{where}: <matrix> needs 9 or 16 numbers, got {len(values)}")
                elif op.tag == "lookat":
                    T = m.look_at(_numbers(a.get("origin", ""), where, 3),
                                  _numbers(a.get("target", ""), where, 3),
                                  _numbers(a.get("up", "0, 1, 0"), where, 3))
                else:
                    self.notes.add(f"<{excerpt(op.tag, quote=False)}> in a transform", line)
                    continue
            except SceneError as exc:
                message = str(exc)
                raise SceneError(message if message.startswith(where) else f"{where}: {message}") from None
            M = T @ M
        return M


def _numbers(text: str, where: str, n: int | None = None) -> list[float]:
    parts = [p for p in re.split(r"[,\s]+", str(text).strip()) if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise SceneError(f"{where}: expected numbers, got {excerpt(text)}") from None
    if not all(math.isfinite(v) for v in values):
        raise SceneError(f"{where}: expected finite numbers, got {excerpt(text)}")
    if n is not None and len(values) != n:
        raise SceneError(f"{where}: expected {n} numbers, got {excerpt(text)}")
    return values


def _number(text, where: str, what: str = "value") -> float:
    if text is None:
        raise SceneError(f"{where}: missing {what}")
    return _numbers(text, where, 1)[0]


def _xyz(a: dict, default: float, where: str) -> tuple:
    if "value" in a:
        values = _numbers(a["value"], where)
        if len(values) == 1:
            return (values[0],) * 3
        if len(values) == 3:
            return tuple(values)
        raise SceneError(f"{where}: expected 1 or 3 numbers, got {excerpt(a['value'])}")
    return tuple(_number(a[k], where, k) if k in a else default for k in "xyz")


def _vector(a: dict, path: Path, line: int, tag: str) -> tuple:
    where = f"{path}:{line}"
    if "value" in a:
        return tuple(_numbers(a["value"], where, 3))
    return tuple(_number(a.get(k, "0"), where, k) for k in "xyz")


# ---- spectra ----------------------------------------------------------------------------
def _cie1931(lam: np.ndarray) -> np.ndarray:
    """CIE 1931 2-degree colour matching functions, Wyman, Sloan and Shirley's (2013)
    multi-lobe fit (max. error ~1% of the peak)."""
    def g(mu, s1, s2):
        s = np.where(lam < mu, s1, s2)
        return np.exp(-0.5 * ((lam - mu) / s) ** 2)
    x = 1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2)
    y = 0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1)
    z = 1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1)


_XYZ_TO_SRGB = np.array([[3.240479, -1.537150, -0.498535],
                         [-0.969256, 1.875991, 0.041556],
                         [0.055648, -0.204043, 1.057311]])
_CIE_MIN, _CIE_MAX, _CIE_Y_INTEGRAL = 360.0, 830.0, 106.856895


def _illuminant(lam: np.ndarray) -> np.ndarray:
    """A 6504 K black body standing in for CIE D65 (their shapes differ by a few per cent
    in the blue, which the white normalisation below absorbs for smooth spectra)."""
    lam_m = lam * 1e-9
    return 1.0 / (lam_m ** 5 * np.expm1(1.4388e-2 / (lam_m * 6504.0)))


def spectrum_to_rgb(wavelengths, values, reflectance: bool) -> tuple:
    """A piecewise-linear spectrum (zero outside its wavelengths) to linear sRGB, as
    Mitsuba's RGB variants convert ``wavelength:value`` lists (spectrum_list_to_srgb):

    - emitted radiance: integrated against the CIE curves and normalised by the
      integral of y (an equal-energy spectrum of 1 has Y = 1);
    - reflectances: weighted by the D65 illuminant and white-balanced so that a
      reflectance of 1 everywhere is (1, 1, 1), then clamped to [0, 1]. Measured
      against Mitsuba 3.9 on its Cornell box spectra: within 2% on channels above 0.3.
    """
    lam = np.linspace(_CIE_MIN, _CIE_MAX, 1000)
    wl, v = np.asarray(wavelengths, np.float64), np.asarray(values, np.float64)
    inside = (lam >= wl[0]) & (lam <= wl[-1])
    s = np.where(inside, np.interp(lam, wl, v), 0.0)
    cmf = _cie1931(lam)
    if reflectance:
        d = _illuminant(lam)
        white = _XYZ_TO_SRGB @ (cmf * d[:, None]).sum(axis=0)
        rgb = np.clip((_XYZ_TO_SRGB @ (cmf * (s * d)[:, None]).sum(axis=0)) / white, 0.0, 1.0)
    else:
        xyz = (cmf * s[:, None]).sum(axis=0) * ((_CIE_MAX - _CIE_MIN) / 1000) / _CIE_Y_INTEGRAL
        rgb = _XYZ_TO_SRGB @ xyz
    return tuple(float(c) for c in rgb)


# ---- nodes to the scene -------------------------------------------------------------------
class _Builder:
    def __init__(self, reader: _Reader, scene: m.Scene):
        self.r, self.scene = reader, scene
        self.materials: dict[int, int] = {}      # id(Node) -> material index
        self.textures: dict[int, m.Texture] = {}
        self.media: dict[int, int] = {}           # id(Node) -> medium index
        self.used: set[int] = set()               # id(Node) of every BSDF and texture read
        self.has_camera = False
        self.groups: dict[int, tuple[Node, list[np.ndarray]]] = {}   # shapegroup -> instances

    def deref(self, item, where_line=None):
        if isinstance(item, tuple) and item[0] == "ref":
            _, ident, line = item
            ident = self.r.aliases.get(ident, ident)
            if ident not in self.r.ids:
                raise SceneError(f"{self.scene.source}:{line}: <ref id=\"{excerpt(ident, quote=False)}\"> "
                                 f"refers to an undefined id")
            return self.r.ids[ident]
        return item

    def objects(self, node: Node, tag: str | None = None):
        for name, item in node.children:
            obj = self.deref(item)
            if tag is None or obj.tag == tag:
                yield name, obj

    # -- typed properties -------------------------------------------------------------
    def prop(self, node: Node, name: str, kind: str, default=None):
        if name not in node.props:
            return default
        tag, value, line = node.props[name]
        where = f"{node.file}:{line}"
        if kind == "float":
            if tag not in ("float", "integer"):
                raise SceneError(f"{where}: {name}: expected a <float>, got <{tag}>")
            return _number(value, where, name)
        if kind == "int":
            number = _number(value, where, name)
            if tag not in ("integer", "float") or number != int(number):
                raise SceneError(f"{where}: {name}: expected an <integer>, got {excerpt(value)}")
            return int(number)
        if kind == "bool":
            if str(value).lower() not in ("true", "false"):
                raise SceneError(f"{where}: {name}: expected true or false, got {excerpt(value)}")
            return str(value).lower() == "true"
        if kind == "string":
            return str(value)
        if kind == "vector":
            if tag not in ("point", "vector"):
                raise SceneError(f"{where}: {name}: expected a <point> or <vector>, got <{tag}>")
            return value
        if kind == "transform":
            if tag != "transform":
                raise SceneError(f"{where}: {name}: expected a <transform>, got <{tag}>")
            return value
        raise AssertionError(kind)

    def color(self, node: Node, name: str, default, emitter: bool = False):
        """An RGB triple from <rgb>, <spectrum>, <float>; or a texture (object or ref)."""
        for child_name, obj in self.objects(node, "texture"):
            if child_name == name:
                return self.texture(obj)
        if name not in node.props:
            return default
        tag, value, line = node.props[name]
        where = f"{node.file}:{line}"
        if tag in ("float", "integer"):
            v = _number(value, where, name)
            return (v, v, v)
        if tag == "rgb":
            values = _numbers(value, where)
            if len(values) == 1:
                values *= 3
            if len(values) != 3:
                raise SceneError(f"{where}: {name}: expected 1 or 3 numbers, got {excerpt(value)}")
            return tuple(values)
        if tag == "spectrum":
            if ":" not in value:
                v = _number(value, where, name)
                return (v, v, v)
            pairs = []
            for item in str(value).split(","):
                if not item.strip():
                    continue
                try:
                    lam, val = (float(x) for x in item.split(":"))
                except ValueError:
                    raise SceneError(f"{where}: {name}: expected wavelength:value pairs, got "
                                     f"{excerpt(item)}") from None
                pairs.append((lam, val))
            pairs.sort()
            if len(pairs) < 2 or not all(math.isfinite(a) and math.isfinite(b) for a, b in pairs):
                raise SceneError(f"{where}: {name}: a spectrum needs at least two finite pairs")
            return spectrum_to_rgb([p[0] for p in pairs], [p[1] for p in pairs], reflectance=not emitter)
        raise SceneError(f"{where}: {name}: expected a colour (<rgb>, <spectrum>, <float>), got <{tag}>")

    def ior(self, node: Node, name: str, default: float) -> float:
        from ..materials import dielectric_ior

        if name not in node.props:
            return default
        tag, value, line = node.props[name]
        if tag == "string":
            try:
                return dielectric_ior(value)
            except SceneError as exc:
                raise SceneError(f"{node.file}:{line}: {name}: {exc}") from None
        return self.prop(node, name, "float")

    # -- plugins ----------------------------------------------------------------------------
    def texture(self, node: Node) -> m.Texture:
        self.used.add(id(node))
        if id(node) in self.textures:
            return self.textures[id(node)]
        M = np.eye(3)
        if "to_uv" in node.props:
            T = self.prop(node, "to_uv", "transform")
            M = np.array([[T[0, 0], T[0, 1], T[0, 3]], [T[1, 0], T[1, 1], T[1, 3]], [0, 0, 1]])
        if node.type == "bitmap":
            from ...film.io import linear_to_srgb

            path, image = self.image(node, "texture")
            if self.prop(node, "raw", "bool", False) and path.suffix.lower() in (".png", ".jpg", ".jpeg"):
                image = linear_to_srgb(image).astype(np.float32)
            filt = self.prop(node, "filter_type", "string", "bilinear")
            wrap = self.prop(node, "wrap_mode", "string", "repeat")
            if filt not in ("bilinear", "nearest") or wrap not in ("repeat", "mirror", "clamp"):
                node.fail(f"filter_type must be bilinear or nearest and wrap_mode repeat, mirror or "
                          f"clamp; got {excerpt(filt)}, {excerpt(wrap)}")
            tex = m.Texture("bitmap", image=image, uv_transform=M, filter=filt, wrap=wrap,
                            name=node.id or path.name)
        elif node.type == "checkerboard":
            tex = m.Texture("checkerboard", color0=self.color(node, "color0", (0.4,) * 3),
                            color1=self.color(node, "color1", (0.2,) * 3), uv_transform=M,
                            name=node.id or "checkerboard")
            for c in (tex.color0, tex.color1):
                if isinstance(c, m.Texture):
                    node.fail("nested textures inside a checkerboard are not supported")
        else:
            self.r.notes.add(f"texture type {excerpt(node.type)} (grey 0.5 used)", node.line)
            tex = m.Texture("checkerboard", color0=(0.5,) * 3, color1=(0.5,) * 3)
        self.textures[id(node)] = tex
        return tex

    def image(self, node: Node, what: str) -> tuple[Path, np.ndarray]:
        """The image file a plugin's ``filename`` names, read (linear RGB)."""
        name = self.prop(node, "filename", "string", "")
        path = self.r.files.resolve(name, node.file, node.line, what, tuple(self.r.search))
        try:
            return path, read_image_checked(path, environment=what == "environment map")
        except SceneError as exc:
            raise SceneError(f"{node.where}: {what} {excerpt(name)}: {exc}") from None

    def alpha(self, node: Node) -> tuple[float, float]:
        if "alpha_u" in node.props or "alpha_v" in node.props:
            return (self.prop(node, "alpha_u", "float", 0.1), self.prop(node, "alpha_v", "float", 0.1))
        for child_name, obj in self.objects(node, "texture"):
            if child_name in ("alpha", "alpha_u", "alpha_v"):
                self.r.notes.add("textured roughness (its mean is used)", obj.line)
                mean = _texture_mean(self.texture(obj))
                return (mean, mean)
        a = self.prop(node, "alpha", "float", 0.1)
        return (a, a)

    def material(self, node: Node) -> int:
        if id(node) in self.materials:
            return self.materials[id(node)]
        mat = self.bsdf(node)
        index = self.scene.add_material(mat)
        self.materials[id(node)] = index
        return index

    def bsdf(self, node: Node, two_sided: bool = False) -> m.Material:
        self.used.add(id(node))
        t, name = node.type, node.id or ""
        if t == "twosided":
            inner = [obj for _, obj in self.objects(node, "bsdf")]
            if not inner:
                node.fail("needs a nested <bsdf>")
            if len(inner) > 1:
                self.r.notes.add("twosided with two different BSDFs (the first is used)", node.line)
            return self.bsdf(inner[0], two_sided=True)
        if t in ("normalmap", "mask"):
            # Mitsuba's normal map: n = 2 c - 1 in the shading frame along dp/du, as ours;
            # its mask blends the BSDF with a null one by opacity: read as a cutout at 1/2
            # (the same image where the opacity is 0 or 1)
            inner = [obj for _, obj in self.objects(node, "bsdf")]
            if not inner:
                node.fail("needs a nested <bsdf>")
            textures = {child: obj for child, obj in self.objects(node, "texture")}
            key = "normalmap" if t == "normalmap" else "opacity"
            mat = self.bsdf(inner[0], two_sided)
            if key not in textures:
                if t == "mask" and "opacity" in node.props:
                    self.r.notes.add("mask with a constant opacity (the nested BSDF is used "
                                     "alone)", node.line)
                    return mat
                node.fail(f"needs a <texture name=\"{key}\">")
            from dataclasses import replace

            if t == "normalmap":
                # Mitsuba 3.7.1 on also multiplies by a shadowing term (Conty Estevez et al.
                # 2019) and flips a normal that hides wi: both on by default, as here
                return replace(mat, normal_map=self.texture(textures[key]),
                               normal_shadowing=self.prop(node, "use_shadowing_function", "bool", True),
                               normal_flip=self.prop(node, "flip_invalid_normals", "bool", True))
            self.r.notes.add("mask (read as an opacity cutout at 0.5)", node.line)
            return replace(mat, opacity=self.texture(textures[key]))
        if t == "bumpmap":
            self.r.notes.add(f"bsdf {t} (the nested BSDF is used alone)", node.line)
            inner = [obj for _, obj in self.objects(node, "bsdf")]
            if inner:
                return self.bsdf(inner[0], two_sided)
        try:
            if t == "diffuse":
                return m.Material("diffuse", reflectance=self.color(node, "reflectance", (0.5,) * 3),
                                  two_sided=two_sided, name=name)
            if t in ("conductor", "roughconductor"):
                from ..materials import conductor_ior

                eta, k = conductor_ior(self.prop(node, "material", "string", "none"))
                if "eta" in node.props or "k" in node.props:
                    eta = self.color(node, "eta", (0.0,) * 3)
                    k = self.color(node, "k", (1.0,) * 3)
                    if isinstance(eta, m.Texture) or isinstance(k, m.Texture):
                        node.fail("textured eta or k is not supported")
                return m.Material(t, eta=tuple(eta), k=tuple(k),
                                  specular_reflectance=self.color(node, "specular_reflectance", (1.0,) * 3),
                                  alpha=self.alpha(node),
                                  distribution=self.prop(node, "distribution", "string", "beckmann"),
                                  two_sided=two_sided, name=name)
            if t in ("dielectric", "roughdielectric", "thindielectric"):
                return m.Material(t, int_ior=self.ior(node, "int_ior", 1.5046),
                                  ext_ior=self.ior(node, "ext_ior", 1.000277),
                                  specular_reflectance=self.color(node, "specular_reflectance", (1.0,) * 3),
                                  specular_transmittance=self.color(node, "specular_transmittance", (1.0,) * 3),
                                  alpha=self.alpha(node),
                                  distribution=self.prop(node, "distribution", "string", "beckmann"),
                                  name=name)
            if t in ("plastic", "roughplastic"):
                return m.Material(t, reflectance=self.color(node, "diffuse_reflectance", (0.5,) * 3),
                                  specular_reflectance=self.color(node, "specular_reflectance", (1.0,) * 3),
                                  int_ior=self.ior(node, "int_ior", 1.49),
                                  ext_ior=self.ior(node, "ext_ior", 1.000277),
                                  nonlinear=self.prop(node, "nonlinear", "bool", False),
                                  alpha=self.alpha(node),
                                  distribution=self.prop(node, "distribution", "string", "beckmann"),
                                  two_sided=two_sided, name=name)
            if t == "null":
                return m.Material("null", name=name)
        except SceneError as exc:
            message = str(exc)
            if message.startswith(str(node.file)):
                raise
            node.fail(message)
        self.r.notes.add(f"bsdf type {excerpt(t)} (grey diffuse used)", node.line)
        return m.Material("diffuse", reflectance=(0.5,) * 3, two_sided=two_sided, name=name)

    def unused(self, node: Node) -> None:
        """Note the unknown types of a BSDF or texture that nothing refers to (and of those
        nested in it): ignored, as the unknown ones that are used are replaced."""
        known = _BSDF_TYPES if node.tag == "bsdf" else _TEXTURE_TYPES
        if id(node) in self.used:
            return
        if node.type not in known:
            self.r.notes.add(f"{node.tag} type {excerpt(node.type)} (not used by any shape)", node.line)
        for _, child in node.children:
            if isinstance(child, Node) and child.tag in ("bsdf", "texture"):
                self.unused(child)

    def shape(self, node: Node) -> None:
        """A top-level shape: drawn, or a shapegroup (drawn by its instances), or an instance
        of one (collected; :meth:`instances` makes the group's shapes)."""
        if node.type == "shapegroup":
            self.groups.setdefault(id(node), (node, []))
            return
        if node.type == "instance":
            groups = [obj for _, obj in self.objects(node, "shape")]
            if len(groups) != 1 or groups[0].type != "shapegroup":
                node.fail("expected one shapegroup (nested or a <ref id=\"...\"/>)")
            M = self.prop(node, "to_world", "transform", np.eye(4))
            self.groups.setdefault(id(groups[0]), (groups[0], []))[1].append(M)
            return
        shape = self.make_shape(node)
        if shape is not None:
            self.scene.shapes.append(shape)

    def instances(self) -> None:
        """The shapes of every shapegroup, placed by its instances: a mesh once, with the
        instances' transforms (Shape.instances: many copies share one tree); other shapes
        once per instance."""
        for group, transforms in self.groups.values():
            members = [obj for _, obj in self.objects(group, "shape")]
            if any(obj.type in ("shapegroup", "instance") for obj in members):
                group.fail("a shapegroup holds shapes, not shapegroups or instances")
            if not transforms:
                continue
            for member in members:
                shape = self.make_shape(member)
                if shape is None:
                    continue
                if shape.kind == "mesh":
                    shape.instances = np.stack(transforms)
                    self.scene.shapes.append(shape)
                else:
                    self.scene.shapes += [dataclasses.replace(shape, world_from_object=T @ shape.world_from_object)
                                          for T in transforms]

    def make_shape(self, node: Node) -> m.Shape | None:
        t = node.type
        M = self.prop(node, "to_world", "transform", np.eye(4))
        if t == "serialized":
            node.fail("Mitsuba's .serialized meshes are not supported (convert the mesh to PLY "
                      "or OBJ)")
        if t not in ("obj", "ply", "rectangle", "cube", "sphere", "disk"):
            self.r.notes.add(f"shape type {excerpt(t)}", node.line)
            return None
        bsdfs = [obj for _, obj in self.objects(node, "bsdf")]
        if bsdfs:
            material = self.material(bsdfs[0])
        else:
            # Mitsuba's default BSDF: diffuse 0.5, but black on an emitter (shape.cpp)
            material = self.default_material(black=any(self.objects(node, "emitter")))
        emission = None
        for _, em in self.objects(node, "emitter"):
            if em.type != "area":
                node.fail(f"a shape can only carry an area emitter, got {excerpt(em.type)}")
            radiance = self.color(em, "radiance", (1.0,) * 3, emitter=True)
            if isinstance(radiance, m.Texture):
                em.fail("textured radiance is not supported")
            emission = m.Emission(tuple(radiance))
        shape = m.Shape("mesh" if t in ("obj", "ply") else t, material=material, world_from_object=M,
                        emission=emission, flip_normals=self.prop(node, "flip_normals", "bool", False),
                        face_normals=self.prop(node, "face_normals", "bool", False),
                        name=node.id or f"{t} (line {node.line})")
        for side, medium in self.objects(node, "medium"):
            # Mitsuba's shape: a medium named interior (behind the surface) or exterior (the
            # side the normal faces); one of each
            if side not in ("interior", "exterior"):
                self.r.notes.add("a medium in a shape named neither interior nor exterior", medium.line)
            elif getattr(shape, side) is not None:
                node.fail(f"only a single {side} medium can be specified per shape")
            else:
                setattr(shape, side, self.medium(medium))
        if t in ("obj", "ply"):
            from .mesh_files import read_mesh

            path = self.r.files.resolve(self.prop(node, "filename", "string", ""), node.file, node.line,
                                        "mesh file", tuple(self.r.search))
            if path.suffix.lower() != f".{t}":
                node.fail(f"expected a .{t} file, got {excerpt(path.name)}")
            mesh = read_mesh(path)
            shape.vertices, shape.triangles, shape.normals, shape.uvs = \
                mesh.vertices, mesh.triangles, mesh.normals, mesh.uvs
        elif t == "sphere":
            shape.center = tuple(self.prop(node, "center", "vector", (0.0, 0.0, 0.0)))
            shape.radius = self.prop(node, "radius", "float", 1.0)
            if not shape.radius > 0:
                node.fail(f"radius must be positive, got {shape.radius}")
        elif t == "disk":
            from .meshes import disk_shape

            shape = disk_shape(shape)
        return shape

    # -- participating media ---------------------------------------------------------------
    def medium(self, node: Node) -> int:
        """The index in Scene.media of the medium ``node`` describes: one per node, however
        many shapes and sensors refer to it."""
        if id(node) in self.media:
            return self.media[id(node)]
        from .media import MEDIUM_KINDS, check_scale

        if node.type not in MEDIUM_KINDS:
            node.fail("unknown medium type (expected homogeneous or heterogeneous)")
        phase, g = self.phase(node)
        medium = m.Medium(node.type, sigma_t=self.medium_value(node, "sigma_t", (1.0,) * 3),
                          albedo=self.medium_value(node, "albedo", (0.75,) * 3),
                          phase=phase, g=g, name=node.id or f"{node.type} (line {node.line})")
        scale = self.prop(node, "scale", "float", 1.0)
        try:
            medium.scale = check_scale(scale)
        except SceneError as exc:
            raise SceneError(f"{node.file}:{node.props['scale'][2]}: scale: {exc}") from None
        medium.sample_emitters = self.prop(node, "sample_emitters", "bool", True)
        self.media[id(node)] = self.scene.add_medium(medium)
        return self.media[id(node)]

    def phase(self, node: Node) -> tuple[str, float]:
        """(kind, g) of a medium's nested phase function; Mitsuba's default is isotropic."""
        from .media import HG_DEFAULT_G, PHASES, check_g

        phases = [obj for _, obj in self.objects(node, "phase")]
        if len(phases) > 1:
            node.fail("only a single phase function can be specified per medium")
        if not phases:
            return "isotropic", 0.0
        phase = phases[0]
        if phase.type not in PHASES:
            phase.fail("unsupported phase function (expected isotropic or hg)")
        if phase.type == "isotropic":
            return "isotropic", 0.0
        g = self.prop(phase, "g", "float", HG_DEFAULT_G)
        try:
            return "hg", check_g(g)
        except SceneError as exc:
            raise SceneError(f"{phase.file}:{phase.props['g'][2]}: g: {exc}") from None

    def medium_value(self, node: Node, name: str, default: tuple):
        """A medium's ``sigma_t`` or ``albedo``: a constant (<float>, <rgb>, <spectrum>) or a
        nested or referenced <volume>, checked against its range. A heterogeneous medium's
        constant sigma_t is Mitsuba's constvolume: constant over the unit cube."""
        from .media import check_value
        from .volumes import constant_volume

        volumes = [obj for child, obj in self.objects(node, "volume") if child == name]
        if len(volumes) > 1:
            node.fail(f"{name} is given by {len(volumes)} volumes")
        bounded = node.type == "heterogeneous" and name == "sigma_t"
        if volumes:
            if node.type == "homogeneous" and name == "sigma_t" and volumes[0].type in _GRID_TYPES:
                volumes[0].fail("a homogeneous medium's sigma_t is a constant (a grid needs "
                                "<medium type=\"heterogeneous\">)")
            return self.volume(volumes[0], name, bounded)
        value = self.color(node, name, default, emitter=name == "sigma_t")
        if isinstance(value, m.Texture):
            node.fail(f"{name}: a texture is not a medium value (expected a constant or a <volume>)")
        where = f"{node.file}:{node.props[name][2]}" if name in node.props else node.where
        try:
            value = check_value(value, name)
        except SceneError as exc:
            raise SceneError(f"{where}: {name}: {exc}") from None
        return constant_volume(value, name=name) if bounded else value

    def volume(self, node: Node, name: str, bounded: bool):
        """A <volume> giving a medium's ``name``: ``constvolume`` (an RGB, or a one-voxel
        grid where ``bounded``) or ``gridvolume`` (a .vol or .npy file)."""
        from .media import check_value
        from .volumes import constant_volume, grid_volume, read_grid

        to_world = self.prop(node, "to_world", "transform", None)
        if node.type == "constvolume":
            value = self.color(node, "value", (1.0,) * 3, emitter=name == "sigma_t")
            if isinstance(value, m.Texture):
                node.fail("value: textures are not supported in a constvolume")
            label = f"{name} value"
        elif node.type in _GRID_TYPES:
            filename = self.prop(node, "filename", "string", "")
            path = self.r.files.resolve(filename, node.file, node.line, "volume file",
                                        tuple(self.r.search))
            filt = self.prop(node, "filter_type", "string", "trilinear")
            if filt not in ("trilinear", "nearest"):
                node.fail(f"filter_type must be trilinear or nearest, got {excerpt(filt)}")
            wrap = self.prop(node, "wrap_mode", "string", "clamp")
            if wrap != "clamp":
                self.r.notes.add(f"gridvolume wrap_mode {excerpt(wrap)} (clamp used)", node.line)
            use_grid_bbox = self.prop(node, "use_grid_bbox", "bool", False)
            try:
                grid = read_grid(path)
            except SceneError as exc:
                node.fail(f"volume file {excerpt(filename)}: {exc}")
            try:
                value = grid_volume(grid, to_world, filt, use_grid_bbox, name=node.id or path.name)
            except SceneError as exc:
                node.fail(str(exc))
            label = f"{name} from {excerpt(filename)}"
        else:
            node.fail("unknown volume type (expected constvolume or gridvolume)")
        try:
            value = check_value(value, name)
        except SceneError as exc:
            node.fail(f"{label}: {exc}")
        if bounded and not isinstance(value, m.Volume):
            try:
                return constant_volume(value, to_world, name=node.id or name)
            except SceneError as exc:
                node.fail(str(exc))
        return value

    def default_material(self, black: bool = False) -> int:
        key = -2 if black else -1
        if key not in self.materials:
            self.materials[key] = self.scene.add_material(m.Material(
                "diffuse", reflectance=(0.0 if black else 0.5,) * 3, name="default-emitter" if black else "default"))
        return self.materials[key]

    def emitter(self, node: Node) -> None:
        t = node.type
        M = self.prop(node, "to_world", "transform", None)
        for _, medium in self.objects(node, "medium"):
            self.r.notes.add("a medium inside an emitter", medium.line)

        def rgb(name, default):
            value = self.color(node, name, default, emitter=True)
            if isinstance(value, m.Texture):
                node.fail(f"textured {name} is not supported")
            return tuple(value)

        if t == "point":
            position = self.prop(node, "position", "vector", None)
            if position is None:
                position = tuple(M[:3, 3]) if M is not None else (0.0, 0.0, 0.0)
            self.scene.lights.append(m.Light("point", position=tuple(position),
                                             intensity=rgb("intensity", (1.0,) * 3)))
        elif t == "spot":
            cutoff = self.prop(node, "cutoff_angle", "float", 20.0)
            self.scene.lights.append(m.Light("spot", world_from_light=M if M is not None else np.eye(4),
                                             intensity=rgb("intensity", (1.0,) * 3), cutoff_angle=cutoff,
                                             beam_width=self.prop(node, "beam_width", "float", cutoff * 0.75)))
        elif t == "directional":
            direction = self.prop(node, "direction", "vector", None)
            if direction is None:
                direction = tuple((M if M is not None else np.eye(4))[:3, :3] @ np.array([0.0, 0.0, 1.0]))
            if np.linalg.norm(direction) == 0:
                node.fail("direction must be non-zero")
            self.scene.lights.append(m.Light("directional", direction=tuple(direction),
                                             irradiance=rgb("irradiance", (1.0,) * 3)))
        elif t == "constant":
            self.scene.lights.append(m.Light("constant", radiance=rgb("radiance", (1.0,) * 3)))
        elif t == "envmap":
            _, image = self.image(node, "environment map")
            self.scene.lights.append(m.Light("envmap", image=image, scale=self.prop(node, "scale", "float", 1.0),
                                             world_from_light=M if M is not None else np.eye(4)))
        elif t == "area":
            self.r.notes.add("an area emitter outside a shape", node.line)
        else:
            self.r.notes.add(f"emitter type {excerpt(t)}", node.line)

    def sensor(self, node: Node) -> None:
        if node.type not in ("perspective", "thinlens", "orthographic"):
            self.r.notes.add(f"sensor type {excerpt(node.type)} (a default camera is used)", node.line)
            return
        if self.has_camera:
            self.r.notes.add("more than one sensor (the first is used)", node.line)
            return
        cam = m.Camera()
        M = self.prop(node, "to_world", "transform", np.eye(4))
        cam.world_from_camera = M
        try:
            if node.type == "orthographic":
                # Mitsuba's orthographic sensor sees [-1, 1] along camera x (the film's aspect
                # ratio sets y) and takes its size from to_world's scale, which
                # world_from_camera keeps
                cam.kind, cam.half_extent = "orthographic", 1.0
                for key in ("fov", "focal_length", "fov_axis", "aperture_radius", "focus_distance"):
                    if key in node.props:
                        node.fail(f"an orthographic sensor has no {key} (its to_world scale sets the view's size)")
                if abs(np.linalg.det(M[:3, :3])) < 1e-12:
                    node.fail("to_world: an orthographic sensor needs an invertible transform (its scale is the view's size)")
            cam.fov = self.prop(node, "fov", "float", 39.3077)
            cam.fov_axis = self.prop(node, "fov_axis", "string", "x")
            if "focal_length" in node.props and "fov" not in node.props:
                # Mitsuba: a focal length on 35 mm film sets the diagonal field of view
                text = self.prop(node, "focal_length", "string").strip().lower().removesuffix("mm")
                focal = _number(text, f"{node.file}:{node.props['focal_length'][2]}", "focal_length")
                if not focal > 0:
                    node.fail(f"focal_length must be positive, got {focal}")
                cam.fov = math.degrees(2 * math.atan(math.hypot(36.0, 24.0) / (2 * focal)))
                cam.fov_axis = "diagonal"
            cam.near_clip = self.prop(node, "near_clip", "float", 1e-2)
            cam.far_clip = self.prop(node, "far_clip", "float", 1e4)
            if node.type == "thinlens":
                cam.aperture_radius = self.prop(node, "aperture_radius", "float", 0.0)
                cam.focus_distance = self.prop(node, "focus_distance", "float", 1.0)
            cam.__post_init__()
        except SceneError as exc:
            node.fail(str(exc))
        media = [medium for _, medium in self.objects(node, "medium")]
        if len(media) > 1:
            node.fail("only a single medium can be specified per sensor")
        if media:
            cam.medium = self.medium(media[0])
        self.scene.camera = cam
        self.has_camera = True
        for _, film in self.objects(node, "film"):
            self.film(film)
        for _, sampler in self.objects(node, "sampler"):
            kind = {"independent": "independent", "stratified": "stratified", "multijitter": "stratified",
                    "ldsampler": "sobol", "orthogonal": "sobol"}.get(sampler.type)
            if kind is None:
                self.r.notes.add(f"sampler type {excerpt(sampler.type)} (sobol used)", sampler.line)
                kind = "sobol"
            spp = self.prop(sampler, "sample_count", "int", 4)
            seed = self.prop(sampler, "seed", "int", 0)
            if not 1 <= spp <= 1 << 30 or not 0 <= seed < 2 ** 32:
                sampler.fail(f"sample_count must be in [1, 2^30] and seed in [0, 2^32), got {spp}, {seed}")
            self.scene.sampler = m.Sampler(kind, spp, seed)

    def film(self, node: Node) -> None:
        if node.type not in ("hdrfilm", "specfilm"):
            self.r.notes.add(f"film type {excerpt(node.type)}", node.line)
        width, height = self.prop(node, "width", "int", 768), self.prop(node, "height", "int", 576)
        film = m.Film(width=1, height=1)
        try:
            film.width, film.height = width, height
            film.__post_init__()
        except SceneError as exc:
            node.fail(str(exc))
        film.filter = "gaussian"
        for _, rf in self.objects(node, "rfilter"):
            if rf.type in ("box", "tent", "gaussian", "mitchell"):
                film.filter = rf.type
                if rf.type == "gaussian":
                    film.gaussian_stddev = self.prop(rf, "stddev", "float", 0.5)
                if rf.type == "mitchell":
                    film.mitchell_b = self.prop(rf, "B", "float", 1 / 3)
                    film.mitchell_c = self.prop(rf, "C", "float", 1 / 3)
                if "radius" in rf.props:
                    film.filter_radius = self.prop(rf, "radius", "float")
            else:
                self.r.notes.add(f"rfilter type {excerpt(rf.type)} (gaussian used)", rf.line)
        if "crop_width" in node.props or "crop_offset_x" in node.props:
            self.r.notes.add("film crop windows", node.line)
        self.scene.film = film

    def integrator(self, node: Node) -> None:
        t = node.type
        if t in ("aov", "moment", "stokes"):
            inner = [obj for _, obj in self.objects(node, "integrator")]
            self.r.notes.add(f"integrator {excerpt(t)} (the nested integrator is used)", node.line)
            if inner:
                return self.integrator(inner[0])
            t = "path"
        if t in ("volpath", "volpathmis"):
            t = "path"      # the path tracer renders media as volpath does
        if t == "prb":
            self.r.notes.add(f"integrator {excerpt(t)} (path used)", node.line)
            t = "path"
        if t not in ("path", "direct"):
            self.r.notes.add(f"integrator {excerpt(t)} (path used)", node.line)
            t = "path"
        # Mitsuba's own rules, whatever glrender's defaults: throughput roulette from rr_depth
        # (its default 5), the power heuristic, uniform light selection
        integ = m.Integrator(t, rr="throughput", strategy="mis-power", light_selection="uniform")
        try:
            integ.max_depth = self.prop(node, "max_depth", "int", -1)
            integ.rr_depth = max(self.prop(node, "rr_depth", "int", 5), 1)
            integ.hide_emitters = self.prop(node, "hide_emitters", "bool", False)
            if t == "direct":
                shading = self.prop(node, "shading_samples", "int", 1)
                integ.emitter_samples = self.prop(node, "emitter_samples", "int", shading)
                integ.bsdf_samples = self.prop(node, "bsdf_samples", "int", shading)
                if not (0 <= integ.emitter_samples <= 64 and 0 <= integ.bsdf_samples <= 64):
                    node.fail("emitter_samples and bsdf_samples must be in [0, 64]")
            integ.__post_init__()
        except SceneError as exc:
            message = str(exc)
            if message.startswith(str(node.file)):
                raise
            node.fail(message)
        self.scene.integrator = integ


def _texture_mean(tex: m.Texture) -> float:
    if tex.kind == "bitmap" and tex.image is not None:
        return float(np.mean(tex.image))
    return 0.5 * (float(np.mean(tex.color0)) + float(np.mean(tex.color1)))


def load_mitsuba(path, **params) -> m.Scene:
    """Load a Mitsuba 3 XML scene; ``params`` override its <default> values."""
    from .finish import finish_scene

    path = Path(path)
    reader = _Reader(path, params)
    root = reader.read_file(path, ())
    scene = m.Scene(source=str(path))
    b = _Builder(reader, scene)
    for _, obj in root.children:
        if isinstance(obj, tuple):
            continue            # a top-level <ref>: the object is defined elsewhere
        if obj.tag == "emitter" and obj.type == "area" and obj.id:
            continue            # used by shapes through <ref>
        if obj.tag == "integrator":
            b.integrator(obj)
        elif obj.tag == "sensor":
            b.sensor(obj)
        elif obj.tag == "shape":
            b.shape(obj)
        elif obj.tag == "emitter":
            b.emitter(obj)
        elif obj.tag in ("bsdf", "texture") or (obj.tag in ("medium", "volume", "phase") and obj.id):
            pass                # used through <ref>
        else:
            reader.notes.add(f"<{excerpt(obj.tag, quote=False)} type=\"{excerpt(obj.type, quote=False)}\">",
                              obj.line)
    for _, obj in root.children:
        if isinstance(obj, Node) and obj.tag in ("bsdf", "texture"):
            b.unused(obj)
        elif isinstance(obj, Node) and obj.tag == "medium" and obj.id and id(obj) not in b.media:
            reader.notes.add(f"medium {excerpt(obj.id)} (not used by any shape or sensor)", obj.line)
    b.instances()
    unused = sorted(set(params) - reader.used)
    if unused:
        warn(f"{path}: parameters given but not used: {', '.join(unused)}")
    reader.notes.emit()
    if not scene.shapes and not scene.lights:
        raise SceneError(f"{path}: the scene has no shapes and no lights")
    return finish_scene(scene, b.has_camera)
