"""glTF 2.0 (``.gltf`` with external or data-URI buffers, and binary ``.glb``).

Read: the node hierarchy (matrix or TRS), meshes instanced by several nodes (one shape
with the nodes' transforms as its ``instances``: many copies share one tree), triangle / strip / fan primitives with POSITION, NORMAL and
TEXCOORD_0, metallic-roughness materials, perspective and orthographic cameras and
KHR_lights_punctual. Materials map onto the renderer's BSDFs by the metallic-roughness
rule of :mod:`.pbr` (docs/scene-format.md), with KHR_materials_transmission and
KHR_materials_ior (default 1.5). A metallicRoughnessTexture varies metallic (blue) and
roughness (green) per texel, the BSDF chosen per surface point by the same rule (on
transmissive materials its mean roughness is used). Emissive factor times
KHR_materials_emissive_strength, times the emissiveTexture at each point where there is one,
makes the primitive an area light. KHR_materials_volume on a transmissive material fills its
meshes with an absorbing medium (:func:`.media.attenuation_medium`).

glTF is top-left based: uv (0, 0) is the first texel of the image, which is Mitsuba's
convention too, so texture coordinates are used as they are. Light intensities are
photometric in glTF (candela, lux): they are divided by 683 lm/W to become the
radiometric W/sr and W/m^2 the renderer uses. Every size (chunks, buffers, views,
accessors) is checked against the bytes that exist before anything is read.
"""
from __future__ import annotations

import base64
import io
import json
import math
import re
import struct
from pathlib import Path

import numpy as np

from ...errors import SceneError, install_command
from .. import model as m
from .diagnostics import Notes, cause, check_image_size, excerpt, image_failure
from .meshes import MeshData, finish_mesh
from .pbr import metallic_roughness_material, textured_metallic_roughness_material
from .scene_files import SceneFiles, read_bytes

SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                        "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                        "KHR_texture_transform", "KHR_draco_mesh_compression"}
_COMPONENT = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_NORMALIZE = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_WRAP = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
LUMENS_PER_WATT = 683.0
MAX_NODE_DEPTH = 256
_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")     # file:, http:, ... (data: is read inline)


