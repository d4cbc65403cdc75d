"""glTF 2.0: the BoxTextured sample in its three containers, a crafted scene for the
hierarchy, instancing, cameras and lights, and hostile files."""
import base64
import json
import math
import struct

import numpy as np
import pytest

import glrender
from glrender.errors import SceneError
from glrender.scene import model as m

from conftest import SCENES

GLTF = SCENES / "gltf"


@pytest.mark.parametrize("name", ["BoxTextured.glb", "BoxTextured-glTF/BoxTextured.gltf",
                                  "draco/BoxTextured_draco.glb"])
def test01_box_textured(name, caught):
    with caught:
        scene = glrender.load(GLTF / name)
    (shape,) = scene.shapes
    assert len(shape.triangles) == 12
    lo, hi = shape.vertices.min(axis=0), shape.vertices.max(axis=0)
    np.testing.assert_allclose(lo, -0.5, atol=1e-6)
    np.testing.assert_allclose(hi, 0.5, atol=1e-6)
    # the root node's matrix: a 90 degree rotation about x
    np.testing.assert_allclose(shape.world_from_object[:3, :3], [[1, 0, 0], [0, 0, 1], [0, -1, 0]], atol=1e-6)
    tex = scene.materials[shape.material].reflectance
    assert isinstance(tex, m.Texture) and tex.image.shape[2] == 3   # 211^2 (256^2 in the Draco copy)
    # the .gltf variant's sampler says wrapS MIRRORED_REPEAT (33648), the GLB REPEAT
    assert tex.wrap == ("mirror" if name.endswith(".gltf") else "repeat")
    assert shape.uvs.max() == pytest.approx(6.0)


def _buffer(arrays):
    blob = b"".join(a.tobytes() for a in arrays)
    return "data:application/octet-stream;base64," + base64.b64encode(blob).decode(), len(blob)


def _triangle_doc(**extra):
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4")
    idx = np.array([0, 1, 2], "<u2")
    uri, length = _buffer([pos, idx])
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri, "byteLength": length}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.1, 1],
                                                "metallicFactor": 0.0, "roughnessFactor": 0.5},
                       "emissiveFactor": [1, 0.5, 0.25],
                       "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}}],
        "nodes": [{"children": [1, 2], "translation": [0, 0, -5]},
                  {"mesh": 0, "translation": [1, 0, 0]},
                  {"mesh": 0, "scale": [2, 2, 2], "rotation": [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)]},
                  {"camera": 0, "translation": [0, 0, 3]},
                  {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 4, 0]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 2.0,
                                                            "znear": 0.1, "zfar": 100}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 683.0,
                                                            "color": [1, 0.5, 1]}]}},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength", "EXT_fancy"],
        "scenes": [{"nodes": [0, 3, 4]}], "scene": 0,
    }
    doc.update(extra)
    return doc


def test02_hierarchy_instancing_material_camera_light(write, caught):
    path = write("t.gltf", json.dumps(_triangle_doc()))
    with caught as messages:
        scene = glrender.load(path)
    a, = scene.shapes                                    # one mesh, two nodes: its instances
    np.testing.assert_array_equal(a.world_from_object, np.eye(4))
    first, second = a.instances
    np.testing.assert_allclose(first[:3, 3], [1, 0, -5])
    np.testing.assert_allclose(second[:3, :3], [[0, -2, 0], [2, 0, 0], [0, 0, 2]], atol=1e-12)
    mat = scene.materials[a.material]
    assert mat.kind == "roughplastic" and mat.reflectance == pytest.approx((0.8, 0.2, 0.1))
    assert mat.alpha == pytest.approx((0.25, 0.25)) and mat.distribution == "ggx"
    assert a.emission.radiance == pytest.approx((4, 2, 1))
    cam = scene.camera
    assert cam.fov == pytest.approx(math.degrees(0.5)) and cam.fov_axis == "y"
    assert scene.film.width == 2 * scene.film.height
    # the camera looks down -z of its node: +z of Mitsuba's camera frame
    np.testing.assert_allclose(cam.world_from_camera[:3, 2], [0, 0, -1])
    np.testing.assert_allclose(cam.world_from_camera[:3, 0], [-1, 0, 0])   # +x is left
    (light,) = scene.lights
    assert light.kind == "point" and light.position == pytest.approx((0, 4, 0))
    assert light.intensity == pytest.approx((1, 0.5, 1))                 # 683 cd -> 1 W/sr
    unsupported = [w for w in messages if "unsupported glTF" in w]
    assert len(unsupported) == 1 and "extension EXT_fancy" in unsupported[0]


def test03_required_extension_is_an_error(write):
    path = write("r.gltf", json.dumps(_triangle_doc(extensionsRequired=["EXT_meshopt_compression"])))
    with pytest.raises(SceneError, match="requires the glTF extension EXT_meshopt_compression"):
        glrender.load(path)


