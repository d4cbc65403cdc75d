"""glTF scenes written by the tests: quads (two triangles each) with their materials,
textures embedded as PNG data URIs, a camera; loaded through glrender.load as any file."""
from __future__ import annotations

import base64
import io
import json
from pathlib import Path

import numpy as np

NEAREST = {"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}


def png_uri(pixels: np.ndarray) -> str:
    """An 8-bit RGB image (H, W, 3 in [0, 255]) as a PNG data URI."""
    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(np.asarray(pixels, np.uint8), "RGB").save(out, format="PNG")
    return "data:image/png;base64," + base64.b64encode(out.getvalue()).decode()


def quad(corner, e1, e2, uv_corner=(0.0, 0.0), uv_e1=(1.0, 0.0), uv_e2=(0.0, 1.0), split: int = 1):
    """The parallelogram corner + a e1 + b e2 as a grid of split x split cells, two
    triangles each (front face e1 x e2, glTF's counter-clockwise winding), with uv =
    uv_corner + a uv_e1 + b uv_e2: (positions, uvs, indices)."""
    t = np.linspace(0.0, 1.0, split + 1)
    a, b = np.meshgrid(t, t, indexing="ij")
    a, b = a.reshape(-1), b.reshape(-1)
    positions = np.asarray(corner) + a[:, None] * np.asarray(e1) + b[:, None] * np.asarray(e2)
    uvs = np.asarray(uv_corner) + a[:, None] * np.asarray(uv_e1) + b[:, None] * np.asarray(uv_e2)
    n = split + 1
    idx = []
    for i in range(split):
        for j in range(split):
            v00, v10, v01, v11 = i * n + j, (i + 1) * n + j, i * n + j + 1, (i + 1) * n + j + 1
            idx += [v00, v10, v11, v00, v11, v01]
    return positions, uvs, np.asarray(idx)


def write_gltf(path: Path, primitives, materials, images=(), camera=None) -> Path:
    """A .gltf file of ``primitives`` ((positions, uvs, indices, material index), one mesh
    each), ``materials`` (glTF material objects), ``images`` (PNG data URIs; texture i is
    image i with the NEAREST sampler, clamped) and a perspective ``camera`` (eye, target,
    up, yfov in radians) placed by its node matrix."""
    blobs, views, accessors, meshes = [], [], [], []
    offset = 0
    for positions, uvs, indices, material in primitives:
        arrays = [(np.asarray(positions, "<f4"), "VEC3", 5126), (np.asarray(uvs, "<f4"), "VEC2", 5126),
                  (np.asarray(indices, "<u4"), "SCALAR", 5125)]
        ids = []
        for arr, kind, ctype in arrays:
            data = arr.tobytes()
            views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(data)})
            accessor = {"bufferView": len(views) - 1, "componentType": ctype,
                        "count": len(arr), "type": kind}
            if kind == "VEC3":
                accessor["min"], accessor["max"] = arr.min(0).tolist(), arr.max(0).tolist()
            accessors.append(accessor)
            ids.append(len(accessors) - 1)
            blobs.append(data)
            offset += len(data)
        meshes.append({"primitives": [{"attributes": {"POSITION": ids[0], "TEXCOORD_0": ids[1]},
                                       "indices": ids[2], "material": material}]})
    blob = b"".join(blobs)
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                     "byteLength": len(blob)}],
        "bufferViews": views, "accessors": accessors, "meshes": meshes, "materials": list(materials),
        "nodes": [{"mesh": k} for k in range(len(meshes))],
    }
    if images:
        doc["images"] = [{"uri": uri} for uri in images]
        doc["samplers"] = [NEAREST]
        doc["textures"] = [{"source": k, "sampler": 0} for k in range(len(images))]
    if camera is not None:
        eye, target, up, yfov = camera
        eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
        back = eye - target
        back /= np.linalg.norm(back)
        right = np.cross(up, back)
        right /= np.linalg.norm(right)
        M = np.eye(4)
        M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = right, np.cross(back, right), back, eye
        doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01}}]
        doc["nodes"].append({"camera": 0, "matrix": M.T.reshape(-1).tolist()})
    doc["scenes"] = [{"nodes": list(range(len(doc["nodes"])))}]
    doc["scene"] = 0
    path.write_text(json.dumps(doc))
    return path