class _Gltf:
    def __init__(self, path: Path, doc: dict, bin_chunk: bytes | None, files: SceneFiles):
        self.path, self.doc, self.bin, self.files = path, doc, bin_chunk, files
        self.notes = Notes(path, "unsupported glTF features")
        self._buffers: dict[int, bytes] = {}
        self._meshes: dict[tuple, MeshData] = {}
        self._materials: dict[tuple, int] = {}
        self._media: dict[int, int | None] = {}     # material index -> its interior medium
        self._textures: dict[int, m.Texture] = {}

    def fail(self, where: str, message: str):
        raise SceneError(f"{self.path}: {where}: {message}")

    def table(self, value, where: str) -> dict:
        """An optional JSON object ({} when absent)."""
        if value is None:
            return {}
        if not isinstance(value, dict):
            self.fail(where, f"expected an object, got {excerpt(value)}")
        return value

    def array(self, value, where: str) -> list:
        """An optional JSON array ([] when absent)."""
        if value is None:
            return []
        if not isinstance(value, list):
            self.fail(where, f"expected an array, got {excerpt(value)}")
        return value

    def names(self, value, where: str) -> list[str]:
        """An optional array of strings (extension names)."""
        items = self.array(value, where)
        if not all(isinstance(x, str) for x in items):
            self.fail(where, f"expected an array of names, got {excerpt(items)}")
        return items

    def item(self, kind: str, index, where: str) -> dict:
        items = self.doc.get(kind)
        if not isinstance(index, int) or isinstance(index, bool) or not isinstance(items, list) \
                or not 0 <= index < len(items) or not isinstance(items[index], dict):
            self.fail(where, f"refers to {kind}[{excerpt(index)}], which does not exist")
        return items[index]

    # -- binary data -----------------------------------------------------------------
    def _uri_bytes(self, uri, where: str) -> bytes:
        if not isinstance(uri, str):
            self.fail(where, f"expected a uri string, got {excerpt(uri)}")
        if uri.startswith("data:"):
            head, _, payload = uri.partition(",")
            if not head.endswith(";base64"):
                self.fail(where, "only base64 data URIs are supported")
            try:
                return base64.b64decode(payload, validate=False)
            except ValueError:
                self.fail(where, "the data URI is not valid base64")
        from urllib.parse import unquote

        if _SCHEME.match(uri):
            self.fail(f"{where}.uri", f"expected a relative path or a data: URI, got {excerpt(uri)}")
        return read_bytes(self.files.resolve(unquote(uri), self.path, what="file",
                                             field=f"{where}.uri"))

    def buffer(self, index, referrer: str) -> bytes:
        b = self.item("buffers", index, referrer)
        if index not in self._buffers:
            where = f"buffers[{index}]"
            if "uri" in b:
                data = self._uri_bytes(b["uri"], where)
            elif index == 0 and self.bin is not None:
                data = self.bin
            else:
                self.fail(where, "has no uri and there is no GLB binary chunk")
            length = b.get("byteLength")
            if not isinstance(length, int) or length < 0 or length > len(data):
                self.fail(where, f"byteLength {excerpt(length)} exceeds the {len(data)} bytes available")
            self._buffers[index] = data[:length]
        return self._buffers[index]

    def view(self, index, where: str) -> tuple[bytes, int, int, int | None]:
        """(buffer bytes, offset, length, stride) of a buffer view, checked."""
        v = self.item("bufferViews", index, where)
        data = self.buffer(v.get("buffer"), f"bufferViews[{index}].buffer")
        offset, length = v.get("byteOffset", 0), v.get("byteLength")
        stride = v.get("byteStride")
        for name, value in (("byteOffset", offset), ("byteLength", length)):
            if not isinstance(value, int) or value < 0:
                self.fail(f"bufferViews[{index}]",
                          f"{name} must be a non-negative integer, got {excerpt(value)}")
        if offset + length > len(data):
            self.fail(f"bufferViews[{index}]", f"bytes [{offset}, {offset + length}) run past the "
                      f"end of buffer {v.get('buffer')} ({len(data)} bytes)")
        if stride is not None and (not isinstance(stride, int) or not 4 <= stride <= 252):
            self.fail(f"bufferViews[{index}]", f"byteStride must be in [4, 252], got {excerpt(stride)}")
        return data, offset, length, stride

    def accessor(self, index, where: str) -> np.ndarray:
        a = self.item("accessors", index, where)
        where = f"accessors[{index}]"
        ctype, atype, count = a.get("componentType"), a.get("type"), a.get("count")
        if not isinstance(ctype, int) or ctype not in _COMPONENT or not isinstance(atype, str) \
                or atype not in _WIDTH:
            self.fail(where, f"unknown componentType {excerpt(ctype)} or type {excerpt(atype)}")
        if not isinstance(count, int) or isinstance(count, bool) or count < 0:
            self.fail(where, f"count must be a non-negative integer, got {excerpt(count)}")
        dtype, width = np.dtype(_COMPONENT[ctype]), _WIDTH[atype]
        if "bufferView" in a:
            arr = self._elements(a["bufferView"], a.get("byteOffset", 0), count, dtype, width, where)
        elif "sparse" in a:
            arr = np.zeros((count, width), dtype)
        else:
            return np.zeros((count, width), np.float64)
        if "sparse" in a:
            self._apply_sparse(arr, a["sparse"], dtype, width, f"{where}.sparse")
        if a.get("normalized") and ctype in _NORMALIZE:
            arr = np.maximum(arr.astype(np.float64) / _NORMALIZE[ctype], -1.0)
        return arr

    def _elements(self, view, offset, count: int, dtype: np.dtype, width: int, where: str) -> np.ndarray:
        """``count`` elements of ``width`` components of ``dtype`` from bufferView ``view``
        at ``offset`` (its byteStride honoured), checked against the view's bytes."""
        data, view_offset, view_length, stride = self.view(view, where)
        elem = dtype.itemsize * width
        stride = stride or elem
        if not isinstance(offset, int) or offset < 0:
            self.fail(where, f"byteOffset must be a non-negative integer, got {excerpt(offset)}")
        need = offset + (stride * (count - 1) + elem if count else 0)
        if need > view_length:
            self.fail(where, f"{count} elements need {need} bytes of bufferView {view}, "
                      f"which has {view_length}")
        if count == 0:
            return np.zeros((0, width), dtype)
        return np.ndarray((count, width), dtype, buffer=data, offset=view_offset + offset,
                          strides=(stride, dtype.itemsize)).copy()

    def _apply_sparse(self, arr: np.ndarray, sparse, dtype: np.dtype, width: int, where: str) -> None:
        """Sparse storage: ``sparse.count`` elements of ``arr`` replaced, at the strictly
        increasing ``indices``, by ``values``."""
        if not isinstance(sparse, dict):
            self.fail(where, "expected an object")
        n = sparse.get("count")
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= len(arr):
            self.fail(where, f"count must be an integer in [1, {len(arr)}], got {excerpt(n)}")
        indices, values = sparse.get("indices"), sparse.get("values")
        if not isinstance(indices, dict) or not isinstance(values, dict) \
                or "bufferView" not in indices or "bufferView" not in values:
            self.fail(where, "needs indices and values, each with a bufferView")
        itype = indices.get("componentType")
        if not isinstance(itype, int) or itype not in (5121, 5123, 5125):
            self.fail(f"{where}.indices", f"componentType must be 5121, 5123 or 5125, got {excerpt(itype)}")
        idx = self._elements(indices["bufferView"], indices.get("byteOffset", 0), n,
                             np.dtype(_COMPONENT[itype]), 1, f"{where}.indices").reshape(-1).astype(np.int64)
        if idx.max() >= len(arr) or (n > 1 and np.any(np.diff(idx) <= 0)):
            self.fail(f"{where}.indices", f"expected strictly increasing indices below {len(arr)}")
        arr[idx] = self._elements(values["bufferView"], values.get("byteOffset", 0), n, dtype, width,
                                  f"{where}.values")

    # -- meshes --------------------------------------------------------------------------
    def primitive_mesh(self, mesh_index: int, k: int, prim: dict) -> MeshData | None:
        key = (mesh_index, k)
        if key in self._meshes:
            return self._meshes[key]
        where = f"meshes[{mesh_index}].primitives[{k}]"
        mode = prim.get("mode", 4)
        if mode not in (4, 5, 6):
            self.notes.add(f"point and line primitives (mode {excerpt(mode, quote=False)}), skipped")
            return None
        attrs = prim.get("attributes")
        if not isinstance(attrs, dict) or "POSITION" not in attrs:
            self.fail(where, "has no POSITION attribute")
        extensions = self.table(prim.get("extensions"), f"{where}.extensions")
        for name in extensions:
            if name not in SUPPORTED_EXTENSIONS:
                self.notes.add(f"primitive extension {excerpt(name, quote=False)}")
        if prim.get("targets"):
            self.notes.add("morph targets")
        if "KHR_draco_mesh_compression" in extensions:
            mesh = finish_mesh(self.draco_mesh(extensions["KHR_draco_mesh_compression"], where),
                               f"{self.path}: {where}")
            self._meshes[key] = mesh
            return mesh
        positions = self.accessor(attrs["POSITION"], where).astype(np.float64)
        if positions.shape[1] != 3:
            self.fail(where, "POSITION must be VEC3")
        if "indices" in prim:
            idx = self.accessor(prim["indices"], where).reshape(-1).astype(np.int64)
        else:
            idx = np.arange(len(positions), dtype=np.int64)
        if mode == 4:
            if len(idx) % 3:
                self.fail(where, f"{len(idx)} indices do not make whole triangles")
            tris = idx.reshape(-1, 3)
        elif mode == 5:   # strip: every other triangle reversed to keep the winding
            n = max(len(idx) - 2, 0)
            i = np.arange(n)
            odd = i % 2 == 1
            tris = np.stack([idx[i], np.where(odd, idx[i + 2], idx[i + 1]),
                             np.where(odd, idx[i + 1], idx[i + 2])], axis=1)
        else:             # fan
            n = max(len(idx) - 2, 0)
            tris = np.stack([np.full(n, idx[0] if len(idx) else 0), idx[1:n + 1], idx[2:n + 2]], axis=1)
        normals = uvs = None
        if "NORMAL" in attrs:
            normals = self.accessor(attrs["NORMAL"], where).astype(np.float64)
        if "TEXCOORD_0" in attrs:
            uvs = self.accessor(attrs["TEXCOORD_0"], where).astype(np.float64)[:, :2]
        for name, arr in (("NORMAL", normals), ("TEXCOORD_0", uvs)):
            if arr is not None and len(arr) != len(positions):
                self.fail(where, f"{name} has {len(arr)} elements for {len(positions)} positions")
        mesh = finish_mesh(MeshData(positions, tris, normals, uvs), f"{self.path}: {where}")
        self._meshes[key] = mesh
        return mesh

    def draco_mesh(self, ext, where: str) -> MeshData:
        """A KHR_draco_mesh_compression primitive, decoded by DracoPy."""
        try:
            import DracoPy
        except ImportError:
            self.fail(where, f"is Draco-compressed; decoding it needs the DracoPy package, "
                             f"which is not installed; install it with: {install_command('draco')}")
        if not isinstance(ext, dict):
            self.fail(where, "KHR_draco_mesh_compression must be an object")
        data, offset, length, _ = self.view(ext.get("bufferView"), where)
        try:
            mesh = DracoPy.decode(data[offset:offset + length])
        except Exception as exc:
            self.fail(where, f"cannot decode the Draco data ({cause(exc)})")
        faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), np.int64).reshape(-1, 3)
        points = np.asarray(mesh.points, np.float64).reshape(-1, 3)
        normals = getattr(mesh, "normals", None)
        uvs = getattr(mesh, "tex_coord", None)
        normals = np.asarray(normals, np.float64).reshape(-1, 3) if normals is not None and len(normals) else None
        uvs = np.asarray(uvs, np.float64).reshape(len(points), -1)[:, :2] \
            if uvs is not None and np.size(uvs) else None
        return MeshData(points, faces, normals, uvs)

    # -- materials and textures -------------------------------------------------------------
    def texture(self, info, where: str, srgb: bool = True, alpha: bool = False) -> m.Texture:
        if not isinstance(info, dict):
            self.fail(where, f"expected a textureInfo object, got {excerpt(info)}")
        index = info.get("index")
        tex_def = self.item("textures", index, where)
        if info.get("texCoord", 0) != 0:
            self.notes.add("texture coordinate sets other than TEXCOORD_0 (set 0 used)")
        key = (index, srgb, alpha)     # colour, raw data (normal maps) or alpha (opacity)
        if key not in self._textures:
            source = tex_def.get("source")
            if source is None:
                for ext in self.table(tex_def.get("extensions"), f"textures[{index}].extensions"):
                    self.notes.add(f"texture extension {excerpt(ext, quote=False)}")
                self.fail(f"textures[{index}]", "has no source image this loader can read")
            image = self.image(source, f"textures[{index}]", srgb, alpha)
            tex = m.Texture("bitmap", image=image, name=f"texture {index}")
            if "sampler" in tex_def:
                sampler = self.item("samplers", tex_def["sampler"], f"textures[{index}]")
                wrap_s, wrap_t = sampler.get("wrapS", 10497), sampler.get("wrapT", 10497)
                tex.wrap = _WRAP.get(wrap_s, "repeat") if isinstance(wrap_s, int) else "repeat"
                if wrap_t != wrap_s:
                    self.notes.add("different wrap modes along s and t (wrapS used)")
                if sampler.get("magFilter") == 9728:
                    tex.filter = "nearest"
            self._textures[key] = tex
        tex = self._textures[key]
        transform = self.table(info.get("extensions"), f"{where}.extensions").get("KHR_texture_transform")
        if isinstance(transform, dict):
            from dataclasses import replace

            tex = replace(tex, uv_transform=_texture_transform(
                transform, self, f"{where}.extensions.KHR_texture_transform"))
        return tex

    def image(self, index, where: str, srgb: bool, alpha: bool = False) -> np.ndarray:
        img = self.item("images", index, where)
        named = f"images[{index}]"
        if "uri" in img:
            data = self._uri_bytes(img["uri"], f"images[{index}]")
            if not str(img["uri"]).startswith("data:"):      # a file: named as written
                named = f"images[{index}].uri {excerpt(img['uri'])}"
        elif "bufferView" in img:
            buf, offset, length, _ = self.view(img["bufferView"], f"images[{index}]")
            data = buf[offset:offset + length]
        else:
            self.fail(f"images[{index}]", "has neither uri nor bufferView")
        from ...film.io import open_pil, srgb_to_linear

        try:
            with open_pil(io.BytesIO(data)) as im:
                check_image_size(*im.size)
                if alpha:       # the alpha channel (linear), as a grey image
                    a = np.asarray(im.convert("RGBA"), np.float64)[..., 3] / 255.0
                    return np.repeat(a[..., None], 3, axis=-1).astype(np.float32)
                pixels = np.asarray(im.convert("RGB"), np.float64) / 255.0
        except Exception as exc:      # our size check's reason, or the decoder's
            self.fail(named, image_failure(exc))
        return (srgb_to_linear(pixels) if srgb else pixels).astype(np.float32)

    def material(self, index, double_sided_default=False) -> tuple[int, m.Emission | None]:
        if index is None:
            key = (None,)
            if key not in self._materials:
                mat = m.Material("roughconductor", eta=(0.0, 0.0, 0.0), k=(1.0, 1.0, 1.0),
                                 alpha=(1.0, 1.0), distribution="ggx", name="glTF default")
                self._materials[key] = (self.scene.add_material(mat), None)
            return self._materials[key]
        mdef = self.item("materials", index, "material")
        if (index,) in self._materials:
            return self._materials[(index,)]
        where = f"materials[{index}]"
        name = str(mdef.get("name", f"material {index}"))
        ext = self.table(mdef.get("extensions"), f"{where}.extensions")
        for e in ext:
            if e not in SUPPORTED_EXTENSIONS:
                self.notes.add(f"material extension {excerpt(e, quote=False)}")
        if "occlusionTexture" in mdef:
            self.notes.add("occlusionTexture")
        pbr = self.table(mdef.get("pbrMetallicRoughness"), f"{where}.pbrMetallicRoughness")
        base = _floats(pbr.get("baseColorFactor", [1, 1, 1, 1]), 4, self, where)[:3]
        metallic = _floats([pbr.get("metallicFactor", 1.0)], 1, self, where)[0]
        roughness = min(max(_floats([pbr.get("roughnessFactor", 1.0)], 1, self, where)[0], 0.0), 1.0)
        color = tuple(base)
        if "baseColorTexture" in pbr:
            tex = self.texture(pbr["baseColorTexture"], f"{where}.baseColorTexture")
            if any(abs(c - 1.0) > 0 for c in base):
                from dataclasses import replace

                tex = replace(tex, image=tex.image * np.asarray(base, np.float32))
            color = tex
        ior = _floats([self.table(ext.get("KHR_materials_ior"), where).get("ior", 1.5)], 1, self, where)[0]
        ior = ior if ior > 1.0 else 1.5
        transmission = _floats([self.table(ext.get("KHR_materials_transmission"), where).get(
            "transmissionFactor", 0.0)], 1, self, where)[0]
        metallic_roughness = None
        if "metallicRoughnessTexture" in pbr:
            # metallic (blue) and roughness (green) per texel, the factors multiplied in: the
            # device picks the BSDF per point by pbr.py's rule (bsdf/metallic_roughness.glsl)
            from dataclasses import replace

            tex = self.texture(pbr["metallicRoughnessTexture"], f"{where}.metallicRoughnessTexture",
                               srgb=False)
            if transmission > 0:
                # glass stays one material: the texture's mean roughness scales the factor
                self.notes.add("metallicRoughnessTexture on a transmissive material (its mean "
                               "roughness is used)")
                roughness *= float(tex.image[..., 1].mean())
            else:
                metallic_roughness = replace(tex, image=tex.image * np.asarray(
                    [0.0, roughness, metallic], np.float32))
        two_sided = bool(mdef.get("doubleSided", double_sided_default))
        if metallic_roughness is not None:
            mat = textured_metallic_roughness_material(color, metallic_roughness, two_sided=two_sided,
                                                       name=name)
        else:
            mat = metallic_roughness_material(color, metallic, roughness, ior=ior,
                                              transmission=transmission, two_sided=two_sided, name=name)
        if "normalTexture" in mdef:
            info = mdef["normalTexture"]
            mat.normal_map = self.texture(info, f"{where}.normalTexture", srgb=False)
            if isinstance(info, dict) and "scale" in info:
                mat.normal_scale = _floats([info["scale"]], 1, self, where)[0]
        mode = mdef.get("alphaMode", "OPAQUE")
        if mode in ("MASK", "BLEND"):
            # a cutout where baseColorTexture.a * baseColorFactor.a < alphaCutoff (BLEND: at
            # 1/2, no partial transparency)
            factor = _floats(pbr.get("baseColorFactor", [1, 1, 1, 1]), 4, self, where)[3]
            if mode == "BLEND":
                self.notes.add("alphaMode BLEND (rendered as a cutout at alpha 0.5)")
            if "baseColorTexture" in pbr:
                tex = self.texture(pbr["baseColorTexture"], f"{where}.baseColorTexture",
                                   srgb=False, alpha=True)
                if factor != 1.0:
                    from dataclasses import replace

                    tex = replace(tex, image=tex.image * np.float32(factor))
                mat.opacity = tex
                mat.alpha_cutoff = 0.5 if mode == "BLEND" else \
                    _floats([mdef.get("alphaCutoff", 0.5)], 1, self, where)[0]
            elif factor < (0.5 if mode == "BLEND" else mdef.get("alphaCutoff", 0.5)):
                self.notes.add("alphaMode with a constant alpha below the cutoff (left opaque)")
        elif mode != "OPAQUE":
            self.notes.add(f"alphaMode {excerpt(mode, quote=False)}")
        emission = None
        emissive = _floats(mdef.get("emissiveFactor", [0, 0, 0]), 3, self, where)
        strength = _floats([self.table(ext.get("KHR_materials_emissive_strength"), where).get(
            "emissiveStrength", 1.0)], 1, self, where)[0]
        emissive_texture = None
        if "emissiveTexture" in mdef and max(emissive) > 0:
            # the radiance per texel: the factor times the (sRGB-decoded) texel
            emissive_texture = self.texture(mdef["emissiveTexture"], f"{where}.emissiveTexture")
        if max(emissive) * strength > 0:
            emission = m.Emission(tuple(float(e) * strength for e in emissive), two_sided=two_sided,
                                  texture=emissive_texture)
        self._materials[(index,)] = (self.scene.add_material(mat), emission)
        return self._materials[(index,)]

    def medium(self, index) -> int | None:
        """The medium inside the surfaces of material ``index`` (KHR_materials_volume), as an
        index into Scene.media; None for a thin-walled material (thicknessFactor 0, the
        default) and without KHR_materials_transmission (the extension needs it)."""
        if index is None:
            return None
        if index in self._media:
            return self._media[index]
        mdef = self.item("materials", index, "material")
        ext = self.table(mdef.get("extensions"), f"materials[{index}].extensions")
        where = f"materials[{index}].extensions.KHR_materials_volume"
        volume = self.table(ext.get("KHR_materials_volume"), where)
        medium = None
        thickness = _floats([volume.get("thicknessFactor", 0.0)], 1, self, f"{where}.thicknessFactor")[0]
        if thickness < 0:
            self.fail(f"{where}.thicknessFactor", f"expected a thickness >= 0, got {thickness:g}")
        if thickness > 0 and "KHR_materials_transmission" not in ext:
            self.notes.add("KHR_materials_volume without KHR_materials_transmission (no medium)")
        elif thickness > 0:
            from .media import attenuation_medium

            color = _floats(volume.get("attenuationColor", [1.0, 1.0, 1.0]), 3, self,
                            f"{where}.attenuationColor")
            if not all(0.0 <= c <= 1.0 for c in color):
                self.fail(f"{where}.attenuationColor", f"expected 3 numbers in [0, 1], got "
                          f"{excerpt(volume['attenuationColor'])}")
            distance = math.inf
            if "attenuationDistance" in volume:
                distance = _floats([volume["attenuationDistance"]], 1, self,
                                   f"{where}.attenuationDistance")[0]
                if not distance > 0:
                    self.fail(f"{where}.attenuationDistance", f"expected a distance > 0, got "
                              f"{distance:g}")
            name = str(mdef.get("name", f"material {index}"))
            medium = self.scene.add_medium(attenuation_medium(tuple(color), distance, name=name))
        self._media[index] = medium
        return medium