@pytest.mark.parametrize("change, message", [
    (lambda d: d["accessors"][0].update(count=1000), r"1000 elements need 12000 bytes of bufferView 0"),
    (lambda d: d["bufferViews"][1].update(byteLength=600), r"run past the end of buffer 0"),
    (lambda d: d["buffers"][0].update(byteLength=10 ** 12), r"byteLength 1000000000000 exceeds"),
    (lambda d: d["nodes"][1].update(children=[0]), r"cycle"),
    (lambda d: d["meshes"][0]["primitives"][0].update(indices=7), r"accessors\[7\]"),
    (lambda d: d["buffers"][0].update(uri="missing.bin"), r"'missing.bin' not found"),
])
def test04_hostile_documents(write, change, message):
    doc = _triangle_doc()
    change(doc)
    with pytest.raises(SceneError, match=message):
        glrender.load(write("h.gltf", json.dumps(doc)))


def test05_indices_out_of_range(write):
    doc = _triangle_doc()
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4")
    uri, length = _buffer([pos, np.array([0, 1, 9], "<u2")])
    doc["buffers"][0] = {"uri": uri, "byteLength": length}
    with pytest.raises(SceneError, match=r"outside \[0, 3\)"):
        glrender.load(write("i.gltf", json.dumps(doc)))


def _sparse_doc(base_view: bool, indices, values, count: int = 2):
    """The triangle document whose POSITION accessor replaces ``count`` vertices sparsely
    (on the dense positions, or on zeros without a base bufferView)."""
    doc = _triangle_doc()
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4")
    idx = np.array([0, 1, 2], "<u2")
    sp_idx = np.asarray(indices, "<u1")
    sp_val = np.asarray(values, "<f4")
    pad = b"\0" * 2
    blob = pos.tobytes() + idx.tobytes() + pad + sp_val.tobytes() + sp_idx.tobytes()
    doc["buffers"][0] = {"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                         "byteLength": len(blob)}
    doc["bufferViews"] += [{"buffer": 0, "byteOffset": 44, "byteLength": sp_val.nbytes},
                           {"buffer": 0, "byteOffset": 44 + sp_val.nbytes, "byteLength": sp_idx.nbytes}]
    accessor = {"componentType": 5126, "count": 3, "type": "VEC3",
                "sparse": {"count": count, "indices": {"bufferView": 3, "componentType": 5121},
                           "values": {"bufferView": 2}}}
    if base_view:
        accessor["bufferView"] = 0
    doc["accessors"][0] = accessor
    return doc


def test05b_sparse_accessors(write, caught):
    """Sparse accessors: the listed elements replaced, on the dense data or on zeros; bad
    sparse indices (out of range, not increasing) are errors naming the accessor."""
    with caught:
        scene = glrender.load(write("s.gltf", json.dumps(_sparse_doc(True, [1, 2], [[2, 0, 0], [0, 3, 0]]))))
    np.testing.assert_array_equal(scene.shapes[0].vertices, [[0, 0, 0], [2, 0, 0], [0, 3, 0]])
    with caught:
        scene = glrender.load(write("z.gltf", json.dumps(_sparse_doc(False, [0, 2], [[1, 1, 0], [0, 1, 0]]))))
    np.testing.assert_array_equal(scene.shapes[0].vertices, [[1, 1, 0], [0, 0, 0], [0, 1, 0]])
    for indices, message in (([1, 3], r"accessors\[0\]\.sparse\.indices.*strictly increasing indices below 3"),
                             ([2, 1], r"strictly increasing")):
        with pytest.raises(SceneError, match=message):
            glrender.load(write("b.gltf", json.dumps(_sparse_doc(True, indices, [[2, 0, 0], [0, 3, 0]]))))
    with pytest.raises(SceneError, match=r"sparse.*count must be an integer in \[1, 3\]"):
        glrender.load(write("c.gltf", json.dumps(_sparse_doc(True, [1, 2], [[2, 0, 0], [0, 3, 0]], count=4))))


@pytest.mark.parametrize("cut", [10, 30, 200, 1000])
def test06_truncated_glb(write, cut):
    data = (GLTF / "BoxTextured.glb").read_bytes()
    with pytest.raises(SceneError, match="truncated|invalid glTF JSON"):
        glrender.load(write("cut.glb", data[:cut]))


def test07_glb_header_lies_about_its_length(write):
    data = bytearray((GLTF / "BoxTextured.glb").read_bytes())
    struct.pack_into("<I", data, 8, 10 ** 9)
    with pytest.raises(SceneError, match="declares 1000000000 bytes"):
        glrender.load(write("lie.glb", bytes(data)))


def test08_huge_image_header_is_refused(write):
    from test_textures import _png_header_claiming

    doc = _triangle_doc()
    png = base64.b64encode(_png_header_claiming(12000, 12000)).decode()
    doc["images"] = [{"uri": "data:image/png;base64," + png}]
    doc["textures"] = [{"source": 0}]
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    with pytest.raises(SceneError, match=r"big\.gltf: images\[0\]: 12000 x 12000 pixels is more than "
                                         r"the 67,108,864 \(8192 x 8192\)"):
        glrender.load(write("big.gltf", json.dumps(doc)))
