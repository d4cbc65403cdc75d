"""Scene files from strangers (docs/scene-format.md, "Referenced files"): one row per crafted
input - the files to write, the call (glrender.load, or the command line where the command
line is what is tested), the exit code and a pattern for the line that says why.

Every row also checks what no input may do: crash with a traceback, put a control
character on the terminal, or show anything of a file outside the allowed folders (a
marker in every file of the folder beside the scene's, and /etc/passwd's first line).
The path policy is tried for every format and every kind of reference it has: ``..``
out of the folder, an absolute path, a symbolic link leading outside, a link to
/dev/zero and a folder; then ``search_path`` / ``--search-path`` allowing a folder."""
from __future__ import annotations

import base64
import io
import json
import os
import re
import stat
import struct
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import glrender
from glrender.errors import GlrenderError, SceneError
from glrender.scene import GlrenderWarning
from glrender.scene.loaders.scene_files import MissingFile, SceneFiles

sys.path.insert(0, str(Path(__file__).parents[1] / "cli"))
from cli_run import glrender as run_cli  # noqa: E402

MARKER = "SECRET-OUTSIDE"
UP = "../" * 16                 # from any temporary folder up to /


def _passwd_line() -> str | None:
    try:
        return Path("/etc/passwd").read_text().splitlines()[0]
    except (OSError, IndexError):
        return None


def _png(color=(200, 100, 50)) -> bytes:
    from PIL import Image

    out = io.BytesIO()
    Image.new("RGB", (2, 2), color).save(out, format="PNG")
    return out.getvalue()


# -- the files ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Link:
    """A symbolic link to ``target`` (absolute, or relative to the test's folder)."""
    target: str


class Folder:
    """A folder where a file is expected."""


TRI_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
TOML_LIGHT = '[[lights]]\ntype = "point"\nposition = [0, 0, 5]\n'
TOML_SPHERE = ('[materials.m]\nreflectance = 0.5\n[[shapes]]\ntype = "sphere"\nmaterial = "m"\n'
               + TOML_LIGHT)


def toml_texture(file: str) -> str:
    return (f'[textures.t]\nfile = "{file}"\n[materials.m]\nreflectance = "t"\n'
            f'[[shapes]]\ntype = "sphere"\nmaterial = "m"\n' + TOML_LIGHT)


def toml_mesh(file: str) -> str:
    return (f'[materials.m]\nreflectance = 0.5\n[[shapes]]\ntype = "mesh"\nmaterial = "m"\n'
            f'file = "{file}"\n' + TOML_LIGHT)


def xml(body: str) -> str:
    return (f'<scene version="3.0.0">\n{body}\n<shape type="sphere"/>\n'
            f'<emitter type="constant"/>\n</scene>\n')


def xml_bitmap(file: str) -> str:
    return xml(f'<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" '
               f'name="reflectance"><string name="filename" value="{file}"/></texture></bsdf>'
               f'</shape>')


_POSITIONS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes()
_INDICES = np.array([0, 1, 2], "<u2").tobytes()
BUFFER = _POSITIONS + _INDICES + b"\0\0"