def _floats(value, n: int, g: _Gltf, where: str) -> list[float]:
    if not isinstance(value, list) or len(value) != n or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in value):
        g.fail(where, f"expected {n} finite numbers, got {excerpt(value)}")
    return [float(x) for x in value]


def _texture_transform(t: dict, g: _Gltf, where: str) -> np.ndarray:
    """KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv."""
    ox, oy = _floats(t.get("offset", [0.0, 0.0]), 2, g, f"{where}.offset")
    sx, sy = _floats(t.get("scale", [1.0, 1.0]), 2, g, f"{where}.scale")
    r = _floats([t.get("rotation", 0.0)], 1, g, f"{where}.rotation")[0]
    c, s = math.cos(r), math.sin(r)
    T = np.array([[1, 0, ox], [0, 1, oy], [0, 0, 1]], np.float64)
    R = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]], np.float64)
    S = np.diag([sx, sy, 1.0])
    return T @ R @ S


def _node_matrix(g: _Gltf, node: dict, where: str) -> np.ndarray:
    if "matrix" in node:
        M = np.array(_floats(node["matrix"], 16, g, f"{where}.matrix")).reshape(4, 4).T  # column-major
        return M
    t = _floats(node.get("translation", [0, 0, 0]), 3, g, f"{where}.translation")
    x, y, z, w = _floats(node.get("rotation", [0, 0, 0, 1]), 4, g, f"{where}.rotation")
    s = _floats(node.get("scale", [1, 1, 1]), 3, g, f"{where}.scale")
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    M = np.eye(4)
    M[:3, :3] = R * np.asarray(s)[None, :]
    M[:3, 3] = t
    return M


