"""glTF textures read per texel: a metallicRoughnessTexture picks the BSDF at each point
(bsdf/metallic_roughness.glsl), an emissiveTexture scales the radiance at each point of an
area light (lights/light.glsl area_light_emitted). Each textured scene renders, block by
block, as the same scene made of uniform pieces, one per texel, with independent
renders on both sides (Šidák over every block, channel and comparison of this file).

What they can see: the uniform pieces are exact (their materials and emitters are what
the loader always made); the textured scene differs only where a texel is read. On the
image means the comparisons detect a bias of 0.2% (path, metallic-roughness) to 1.3% (bdpt,
emission) (Comparison.detectable_bias, printed; asserted below 1.5%); per 8x8 block a few
percent: a plastic texel's roughness read as 0.76 instead of 0.78 fails the block test
(z 5.5). A texel that picked the wrong BSDF, an emitter texel read at the wrong uv or a
light sample that forgot the texel changes whole quadrants or halves by far more.
"""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.film.io import srgb_to_linear
from glrender.scene import model as m
from glrender.testing.images import compare_images

from bidir_scenes import renders
from gltf_scenes import png_uri, quad, write_gltf

SIZE = 24
BLOCK = 8
SEEDS_A, SEEDS_B = (11, 12, 13, 14), (21, 22, 23, 24)
# the family of block tests in this file: every comparison's blocks x channels and image mean
COMPARISONS = 6
TESTS_PER_COMPARISON = 3 * (SIZE // BLOCK) ** 2 + 2

# metallic (blue) and roughness (green) of the four texels: rough metal, smooth metal,
# and plastic at two roughness levels (rows top to bottom, v = 0 the top row)
MR_TEXELS = np.array([[[0, 64, 255], [0, 0, 255]],
                      [[0, 200, 0], [0, 90, 0]]], np.uint8)
BASE = [0.8, 0.5, 0.3, 1.0]
# the emissive texture: two texels along u, decoded from sRGB
EMISSIVE_TEXELS = np.array([[[255, 128, 40], [60, 200, 255]]], np.uint8)
STRENGTH = 4.0


def device_value(x) -> float:
    """A texel value as the device holds it (textures are half floats)."""
    return float(np.float16(np.float32(x)))


def emitter_material(factor) -> dict:
    return {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0},
            "emissiveFactor": list(factor),
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": STRENGTH}}}


def metallic_roughness_scene(tmp_path, textured: bool) -> m.Scene:
    """A quad ([-1, 1]^2 at z = 0, facing +z; u along +x, v down -y) under a uniform
    panel and a uniform environment: its texture's four texels, or four quads, one per
    texel, each with the texel's metallic and roughness as uniform factors."""
    light = quad((-0.4, -0.4, 2.0), (0, 0.8, 0), (0.8, 0, 0)) + (0,)       # facing -z
    materials = [emitter_material((1.0, 1.0, 1.0))]
    if textured:
        materials.append({"pbrMetallicRoughness": {"baseColorFactor": BASE, "metallicFactor": 1.0,
                                                   "roughnessFactor": 1.0,
                                                   "metallicRoughnessTexture": {"index": 0}}})
        prims = [light, quad((-1, 1, 0), (0, -2, 0), (2, 0, 0), uv_e1=(0, 1), uv_e2=(1, 0)) + (1,)]
        images = [png_uri(MR_TEXELS)]
    else:
        prims, images = [light], []
        for row in range(2):
            for col in range(2):
                _, g, b = MR_TEXELS[row, col] / 255.0
                materials.append({"pbrMetallicRoughness": {
                    "baseColorFactor": BASE, "metallicFactor": device_value(b),
                    "roughnessFactor": device_value(g)}})
                x0, y0 = -1.0 + col, 1.0 - row
                prims.append(quad((x0, y0, 0), (0, -1, 0), (1, 0, 0)) + (len(materials) - 1,))
    path = write_gltf(tmp_path / f"mr-{textured}.gltf", prims, materials, images,
                      camera=((0.0, -1.6, 3.6), (0, 0, 0), (0, 0, 1), 0.62))
    scene = glrender.load(path)
    scene.film = m.Film(SIZE, SIZE, filter="box")
    scene.lights.append(m.Light("constant", radiance=(0.4, 0.45, 0.5)))
    return scene


def emission_scene(tmp_path, textured: bool, split: int = 1) -> m.Scene:
    """A panel (x in [-1, 1], y in [-0.5, 0.5], z = 1, facing down) over a diffuse floor,
    seen from below its plane (near enough that light samples below it take the spherical
    triangle, whose point's uv is found from its position): with the emissive texture's two texels, or as two panels,
    one per texel with its radiance as a uniform factor. ``split`` cuts the textured panel
    into split^2 cells (2 split^2 triangles: above 32 the mesh goes to the BVH)."""
    linear = srgb_to_linear(EMISSIVE_TEXELS / 255.0)[0]
    if textured:
        materials = [emitter_material((1.0, 1.0, 1.0))]
        materials[0]["emissiveTexture"] = {"index": 0}
        prims = [quad((-1, -0.5, 1.0), (0, 1, 0), (2, 0, 0), uv_e1=(0, 1), uv_e2=(1, 0), split=split) + (0,)]
        images = [png_uri(EMISSIVE_TEXELS)]
    else:
        materials = [emitter_material([device_value(c) for c in linear[k]]) for k in range(2)]
        prims = [quad((-1 + k, -0.5, 1.0), (0, 1, 0), (1, 0, 0)) + (k,) for k in range(2)]
        images = []
    path = write_gltf(tmp_path / f"em-{textured}-{split}.gltf", prims, materials, images,
                      camera=((0.3, -3.2, 0.45), (0, 0, 0.55), (0, 0, 1), 0.75))
    scene = glrender.load(path)
    scene.film = m.Film(SIZE, SIZE, filter="box")
    floor = scene.add_material(m.Material("diffuse", reflectance=(0.7, 0.7, 0.7)))
    scene.shapes.append(m.Shape("rectangle", material=floor, world_from_object=m.scale(3.0)))
    return scene


def agree(a: np.ndarray, b: np.ndarray) -> None:
    ref, ref_se = b.mean(axis=0), b.std(axis=0, ddof=1) / np.sqrt(len(b))
    c = compare_images(a, ref, ref_se, block=BLOCK,
                       extra_tests=(COMPARISONS - 1) * TESTS_PER_COMPARISON)
    print(c.summary())
    assert c.detectable_bias < 0.015, c.summary()
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def test01_loader_makes_one_per_texel_material(tmp_path):
    """The textured quad is one metallicroughness material with its factors in the
    texture; the emissive one an area light with the texture (no mean taken)."""
    scene = metallic_roughness_scene(tmp_path, True)
    mat = scene.materials[scene.shapes[1].material]
    assert mat.kind == "metallicroughness"
    np.testing.assert_allclose(mat.metallic_roughness.image[0, 0], [0, 64 / 255, 1], rtol=1e-6)
    scene = emission_scene(tmp_path, True)
    emission = scene.shapes[0].emission
    assert emission.texture is not None and emission.radiance == (STRENGTH,) * 3


@pytest.mark.parametrize("integrator, spp", [("path", 128), ("bdpt", 64)])
def test02_metallic_roughness_texture_per_texel(gl_ctx, tmp_path, integrator, spp):
    textured = renders(metallic_roughness_scene(tmp_path, True), integrator, spp, SEEDS_A, max_depth=3)
    pieces = renders(metallic_roughness_scene(tmp_path, False), integrator, spp, SEEDS_B, max_depth=3)
    agree(textured, pieces)


@pytest.mark.parametrize("integrator, spp, split", [("path", 256, 1), ("path", 256, 6),
                                                    ("lighttrace", 256, 1), ("bdpt", 128, 1)])
def test03_emissive_texture_per_texel(gl_ctx, tmp_path, integrator, spp, split):
    """Seen directly, and lighting the floor: emitter hits and light samples (path; below
    the panel they take the spherical triangle),
    emission from the light (light tracing), every strategy (bdpt); split 6 puts the
    panel into the BVH."""
    textured = renders(emission_scene(tmp_path, True, split), integrator, spp, SEEDS_A, max_depth=2)
    pieces = renders(emission_scene(tmp_path, False), integrator, spp, SEEDS_B, max_depth=2)
    assert pieces.mean() > 0.05, pieces.mean()
    agree(textured, pieces)
