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
normal_shadowing = true
opacity = { file = "rgba.png", raw = true }
alpha_cutoff = 0.25

[[shapes]]
type = "rectangle"
material = "leaf"
""")
    mat = glrender.load(path).materials[0]
    np.testing.assert_allclose(mat.normal_map.image, NORMAL / 255.0, atol=1e-6)   # raw
    assert mat.normal_scale == 0.5 and mat.alpha_cutoff == 0.25
    assert mat.normal_shadowing and not mat.normal_flip     # the flip stays off unless asked
    assert mat.opacity.image.shape == (1, 2, 3)


@pytest.mark.parametrize("field, value, message", [
    ("normal_map", "3", "materials.leaf.normal_map: expected a texture"),
    ("opacity", '"nothing"', "materials.leaf.opacity: no texture named 'nothing'"),
    ("alpha_cutoff", "2", "materials.leaf.alpha_cutoff"),
    ("normal_flip", "true", "materials.leaf.normal_flip: applies to a normal map"),
    ("normal_shadowing", "1", "materials.leaf.normal_shadowing"),
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
    assert not mat.normal_shadowing and not mat.normal_flip


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
    assert not mat.normal_shadowing and not mat.normal_flip      # glTF's plain normal map
    np.testing.assert_allclose(mat.opacity.image[..., 0], [[0.0, 0.5]])    # alpha x factor
    # the base colour stays sRGB-decoded colour, not the alpha
    assert mat.reflectance.image[0, 0, 0] > 0.5


def test05_obj_with_dozens_of_textures_renders_each(write, tmp_path, gl_ctx):
    """36 quads in a 6x6 grid, each with its own MTL material and map_Kd image (sizes from
    1x1 to 96x40, one flat colour each), under a uniform sky: every quad's pixels show its
    own texture's colour times the diffuse sky response (albedo x radiance 1)."""
    rng = np.random.default_rng(5)
    colours = rng.uniform(0.1, 0.9, (36, 3))
    mtl, obj, vt = [], ["mtllib m.mtl", "vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1"], 0
    for k in range(36):
        h, w = int(rng.integers(1, 41)), int(rng.integers(1, 97))
        srgb = np.round(255 * colours[k] ** (1 / 2.2)).astype(np.uint8)
        Image.fromarray(np.broadcast_to(srgb, (h, w, 3)).copy()).save(tmp_path / f"t{k}.png")
        mtl += [f"newmtl m{k}", f"map_Kd t{k}.png"]
        x, y = k % 6 - 3.0, k // 6 - 3.0
        obj += [f"v {x + 0.05} {y + 0.05} 0", f"v {x + 0.95} {y + 0.05} 0",
                f"v {x + 0.95} {y + 0.95} 0", f"v {x + 0.05} {y + 0.95} 0",
                f"usemtl m{k}", f"f {4 * k + 1}/1 {4 * k + 2}/2 {4 * k + 3}/3 {4 * k + 4}/4"]
    write("m.mtl", "\n".join(mtl) + "\n")
    path = write("grid.obj", "\n".join(obj) + "\n")
    from glrender.film.tonemap import srgb_to_linear
    from glrender.scene import model as m

    scene = glrender.load(path)
    assert len(scene.materials) >= 36
    scene.lights = [m.Light("constant")]
    scene.integrator = m.Integrator("path", max_depth=2)
    scene.film = m.Film(120, 120, filter="box")
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 10), (0, 0, 0), (0, 1, 0)),
                            fov=2 * np.degrees(np.arctan(3.0 / 10)))
    film = glrender.render(scene, spp=64, seed=1, sampler="independent")
    for k in range(36):
        # quad k's centre: x = k % 6 - 2.5, y = k // 6 - 2.5 (world +x to the image's right
        # seen from +z, +y up)
        col = int(round(60 + (k % 6 - 2.5) * 20 - 0.5))
        row = int(round(60 - (k // 6 - 2.5) * 20 - 0.5))
        got = film.mean[row - 3:row + 4, col - 3:col + 4].reshape(-1, 3).mean(axis=0)
        want = srgb_to_linear(np.round(255 * colours[k] ** (1 / 2.2)) / 255.0)
        # a diffuse quad under a sky of radiance 1 reflects its albedo; 49 pixels x 64
        # samples of a cosine-weighted estimate: a few tenths of a percent of noise
        np.testing.assert_allclose(got, want, rtol=0.03, err_msg=f"quad {k}")


def test06_mitsuba_normalmap_and_mask(write, tmp_path, caught):
    images(tmp_path)
    path = write("s.xml", """<scene version="3.0.0">
  <shape type="rectangle">
    <bsdf type="mask">
      <texture name="opacity" type="bitmap">
        <string name="filename" value="rgba.png"/><boolean name="raw" value="true"/>
      </texture>
      <bsdf type="normalmap">
        <texture name="normalmap" type="bitmap">
          <string name="filename" value="n.png"/><boolean name="raw" value="true"/>
        </texture>
        <bsdf type="roughplastic"/>
      </bsdf>
    </bsdf>
  </shape>
</scene>""")
    with caught as messages:
        scene = glrender.load(path)
    mat = scene.materials[scene.shapes[0].material]
    assert mat.kind == "roughplastic"
    np.testing.assert_allclose(mat.normal_map.image, NORMAL / 255.0, atol=1e-6)
    assert mat.opacity is not None and mat.alpha_cutoff == 0.5
    assert any("mask (read as an opacity cutout at 0.5)" in w for w in messages)
    bad = write("b.xml", '<scene version="3.0.0"><shape type="rectangle"><bsdf type="normalmap">'
                         '<bsdf type="diffuse"/></bsdf></shape></scene>')
    with pytest.raises(SceneError, match=r'b.xml:1: .*needs a <texture name="normalmap">'):
        glrender.load(bad)


@pytest.mark.parametrize("flags, shadowing, flip", [
    ("", True, True),
    ('<boolean name="use_shadowing_function" value="false"/>', False, True),
    ('<boolean name="use_shadowing_function" value="false"/>'
     '<boolean name="flip_invalid_normals" value="false"/>', False, False),
])
def test07_mitsuba_normalmap_terminator_options(write, tmp_path, caught, flags, shadowing, flip):
    """Mitsuba 3.7.1 on multiplies a normal map by a shadowing term and flips normals that
    hide wi, both by default: the loader maps both with those defaults, silently (the parity
    scenes bsdf-normalmap, both off, and bsdf-normalmap-mitsuba-defaults match Mitsuba)."""
    images(tmp_path)
    path = write("s.xml", f"""<scene version="3.0.0"><shape type="rectangle">
      <bsdf type="normalmap">{flags}
        <texture name="normalmap" type="bitmap">
          <string name="filename" value="n.png"/><boolean name="raw" value="true"/>
        </texture>
        <bsdf type="diffuse"/>
      </bsdf></shape></scene>""")
    with caught as messages:
        scene = glrender.load(path)
    mat = scene.materials[scene.shapes[0].material]
    assert mat.normal_map is not None
    assert (mat.normal_shadowing, mat.normal_flip) == (shadowing, flip)
    assert not [w for w in messages if "shadowing" in w or "flip_invalid" in w], messages