def _read_container(path: Path) -> tuple[dict, bytes | None]:
    data = read_bytes(path)
    bin_chunk = None
    if data[:4] == b"glTF":
        if len(data) < 20:
            raise SceneError(f"{path}: truncated GLB header")
        version, length = struct.unpack_from("<II", data, 4)
        if version != 2:
            raise SceneError(f"{path}: GLB version {version}; only glTF 2.0 is supported")
        if length > len(data):
            raise SceneError(f"{path}: the GLB header declares {length} bytes, the file has {len(data)} "
                             f"(truncated)")
        offset, chunks = 12, []
        while offset + 8 <= length:
            size, kind = struct.unpack_from("<II", data, offset)
            if offset + 8 + size > length:
                raise SceneError(f"{path}: a GLB chunk of {size} bytes runs past the end of the file "
                                 f"(truncated)")
            chunks.append((kind, data[offset + 8:offset + 8 + size]))
            offset += 8 + size + (-size % 4 if offset + 8 + size < length else 0)
        if not chunks or chunks[0][0] != 0x4E4F534A:
            raise SceneError(f"{path}: the GLB file has no JSON chunk first")
        text = chunks[0][1]
        bin_chunk = next((c for k, c in chunks[1:] if k == 0x004E4942), None)
    else:
        text = data
    try:
        doc = json.loads(text.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise SceneError(f"{path}: invalid glTF JSON ({cause(exc)})") from None
    if not isinstance(doc, dict):
        raise SceneError(f"{path}: the glTF JSON is not an object")
    asset = doc.get("asset")
    version = str(asset.get("version", "")) if isinstance(asset, dict) else ""
    if not version.startswith("2"):
        raise SceneError(f"{path}: glTF version {excerpt(version, quote=False) or '(none)'}; only "
                         f"glTF 2.0 is supported")
    return doc, bin_chunk


def load_gltf(path, **params) -> m.Scene:
    from .finish import finish_scene

    path = Path(path)
    doc, bin_chunk = _read_container(path)
    g = _Gltf(path, doc, bin_chunk, SceneFiles(path.parent))
    required = [e for e in g.names(doc.get("extensionsRequired"), "extensionsRequired")
                if e not in SUPPORTED_EXTENSIONS]
    if required:
        raise SceneError(f"{path}: requires the glTF extension{'s' if len(required) > 1 else ''} "
                         f"{excerpt(', '.join(required), quote=False)}, which glrender does not "
                         f"support")
    for e in g.names(doc.get("extensionsUsed"), "extensionsUsed"):
        if e not in SUPPORTED_EXTENSIONS:
            g.notes.add(f"extension {excerpt(e, quote=False)}")
    scene = m.Scene(source=str(path))
    g.scene = scene
    nodes = g.array(doc.get("nodes"), "nodes")
    if g.array(doc.get("scenes"), "scenes"):
        scene_index = doc.get("scene", 0)
        roots = g.array(g.item("scenes", scene_index, "scene").get("nodes"), f"scenes[{scene_index}].nodes")
    else:
        children = {c for i, n in enumerate(nodes) if isinstance(n, dict)
                    for c in g.array(n.get("children"), f"nodes[{i}].children")
                    if isinstance(c, int)}
        roots = [i for i in range(len(nodes)) if i not in children]
    lights = g.table(g.table(doc.get("extensions"), "extensions").get("KHR_lights_punctual"),
                     "extensions.KHR_lights_punctual")
    light_defs = g.array(lights.get("lights"), "extensions.KHR_lights_punctual.lights")
    camera = None
    placed: dict[tuple[int, int], list[int]] = {}     # (mesh, primitive) -> its shapes
    stack = [(r, np.eye(4), 0, ()) for r in reversed(roots)]
    while stack:
        index, parent, depth, path_nodes = stack.pop()
        where = f"nodes[{index}]"
        node = g.item("nodes", index, "scene" if depth == 0 else f"nodes[{path_nodes[-1]}].children")
        if index in path_nodes:
            g.fail(where, "the node hierarchy has a cycle")
        if depth > MAX_NODE_DEPTH:
            g.fail(where, f"the node hierarchy is deeper than {MAX_NODE_DEPTH}")
        M = parent @ _node_matrix(g, node, where)
        if "mesh" in node:
            mesh_def = g.item("meshes", node["mesh"], where)
            for k, prim in enumerate(g.array(mesh_def.get("primitives"),
                                             f"meshes[{node['mesh']}].primitives")):
                if not isinstance(prim, dict):
                    g.fail(f"meshes[{node['mesh']}].primitives[{k}]", "expected an object")
                mesh = g.primitive_mesh(node["mesh"], k, prim)
                if mesh is None:
                    continue
                mat, emission = g.material(prim.get("material"))
                placed.setdefault((node["mesh"], k), []).append(len(scene.shapes))
                scene.shapes.append(m.Shape("mesh", material=mat, world_from_object=M,
                                            vertices=mesh.vertices, triangles=mesh.triangles,
                                            normals=mesh.normals, uvs=mesh.uvs, emission=emission,
                                            name=str(node.get("name", f"node {index}")),
                                            interior=g.medium(prim.get("material"))))
        if "camera" in node and camera is None:
            camera = _camera(g, node["camera"], M, scene)
        light_ref = g.table(g.table(node.get("extensions"), f"{where}.extensions").get(
            "KHR_lights_punctual"), f"{where}.extensions.KHR_lights_punctual").get("light")
        if light_ref is not None:
            if not isinstance(light_ref, int) or isinstance(light_ref, bool) or \
                    not 0 <= light_ref < len(light_defs):
                g.fail(where, f"refers to light {excerpt(light_ref)}, which does not exist")
            light = _light(g, light_defs[light_ref], M, f"KHR_lights_punctual.lights[{light_ref}]")
            if light is not None:
                scene.lights.append(light)
        for child in reversed(g.array(node.get("children"), f"{where}.children")):
            stack.append((child, M, depth + 1, path_nodes + (index,)))
    g.notes.emit()
    _share_meshes(scene, placed)
    if camera is not None:
        scene.camera = camera
    if not scene.shapes and not scene.lights:
        raise SceneError(f"{path}: the scene has no meshes and no lights")
    return finish_scene(scene, has_camera=camera is not None)


def _share_meshes(scene: m.Scene, placed: dict[tuple[int, int], list[int]]) -> None:
    """One shape per mesh primitive that several nodes place, with the nodes' transforms as
    its instances (Shape.instances), where its first node put it."""
    drop = set()
    for (mesh, k), shapes in placed.items():
        if len(shapes) > 1:
            first = scene.shapes[shapes[0]]
            first.instances = np.stack([scene.shapes[i].world_from_object for i in shapes])
            first.world_from_object = np.eye(4)
            first.name = f"mesh {mesh} primitive {k} ({len(shapes)} nodes)"
            drop.update(shapes[1:])
    if drop:
        scene.shapes = [s for i, s in enumerate(scene.shapes) if i not in drop]


# glTF cameras look along -z with +y up and +x right; Mitsuba's along +z with +x left
_FLIP_XZ = np.diag([-1.0, 1.0, -1.0, 1.0])


def _camera(g: _Gltf, index, M: np.ndarray, scene: m.Scene) -> m.Camera | None:
    cam = g.item("cameras", index, "camera")
    kind = cam.get("type")
    if kind not in ("perspective", "orthographic"):
        g.notes.add(f"{excerpt(kind, quote=False)} cameras")
        return None
    # remove scale from the node transform, keep rotation and position
    R = M[:3, :3] / np.maximum(np.linalg.norm(M[:3, :3], axis=0), 1e-30)
    W = np.eye(4)
    W[:3, :3], W[:3, 3] = R, M[:3, 3]
    if kind == "orthographic":
        return _orthographic_camera(g, f"cameras[{index}].orthographic", cam, W, scene)
    p = g.table(cam.get("perspective"), f"cameras[{index}].perspective")
    yfov = _floats([p.get("yfov", 0.8)], 1, g, f"cameras[{index}].perspective.yfov")[0]
    if not 0 < yfov < math.pi:
        g.fail(f"cameras[{index}].perspective.yfov", f"expected radians in (0, pi), got {yfov}")
    aspect = p.get("aspectRatio")
    if isinstance(aspect, (int, float)) and not isinstance(aspect, bool) and 0.05 < aspect < 20:
        scene.film.width = max(1, int(round(scene.film.height * aspect)))
    znear = p.get("znear", 0.01)
    zfar = p.get("zfar", 1e4)
    near = float(znear) if isinstance(znear, (int, float)) and znear > 0 else 0.01
    far = float(zfar) if isinstance(zfar, (int, float)) and zfar > near else 1e4
    return m.Camera(world_from_camera=W @ _FLIP_XZ, fov=math.degrees(yfov), fov_axis="y",
                    near_clip=near, far_clip=far)


def _orthographic_camera(g: _Gltf, where: str, cam: dict, W: np.ndarray, scene: m.Scene) -> m.Camera:
    """xmag and ymag are the view's half width and half height (the glTF projection maps
    [-xmag, xmag] x [-ymag, ymag] to the viewport): ymag is the camera's half extent along
    y, and the film's width follows xmag / ymag as it follows a perspective aspectRatio.
    All four properties are required by the glTF specification."""
    o = g.table(cam.get("orthographic"), where)
    values = {}
    for key in ("xmag", "ymag", "znear", "zfar"):
        if key not in o:
            g.fail(f"{where}.{key}", "missing (an orthographic camera needs xmag, ymag, znear and zfar)")
        values[key] = _floats([o[key]], 1, g, f"{where}.{key}")[0]
    for key in ("xmag", "ymag"):
        if not values[key] > 0:
            g.fail(f"{where}.{key}", f"expected a positive half width, got {values[key]}")
    if not values["znear"] >= 0:
        g.fail(f"{where}.znear", f"expected a distance >= 0, got {values['znear']}")
    if not values["zfar"] > values["znear"]:
        g.fail(f"{where}.zfar", f"expected a distance above znear ({values['znear']}), got {values['zfar']}")
    aspect = values["xmag"] / values["ymag"]
    if not 0.05 < aspect < 20:
        g.fail(f"{where}.xmag", f"xmag / ymag = {aspect:.4g}: expected an aspect ratio in (0.05, 20)")
    scene.film.width = max(1, int(round(scene.film.height * aspect)))
    return m.Camera(world_from_camera=W @ _FLIP_XZ, kind="orthographic", half_extent=values["ymag"],
                    fov_axis="y", near_clip=values["znear"], far_clip=values["zfar"])


def _light(g: _Gltf, ldef, M: np.ndarray, where: str) -> m.Light | None:
    if not isinstance(ldef, dict):
        g.fail(where, "expected an object")
    color = _floats(ldef.get("color", [1, 1, 1]), 3, g, f"{where}.color")
    intensity = _floats([ldef.get("intensity", 1.0)], 1, g, f"{where}.intensity")[0]
    value = tuple(c * intensity / LUMENS_PER_WATT for c in color)
    kind = ldef.get("type")
    R = M[:3, :3] / np.maximum(np.linalg.norm(M[:3, :3], axis=0), 1e-30)
    if kind == "point":
        return m.Light("point", position=tuple(M[:3, 3]), intensity=value, name=str(ldef.get("name", "")))
    if kind == "directional":
        d = R @ np.array([0.0, 0.0, -1.0])
        return m.Light("directional", direction=tuple(d), irradiance=value, name=str(ldef.get("name", "")))
    if kind == "spot":
        spot = g.table(ldef.get("spot"), f"{where}.spot")
        outer = _floats([spot.get("outerConeAngle", math.pi / 4)], 1, g, f"{where}.spot")[0]
        inner = _floats([spot.get("innerConeAngle", 0.0)], 1, g, f"{where}.spot")[0]
        W = np.eye(4)
        W[:3, :3] = R @ np.diag([1.0, -1.0, -1.0])    # the light's +z along the node's -z
        W[:3, 3] = M[:3, 3]
        outer_deg = min(max(math.degrees(outer), 0.01), 90.0)
        return m.Light("spot", world_from_light=W, intensity=value, cutoff_angle=outer_deg,
                       beam_width=min(max(math.degrees(inner), 0.0), outer_deg),
                       name=str(ldef.get("name", "")))
    g.notes.add(f"light type {excerpt(kind)}")
    return None