def gltf_doc(buffer_uri: str | None = None, image_uri: str | None = None) -> dict:
    """A triangle; its buffer at ``buffer_uri`` (else inline), a base colour texture at
    ``image_uri`` (if given)."""
    uri = buffer_uri or "data:application/octet-stream;base64," + base64.b64encode(BUFFER).decode()
    doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": uri, "byteLength": len(BUFFER)}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                           {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                       "material": 0}]}],
           "materials": [{}], "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0,
           "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}},
           "extensionsUsed": ["KHR_lights_punctual"]}
    doc["nodes"].append({"extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc["scenes"][0]["nodes"].append(1)
    if image_uri is not None:
        doc["images"] = [{"uri": image_uri}]
        doc["textures"] = [{"source": 0}]
        doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    return doc


def gltf(**kwargs) -> str:
    return json.dumps(gltf_doc(**kwargs))


def gltf_texture_slot(slot: str, info, image_uri: str = "t.png") -> str:
    """The triangle whose material reads its texture ``slot`` (metallicRoughnessTexture,
    emissiveTexture) through the textureInfo ``info``; texture 0 is the image at image_uri."""
    doc = gltf_doc(image_uri=image_uri)
    material = {"pbrMetallicRoughness": {}, "emissiveFactor": [1, 1, 1]}
    if slot == "metallicRoughnessTexture":
        material["pbrMetallicRoughness"][slot] = info
    else:
        material[slot] = info
    doc["materials"] = [material]
    return json.dumps(doc)


def glb(**kwargs) -> bytes:
    text = json.dumps(gltf_doc(**kwargs)).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def obj_mtl(mtllib: str) -> str:
    return f"mtllib {mtllib}\n" + TRI_OBJ.replace("f ", "usemtl a\nf ")


PLY_HEAD = ("ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\n")
PLY_VERTICES = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes()


def ply_faces(list_type: str, count: int) -> bytes:
    head = PLY_HEAD + f"element face 1\nproperty list {list_type} vertex_indices\nend_header\n"
    size = {"uint": "<I", "uchar": "<B", "int": "<i"}[list_type.split()[0]]
    return head.encode() + PLY_VERTICES + struct.pack(size, count) + struct.pack("<3i", 0, 1, 2)


ESCAPES = "\x1b]0;PWNED\x07\x1b[31m"                  # retitle the terminal, then red
ESCAPED = re.escape(r"\x1b]0;PWNED\x07\x1b[31m")


# -- the table ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    files: dict                     # path under the test folder -> text, bytes, Link or Folder;
                                    # the first one is the scene file
    pattern: str                    # a line of the output matches it
    code: int = 2                   # 2: one error line; 0: loads (renders), warnings allowed
    cli: tuple | None = None        # command-line arguments ({tmp}: the test folder); None: load
    search: tuple = ()              # load(search_path=...) ({tmp}: the test folder)


def _png_claiming(width: int, height: int) -> bytes:
    """A PNG signature and IHDR chunk claiming width x height RGB pixels, and no data."""
    import zlib

    chunk = b"IHDR" + struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + chunk + struct.pack(">I", zlib.crc32(chunk))
            + b"\0\0\0\0IEND\xaeB`\x82")


PNG_20000 = _png_claiming(20000, 20000)      # past Pillow's error limit, not only its warning


def refused(what: str, name: str) -> str:
    return rf"{what} '{re.escape(name)}' resolves to \S+, outside the scene's folder \S+: refused"


CASES = {
    # -- TOML: includes, meshes (also through trimesh), textures, environment maps
    "toml include ..": Case({"scene/s.toml": 'include = "../outside/secret.toml"\n'},
                            r"s\.toml: include\[0\]: " + refused("file", "../outside/secret.toml")),
    "toml include absolute": Case({"scene/s.toml": 'include = "/etc/passwd"\n'},
                                  r"s\.toml: include\[0\]: " + refused("file", "/etc/passwd")),
    "toml mesh link out": Case({"scene/s.toml": toml_mesh("link.obj"),
                                "scene/link.obj": Link("outside/secret.obj")},
                               r"s\.toml: shapes\[0\]\.file: " + refused("file", "link.obj")),
    "toml mesh's glTF buffer ..": Case({"scene/s.toml": toml_mesh("m.gltf"),
                                        "scene/m.gltf": gltf(buffer_uri="../outside/secret.bin")},
                                       r"m\.gltf: " + refused("file", "../outside/secret.bin")),
    "toml texture ..": Case({"scene/s.toml": toml_texture("../outside/secret.png")},
                            r"textures\.t\.file: " + refused("file", "../outside/secret.png")),
    "toml envmap absolute": Case({"scene/s.toml": '[[lights]]\ntype = "envmap"\nfile = "/etc/passwd"\n'},
                                 r"lights\[0\]\.file: " + refused("file", "/etc/passwd")),
    "toml texture /dev/zero": Case({"scene/s.toml": toml_texture("zero.png"),
                                    "scene/zero.png": Link("/dev/zero")},
                                   r"textures\.t\.file: file 'zero\.png' is not a regular file "
                                   r"\(a character device\)"),
    "toml texture folder": Case({"scene/s.toml": toml_texture("dir.png"), "scene/dir.png": Folder()},
                                r"file 'dir\.png' is not a regular file \(a folder\)"),
    "toml texture allowed": Case({"scene/s.toml": toml_texture("../outside/ok.png")},
                                 r"no camera", code=0, search=("{tmp}/outside",)),
    "toml include allowed": Case({"scene/s.toml": 'include = "../outside/ok.toml"\n'},
                                 r"no camera", code=0, search=("{tmp}/outside",)),
    # -- images a scene refers to: one line, the scene file and its field or line, the image
    #    as the scene names it (once) and why; one size rule for every format; PIL's warning
    "toml texture not an image": Case({"scene/s.toml": toml_texture("junk.png"),
                                       "scene/junk.png": "not an image\n"},
                                      r"s\.toml: textures\.t\.file: image 'junk\.png': cannot "
                                      r"decode it \(cannot identify image file\)$"),
    "toml envmap NaN": Case({"scene/s.toml": '[[lights]]\ntype = "envmap"\nfile = "e.pfm"\n',
                             "scene/e.pfm": b"PF\n1 1\n-1.0\n" + struct.pack("<3f", float("nan"), 0, 0)},
                            r"s\.toml: lights\[0\]\.file: image 'e\.pfm': it holds NaN or "
                            r"infinite values$"),
    "xml texture hdr too large": Case(
        {"scene/s.xml": xml_bitmap("big.hdr"),
         "scene/big.hdr": b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 9000 +X 9000\n"},
        r"s\.xml:2: texture 'big\.hdr': 9000 x 9000 pixels is more than the 67,108,864 "
        r"\(8192 x 8192\) a texture or environment map may have$"),
    "cli texture bomb png": Case(
        {"scene/s.toml": toml_texture("bomb.png"), "scene/bomb.png": PNG_20000},
        r"^glrender: error: \S+/s\.toml: textures\.t\.file: image 'bomb\.png': 20000 x 20000 "
        r"pixels is more than the 67,108,864 \(8192 x 8192\) a texture or environment map may "
        r"have$", cli=("render", "{tmp}/scene/s.toml")),
    # -- Mitsuba XML: includes, obj and ply meshes, bitmaps, environment maps, <path>
    "xml include ..": Case({"scene/s.xml": xml('<include filename="../outside/secret.xml"/>')},
                           r"s\.xml:2: " + refused("included file", "../outside/secret.xml")),
    "xml obj absolute": Case({"scene/s.xml": xml('<shape type="obj"><string name="filename" '
                                                 'value="/etc/passwd"/></shape>')},
                             r"s\.xml:2: " + refused("mesh file", "/etc/passwd")),
    "xml ply link out": Case({"scene/s.xml": xml('<shape type="ply"><string name="filename" '
                                                 'value="link.ply"/></shape>'),
                              "scene/link.ply": Link("outside/secret.ply")},
                             r"s\.xml:2: " + refused("mesh file", "link.ply")),
    "xml bitmap ..": Case({"scene/s.xml": xml_bitmap("../outside/secret.png")},
                          r"s\.xml:2: " + refused("texture", "../outside/secret.png")),
    "xml envmap link out": Case({"scene/s.xml": xml('<emitter type="envmap"><string name="filename" '
                                                    'value="env.exr"/></emitter>'),
                                 "scene/env.exr": Link("outside/secret.exr")},
                                r"s\.xml:2: " + refused("environment map", "env.exr")),
    "xml path ..": Case({"scene/s.xml": xml('<path value="../outside"/><shape type="obj"><string '
                                            'name="filename" value="secret.obj"/></shape>')},
                        r"s\.xml:2: " + refused("mesh file", "secret.obj")),
    "xml path .., file missing": Case({"scene/s.xml": xml('<path value="../outside"/><shape type="obj">'
                                                          '<string name="filename" value="no.obj"/></shape>')},
                                      r"s\.xml:2: mesh file 'no\.obj' not found \(looked in "),
    "xml include /dev/zero": Case({"scene/s.xml": xml('<include filename="zero.xml"/>'),
                                   "scene/zero.xml": Link("/dev/zero")},
                                  r"included file 'zero\.xml' is not a regular file "
                                  r"\(a character device\)"),
    "xml path allowed": Case({"scene/s.xml": xml('<path value="../outside"/><shape type="obj">'
                                                 '<string name="filename" value="ok.obj"/></shape>')},
                             r"no camera", code=0, search=("{tmp}/outside",)),
    # -- glTF and GLB: buffers and images
    "gltf buffer ..": Case({"scene/s.gltf": gltf(buffer_uri="../outside/secret.bin")},
                           r"s\.gltf: buffers\[0\]\.uri: " + refused("file", "../outside/secret.bin")),
    "gltf buffer absolute": Case({"scene/s.gltf": gltf(buffer_uri="/etc/passwd")},
                                 r"s\.gltf: buffers\[0\]\.uri: " + refused("file", "/etc/passwd")),
    "gltf buffer file URI": Case({"scene/s.gltf": gltf(buffer_uri="file:///etc/passwd")},
                                 r"buffers\[0\]\.uri: expected a relative path or a data: URI, "
                                 r"got 'file:///etc/passwd'"),
    "gltf buffer percent-encoded ..": Case({"scene/s.gltf": gltf(buffer_uri="%2E%2E/outside/secret.bin")},
                                           refused("file", "../outside/secret.bin")),
    "gltf buffer /dev/zero": Case({"scene/s.gltf": gltf(buffer_uri="zero.bin"),
                                   "scene/zero.bin": Link("/dev/zero")},
                                  r"buffers\[0\]\.uri: file 'zero\.bin' is not a regular file"),
    "gltf image link out": Case({"scene/s.gltf": gltf(image_uri="link.png"),
                                 "scene/link.png": Link("outside/secret.png")},
                                r"s\.gltf: images\[0\]\.uri: " + refused("file", "link.png")),
    **{f"gltf {slot} {name}": Case({"scene/s.gltf": gltf_texture_slot(slot, info, uri),
                                    **({"scene/link.png": Link("outside/secret.png")} if uri == "link.png" else {})},
                                   rf"s\.gltf: {pattern}")
       for slot in ("metallicRoughnessTexture", "emissiveTexture")
       for name, info, uri, pattern in (
           ("missing texture", {"index": 3}, "t.png",
            rf"materials\[0\]\.{slot}: refers to textures\[3\], which does not exist"),
           ("not an object", "t.png", "t.png",
            rf"materials\[0\]\.{slot}: expected a textureInfo object, got 't\.png'"),
           ("image link out", {"index": 0}, "link.png",
            r"images\[0\]\.uri: " + refused("file", "link.png")))},
    "gltf buffer allowed": Case({"scene/s.gltf": gltf(buffer_uri="../outside/ok.bin")},
                                r"no camera", code=0, search=("{tmp}/outside",)),
    "glb buffer absolute": Case({"scene/s.glb": glb(buffer_uri="/etc/passwd")},
                                r"s\.glb: buffers\[0\]\.uri: " + refused("file", "/etc/passwd")),
    "glb image ..": Case({"scene/s.glb": glb(image_uri="../outside/secret.png")},
                         r"s\.glb: images\[0\]\.uri: " + refused("file", "../outside/secret.png")),
    # -- OBJ and MTL: material libraries, and the MTL's map_Kd, map_d, norm
    "obj mtllib to /etc/passwd": Case({"scene/m.obj": obj_mtl(UP + "etc/passwd")},
                                      r"m\.obj:1: " + refused("material library", UP + "etc/passwd")),
    "obj mtllib link out": Case({"scene/m.obj": obj_mtl("link.mtl"),
                                 "scene/link.mtl": Link("outside/secret.mtl")},
                                r"m\.obj:1: " + refused("material library", "link.mtl")),
    "obj mtllib /dev/zero": Case({"scene/m.obj": obj_mtl("zero.mtl"), "scene/zero.mtl": Link("/dev/zero")},
                                 r"m\.obj:1: material library 'zero\.mtl' is not a regular file"),
    "obj mtllib folder": Case({"scene/m.obj": obj_mtl("dir.mtl"), "scene/dir.mtl": Folder()},
                              r"m\.obj:1: material library 'dir\.mtl' is not a regular file \(a folder\)"),
    "mtl map_Kd ..": Case({"scene/m.obj": obj_mtl("m.mtl"),
                           "scene/m.mtl": "newmtl a\nmap_Kd ../outside/secret.png\n"},
                          r"m\.mtl:2: " + refused("texture", "../outside/secret.png")),
    "mtl map_d absolute": Case({"scene/m.obj": obj_mtl("m.mtl"), "scene/m.mtl": "newmtl a\nmap_d /etc/passwd\n"},
                               r"m\.mtl:2: " + refused("texture", "/etc/passwd")),
    "mtl norm link out": Case({"scene/m.obj": obj_mtl("m.mtl"), "scene/m.mtl": "newmtl a\nnorm n.png\n",
                               "scene/n.png": Link("outside/secret.png")},
                              r"m\.mtl:2: " + refused("texture", "n.png")),
    "obj mtllib allowed": Case({"scene/m.obj": obj_mtl("../outside/ok.mtl")},
                               r"no camera", code=0, search=("{tmp}/outside",)),
    # -- the scene file itself not a regular file
    "scene file /dev/zero": Case({"scene/s.toml": Link("/dev/zero")},
                                 r"s\.toml: not a regular file \(a character device\)"),
    "scene file a folder": Case({"scene/d.obj": Folder()}, r"d\.obj: not a regular file \(a folder\)"),
    # -- terminal escapes and long excerpts: escaped and cut wherever file content is quoted
    "obj statement escapes": Case({"scene/e.obj": TRI_OBJ + ESCAPES + "\n"},
                                  rf"e\.obj: ignored OBJ statements: '{ESCAPED}' \(line 5\)", code=0),
    "obj garbage bytes": Case({"scene/g.obj": TRI_OBJ.encode() + b"\x00\x1b[2J\xc2\x9b31m\x07 x\n"},
                              r"ignored OBJ statements: '\\x00\\x1b\[2J\\x9b31m\\x07'", code=0),
    "obj face escapes": Case({"scene/e.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 " + ESCAPES + "\n"},
                             rf"e\.obj:4: malformed face vertex '{ESCAPED}'$"),
    "obj long line cut": Case({"scene/l.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 " + "A" * 5000 + "\n"},
                              r"l\.obj:4: malformed face vertex 'A{80}'\.\.\.$"),
    "obj garbage statements listed up to 20": Case(
        {"scene/g.obj": TRI_OBJ + "".join(f"k{i} x\n" for i in range(100))},
        r"ignored OBJ statements: 'k0' \(line 5\); .*'k19' \(line 24\); and 80 more$", code=0),
    "mtl keyword escapes": Case({"scene/m.obj": obj_mtl("m.mtl"), "scene/m.mtl": ESCAPES + " 1\n"},
                                rf"m\.mtl:1: '{ESCAPED}' before the first newmtl"),
    "toml value escapes": Case({"scene/s.toml": '[film]\nwidth = "\\u001b]0;PWNED\\u0007\\u001b[31m"\n'},
                               rf"film\.width: expected an integer in \[1, 65536\], got \"{ESCAPED}\""),
    "toml key escapes": Case({"scene/s.toml": '"\\u001b[2J\\u009b" = 1\n'},
                             r"s\.toml: \\x1b\[2J\\x9b: unknown field"),
    "xml value escapes": Case({"scene/s.xml": xml('<shape type="sphere"><float name="radius" '
                                                  'value="&#x9b;31m&#x202e;"/></shape>')},
                              r"s\.xml:2: expected numbers, got '\\x9b31m\\u202e'"),
    "xml bsdf type escapes": Case({"scene/s.xml": xml('<shape type="sphere"><bsdf type="&#x9b;2J"/></shape>')},
                                  r"bsdf type '\\x9b2J' \(grey diffuse used\) \(line 2\)", code=0),
    "gltf uri escapes": Case({"scene/s.gltf": gltf(buffer_uri="\x1b[31mred.bin")},
                             r"buffers\[0\]\.uri: file '\\x1b\[31mred\.bin' not found"),
    "gltf extension escapes": Case({"scene/s.gltf": json.dumps({**gltf_doc(), "extensionsUsed": [ESCAPES]})},
                                   rf"unsupported glTF features: extension {ESCAPED}", code=0),
    "ply header escapes": Case({"scene/p.ply": "ply\nformat ascii 1.0\nelement \x1b[31mvertex 3\nend_header\n"},
                               r"p\.ply: expected 'vertex' and 'face' elements, found \\x1b\[31mvertex"),
    "escapes in a file name": Case({"scene/\x1b[31mx.toml": "[film\n"},
                                   r"scene/\\x1b\[31mx\.toml: invalid TOML"),
    # -- Mitsuba: an unknown BSDF that nothing uses is reported like any ignored element
    "xml unused unknown bsdf": Case({"scene/s.xml": xml('<bsdf type="fancy" id="unused"/>')},
                                    r"unsupported Mitsuba features \(ignored\): bsdf type 'fancy' "
                                    r"\(not used by any shape\) \(line 2\)", code=0),
    # -- PLY: sizes a header declares, checked against the file before allocating
    "ply list of 4e9 items": Case({"scene/p.ply": ply_faces("uint int", 4_000_000_000)},
                                  r"p\.ply: element 'face' is truncated \(a list of 4000000000 items "
                                  r"runs past the end of the file\)"),
    "ply 1e12 vertices": Case({"scene/p.ply": PLY_HEAD.replace("vertex 3", "vertex 1000000000000").encode()
                               + b"element face 0\nproperty list uchar int vertex_indices\nend_header\n"},
                              r"p\.ply: element 'vertex' declares 1000000000000 records of 12 bytes"),
    "ply ascii 1e15 faces": Case({"scene/p.ply": "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                  "property float y\nproperty float z\nelement face 1000000000000000\n"
                                  "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                                  "3 0 1 2\n"},
                                 r"p\.ply: element 'face' declares 1000000000000000 records"),
    "ply element without properties": Case({"scene/p.ply": (PLY_HEAD + "element junk 1000000000000\n"
                                                            "element face 1\nproperty list uchar int "
                                                            "vertex_indices\nend_header\n").encode()
                                            + PLY_VERTICES + b"\x03" + struct.pack("<3i", 0, 1, 2)},
                                           r"no camera", code=0),
    "ply huge ascii index": Case({"scene/p.ply": "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                  "property float y\nproperty float z\nelement face 2\n"
                                  "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
                                  "3 0 1 2\n4 0 1 2 99999999999999999999999\n"},
                                 r"p\.ply: element 'face' is malformed or truncated"),
    # -- the command line: the same rules, one line on stderr, --search-path
    "cli obj mtllib to /etc/passwd": Case({"scene/m.obj": obj_mtl(UP + "etc/passwd")},
                                          r"^glrender: error: .*m\.obj:1: " + refused("material library", UP + "etc/passwd"),
                                          cli=("render", "{tmp}/scene/m.obj")),
    "cli scene file /dev/zero": Case({"scene/s.toml": Link("/dev/zero")},
                                     r"^glrender: error: .*s\.toml: not a regular file \(a character device\)$",
                                     cli=("render", "{tmp}/scene/s.toml")),
    "cli search path allowed, escapes shown": Case(
        {"scene/m.obj": obj_mtl("../outside/ok.mtl") + ESCAPES + "\n"},
        rf"^glrender: warning: .*m\.obj: ignored OBJ statements: '{ESCAPED}' \(line 7\)$", code=0,
        cli=("render", "{tmp}/scene/m.obj", "--search-path", "{tmp}/outside")),
    "cli search path not a folder": Case({"scene/s.toml": TOML_SPHERE},
                                         r"^glrender: error: --search-path \S+/nothere: no such folder$",
                                         cli=("render", "{tmp}/scene/s.toml", "--search-path", "{tmp}/nothere")),
}


def outside_folder(tmp: Path) -> None:
    """The folder beside the scene's: files that must never be read unless allowed
    (each holds the marker), and valid ones that ``search_path`` rows use."""
    out = tmp / "outside"
    out.mkdir()
    for ext in ("toml", "obj", "mtl", "png", "bin", "xml", "ply", "exr"):
        (out / f"secret.{ext}").write_text(f"{MARKER} root:x:0:0\n")
    (out / "ok.png").write_bytes(_png())
    (out / "ok.toml").write_text(TOML_SPHERE)
    (out / "ok.obj").write_text(TRI_OBJ)
    (out / "ok.mtl").write_text("newmtl a\nKd 0.5 0.5 0.5\nmap_Kd ok.png\n")
    (out / "ok.bin").write_bytes(BUFFER)


def write_files(tmp: Path, files: dict) -> None:
    for name, content in files.items():
        path = tmp / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, Link):
            target = content.target if content.target.startswith("/") else str(tmp / content.target)
            path.symlink_to(target)
        elif isinstance(content, Folder):
            path.mkdir()
        elif isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content)


def load_lines(scene: Path, search: list[str]) -> tuple[int, list[str]]:
    """(exit code, output lines) of glrender.load as the command line reports them."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        try:
            glrender.load(scene, search_path=search)
            code, error = 0, []
        except GlrenderError as exc:
            assert "\n" not in str(exc), str(exc)
            code, error = exc.exit_code, [f"glrender: error: {exc}"]
    return code, [f"glrender: warning: {w.message}" for w in record
                  if issubclass(w.category, GlrenderWarning)] + error


@pytest.mark.parametrize("name", list(CASES))
def test01_hostile_input(tmp_path, name):
    case = CASES[name]
    outside_folder(tmp_path)
    write_files(tmp_path, case.files)
    scene = tmp_path / next(iter(case.files))          # the first file is the scene
    fill = lambda text: text.replace("{tmp}", str(tmp_path))  # noqa: E731
    if case.cli is None:
        code, lines = load_lines(scene, [fill(s) for s in case.search])
        text = "\n".join(lines)
    else:
        args = [fill(a) for a in case.cli] + ["-o", tmp_path / "out.png", "--width", 8,
                                               "--height", 8, "--spp", 1]
        result = run_cli(*args)
        code, lines, text = result.returncode, result.stderr.splitlines(), result.stdout + result.stderr
    assert code == case.code, text
    assert "Traceback" not in text
    assert all(ch.isprintable() for line in text.splitlines() for ch in line), ascii(text)
    assert MARKER not in text
    assert "decompression bomb" not in text.lower()      # images are held to glrender's limit
    passwd = _passwd_line()
    assert passwd is None or passwd not in text
    errors = [line for line in lines if line.startswith("glrender: error:")]
    assert len(errors) == (1 if case.code == 2 else 0), text
    matching = errors if case.code == 2 else lines
    assert any(re.search(case.pattern, line) for line in matching), text


# -- path resolution, fuzzed --------------------------------------------------------------------
_PARTS = ["..", ".", "", "scene", "extra", "outside", "sub", "a.toml", "secret.toml",
          "in.toml", "out.toml", "extra.toml", "zero.toml", "loop.toml", "dir.toml",
          "dangling.toml", "up", "nothere.toml", "etc", "passwd"]


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    """root/scene (the scene's folder), root/extra (allowed by search_path) and
    root/outside, with links among them; files inside hold valid TOML, the others the
    marker as an unknown key (an error would show it if they were ever read)."""
    root = tmp_path_factory.mktemp("tree").resolve()
    for folder in ("scene/sub", "extra", "outside"):
        (root / folder).mkdir(parents=True)
    for folder in ("scene", "scene/sub", "extra"):
        (root / folder / "a.toml").write_text("")
    (root / "outside" / "secret.toml").write_text(f'"{MARKER}" = 1\n')
    (root / "outside" / "a.toml").write_text(f'"{MARKER}" = 1\n')
    links = {"in.toml": root / "scene/sub/a.toml", "out.toml": root / "outside/secret.toml",
             "extra.toml": root / "extra/a.toml", "zero.toml": Path("/dev/zero"),
             "loop.toml": root / "scene/loop.toml", "dangling.toml": root / "scene/nothere",
             "up": root, "etc": Path("/etc")}
    for name, target in links.items():
        (root / "scene" / name).symlink_to(target)
    (root / "scene" / "dir.toml").mkdir()
    return root


def _relpaths():
    part = st.sampled_from(_PARTS)
    return st.builds(lambda parts, absolute: ("/" if absolute else "") + "/".join(parts),
                     st.lists(part, min_size=1, max_size=6), st.booleans())


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.one_of(_relpaths(), st.sampled_from(["/etc/passwd", "../outside/secret.toml",
                                                    "up/outside/secret.toml", "etc/passwd"])),
       use_search=st.booleans())
def test02_fuzzed_paths_resolve_inside_or_are_refused(tree, name, use_search):
    """A reference resolves to a regular file inside the allowed folders (the one the path
    names, links followed) or is refused in one line naming the referrer and the path;
    loading a scene that includes it never reads a file outside."""
    scene = tree / "scene" / "s.toml"
    allowed = [tree / "scene"] + ([tree / "extra"] if use_search else [])
    files = SceneFiles(tree / "scene", search=allowed[1:])
    real = Path(os.path.realpath(tree / "scene" / name))
    inside = any(real.is_relative_to(folder) for folder in allowed)
    try:
        mode = os.stat(real).st_mode
        state = "file" if stat.S_ISREG(mode) else "other"
    except (FileNotFoundError, NotADirectoryError):
        state = "missing"
    except OSError:
        state = "unreadable"          # a link loop
    try:
        found = files.resolve(name, scene, field="include[0]")
    except MissingFile as exc:
        assert inside and state == "missing", (name, str(exc))
    except SceneError as exc:
        message = str(exc)
        assert "\n" not in message and message.startswith(f"{scene}: include[0]: "), message
        if not name.strip():
            assert "expected a file name" in message
        elif state == "other":
            assert "is not a regular file" in message, message
        elif not inside:
            assert f"resolves to {real}, outside the scene's folder" in message, message
        else:
            assert state == "unreadable" and "cannot read" in message, message
    else:
        assert inside and state == "file" and found == real, (name, found)

    scene_text = f"include = {json.dumps(name)}\n" + TOML_SPHERE
    scene.write_text(scene_text)
    code, lines = load_lines(scene, allowed[1:])
    assert MARKER not in "\n".join(lines)
    assert code == 0 or len([line for line in lines if "error:" in line]) == 1
