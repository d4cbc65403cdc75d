"""Normal maps and opacity cutouts from the scene formats: TOML, OBJ/MTL and glTF."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

import glrender
from glrender.errors import SceneError

NORMAL = np.array([[[128, 128, 255], [255, 128, 128]]], np.uint8)         # 1 x 2 RGB
RGBA = np.array([[[200, 10, 10, 0], [10, 200, 10, 255]]], np.uint8)      # alpha 0 | 1


def images(folder):
    Image.fromarray(NORMAL).save(folder / "n.png")
    Image.fromarray(RGBA, "RGBA").save(folder / "rgba.png")


def test01_toml(write, tmp_path):
    images(tmp_path)
    path = write("s.toml", """
[textures.bumps]
file = "n.png"
raw = true

[materials.leaf]
reflectance = 0.5
normal_map = "bumps"
normal_scale = 0.5
opacity = { file = "rgba.png", raw = true }
alpha_cutoff = 0.25

[[shapes]]
type = "rectangle"
material = "leaf"
""")
    mat = glrender.load(path).materials[0]
    np.testing.assert_allclose(mat.normal_map.image, NORMAL / 255.0, atol=1e-6)   # raw
    assert mat.normal_scale == 0.5 and mat.alpha_cutoff == 0.25
    assert mat.opacity.image.shape == (1, 2, 3)


@pytest.mark.parametrize("field, value, message", [
    ("normal_map", "3", "materials.leaf.normal_map: expected a texture"),
    ("opacity", '"nothing"', "materials.leaf.opacity: no texture named 'nothing'"),
    ("alpha_cutoff", "2", "materials.leaf.alpha_cutoff"),
])
def test02_toml_errors(write, field, value, message):
    path = write("s.toml", f"[materials.leaf]\n{field} = {value}\n")
    with pytest.raises(SceneError, match=message.replace(".", r"\.").replace("(", r"\(")):
        glrender.load(path)


def test03_obj_mtl(write, tmp_path):
    images(tmp_path)
    write("m.mtl", "newmtl leaf\nKd 0.5 0.5 0.5\nmap_d rgba.png\nnorm n.png\n")
    path = write("s.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                          "usemtl leaf\nf 1/1 2/2 3/3\n")
    scene = glrender.load(path)
    mat = scene.materials[scene.shapes[0].material]
    np.testing.assert_allclose(mat.opacity.image[..., 0], [[0.0, 1.0]])      # the alpha channel
    np.testing.assert_allclose(mat.normal_map.image, NORMAL / 255.0, atol=1e-6)


def test04_gltf_normal_texture_and_mask(write, tmp_path):
    from test_gltf import _triangle_doc

    images(tmp_path)
    doc = _triangle_doc()
    doc["images"] = [{"uri": "n.png"}, {"uri": "rgba.png"}]
    doc["textures"] = [{"source": 0}, {"source": 1}]
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 1},
                                                  "baseColorFactor": [1, 1, 1, 0.5],
                                                  "metallicFactor": 0.0},
                         "normalTexture": {"index": 0, "scale": 0.75},
                         "alphaMode": "MASK", "alphaCutoff": 0.3}]
    path = write("s.gltf", json.dumps(doc))
    scene = glrender.load(path)
    mat = scene.materials[scene.shapes[0].material]
    np.testing.assert_allclose(mat.normal_map.image, NORMAL / 255.0, atol=1e-6)
    assert mat.normal_scale == 0.75 and mat.alpha_cutoff == pytest.approx(0.3)
    np.testing.assert_allclose(mat.opacity.image[..., 0], [[0.0, 0.5]])    # alpha x factor
    # the base colour stays sRGB-decoded colour, not the alpha
    assert mat.reflectance.image[0, 0, 0] > 0.5
