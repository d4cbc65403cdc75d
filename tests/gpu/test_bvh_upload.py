"""Geometry past one buffer texture (glrender/gpu/bvh_upload.py, shaders/geometry/bvh_layout.glsl):
each kind of BVH and per-triangle data cut into parts renders the image it renders from one
texture, bit for bit, and a scene that needs more parts than the units allow is refused in one
line before its BVH is built. The tests force the texel limit down (bvh_upload.TEXEL_LIMIT) so
that a mesh of 100k triangles needs parts; traversal widths: tests/accel/test_traversal.py."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from glrender.errors import UsageError
from glrender.gpu import bvh_upload
from glrender.gpu.device_scene import DeviceScene
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.scene import model as m

# the corners of the scene's 99,860 triangles (299,580 texels) in five parts of 69,996 texels,
# and every other kind in two to five
TEXEL_LIMIT = 70_000


def bumpy_sphere(rows: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A latitude-longitude sphere of 4 rows^2 triangles (rows x 2 rows quads), its radius
    displaced by ripples so that neighbouring triangles face apart: vertices, triangles, uvs."""
    theta, phi = np.meshgrid(np.linspace(0, np.pi, rows + 1), np.linspace(0, 2 * np.pi, 2 * rows + 1),
                             indexing="ij")
    r = 1 + 0.04 * np.sin(9 * theta) * np.cos(13 * phi)
    v = np.stack([r * np.sin(theta) * np.cos(phi), r * np.cos(theta), r * np.sin(theta) * np.sin(phi)], -1)
    uv = np.stack([phi / (2 * np.pi), theta / np.pi], -1)
    i = np.arange(rows)[:, None] * (2 * rows + 1) + np.arange(2 * rows)[None, :]
    quads = np.stack([i, i + 1, i + 2 * rows + 2, i + 2 * rows + 1], -1).reshape(-1, 4)
    f = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    return v.reshape(-1, 3), f, uv.reshape(-1, 2)


def big_mesh_scene() -> m.Scene:
    """A checkered bumpy sphere of 99,856 triangles (99,540 of them of non-zero area) and a
    small turning mesh of 320 in front of it (a motion instance: its tree and triangles follow
    the static ones in the same textures), lit by a point light and a constant environment."""
    scene = m.Scene(film=m.Film(width=64, height=64, filter="box"), integrator=m.Integrator(max_depth=3),
                    source="<100k triangles>")
    scene.camera = m.Camera(world_from_camera=m.look_at((0.0, 0.4, 3.2), (0, 0, 0), (0, 1, 0)), fov=45)
    checker = m.Texture("checkerboard", color0=(0.8, 0.3, 0.2), color1=(0.2, 0.5, 0.8),
                        uv_transform=np.diag([16.0, 8.0, 1.0]))
    v, f, uv = bumpy_sphere(158)
    scene.shapes.append(m.Shape("mesh", material=scene.add_material(m.Material("diffuse", reflectance=checker)),
                                vertices=v, triangles=f, uvs=uv))
    ico = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    moving = m.Shape("mesh", material=scene.add_material(m.Material("roughplastic", alpha=0.2)),
                     vertices=ico.vertices, triangles=ico.faces, world_from_object=m.translate((0.6, 0.2, 1.2)))
    moving.world_from_object_close = m.translate((0.8, 0.3, 1.1)) @ m.rotate((0, 0, 1), 60)
    scene.shapes.append(moving)
    scene.shutter = m.Shutter(0, 1)
    scene.lights += [m.Light("point", position=(2.0, 3.0, 3.0), intensity=(20.0,) * 3),
                     m.Light("constant", radiance=(0.3, 0.3, 0.3))]
    return scene


def render(scene: m.Scene, gl_ctx, **options) -> tuple[np.ndarray, dict]:
    with Renderer(scene, settings_from_scene(scene, spp=4, seed=3, **options), ctx=gl_ctx) as r:
        r.step(4)
        return r.film().mean.copy(), dict(r.device_scene.defines())


@pytest.mark.parametrize("options", [dict(integrator="path"), dict(integrator="path", executor="wavefront"),
                                     dict(integrator="bdpt")], ids=["path", "wavefront", "bdpt"])
def test01_a_mesh_in_parts_renders_bitwise_the_one_texture_image(gl_ctx, monkeypatch, options):
    """The render kernel, the wavefront executor's stages and bdpt (light subpaths, splats)."""
    scene = big_mesh_scene()
    whole, defines = render(scene, gl_ctx, **options)
    assert defines == {}
    monkeypatch.setattr(bvh_upload, "TEXEL_LIMIT", TEXEL_LIMIT)
    split, defines = render(scene, gl_ctx, **options)
    assert defines == {"GLRENDER_GEOMETRY_PART_TEXELS": 69_996, "GLRENDER_BVH_NODE_PARTS": 2,
                       "GLRENDER_BVH_TRIANGLE_PARTS": 5, "GLRENDER_TRI_NORMAL_PARTS": 5,
                       "GLRENDER_TRI_UV_PARTS": 3, "GLRENDER_TRI_INFO_PARTS": 2}
    assert whole.std() > 0.05          # the checks, the bumps and the moving mesh show
    np.testing.assert_array_equal(split, whole)


def test02_more_parts_than_units_are_refused_before_the_build(gl_ctx, monkeypatch):
    """At 50,000 texels a texture the corners of the scene's 99,860 triangles would take six
    textures, one more than their units: one line naming the count, the limit and what to do."""
    monkeypatch.setattr(bvh_upload, "TEXEL_LIMIT", 50_000)
    with pytest.raises(UsageError) as error:
        DeviceScene(gl_ctx, big_mesh_scene())
    message = str(error.value)
    assert "\n" not in message
    assert message == ("99,860 triangles are too many for this device: their triangle corners need 6 "
                       "buffer textures of at most 50,000 texels (GL_MAX_TEXTURE_BUFFER_SIZE) and "
                       "glrender binds 5; render the scene in pieces of fewer triangles")


def test03_the_triangle_ceiling_is_what_the_upload_takes():
    """triangle_ceiling (--stats and glrender info: max_triangles) is the most triangles
    check_triangles lets through: one more is refused. With llvmpipe's limits (2^27 texels a
    texture, 32 units) the corners and the normals fill their 5 textures first."""
    from types import SimpleNamespace

    for texels, units in ((1 << 27, 32), (50_000, 32), (65_536, 28)):
        gl = SimpleNamespace(info={"GL_MAX_TEXTURE_BUFFER_SIZE": texels,
                                   "GL_MAX_COMPUTE_TEXTURE_IMAGE_UNITS": units})
        most, kind = bvh_upload.triangle_ceiling(gl)
        bvh_upload.check_triangles(gl, most)
        with pytest.raises(UsageError):
            bvh_upload.check_triangles(gl, most + 1)
        if texels == 1 << 27:
            assert (most, kind) == (5 * (texels // 12 * 12) // 3, "triangles")
