"""Normal maps (tangent space, glTF convention) and alpha cutouts (opacity textures honoured
by camera, path and shadow rays)."""
from __future__ import annotations

import numpy as np
import pytest

import glrender
from glrender.scene import model as m

QUAD_V = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
QUAD_T = np.array([[0, 1, 2], [0, 2, 3]])
# image convention: v = 0 is the top row, so the quad's top edge (+y) has v = 0
QUAD_UV = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float64)


def flat_map(n_tangent) -> m.Texture:
    """A 2x2 raw normal map holding one tangent-space normal everywhere."""
    n = np.asarray(n_tangent, np.float64)
    n = n / np.linalg.norm(n)
    return m.Texture("bitmap", image=np.full((2, 2, 3), 0.5 * n + 0.5, np.float32),
                     filter="nearest")


def quad_scene(material: m.Material, kind: str) -> m.Scene:
    scene = m.Scene(film=m.Film(8, 8, filter="box"), integrator=m.Integrator("path", max_depth=2))
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 3), (0, 0, 0), (0, 1, 0)), fov=20)
    scene.materials.append(material)
    if kind == "mesh":
        scene.shapes.append(m.Shape("mesh", vertices=QUAD_V, triangles=QUAD_T, uvs=QUAD_UV))
    else:
        scene.shapes.append(m.Shape("rectangle"))
    scene.lights.append(m.Light("constant"))
    return scene


@pytest.mark.parametrize("kind", ["mesh", "rectangle"])
@pytest.mark.parametrize("tangent, world", [
    ((0, 0, 1), (0, 0, 1)),                 # the unperturbed normal
    ((1, 0, 1), (1, 0, 1)),                 # +x of the map: along dp/du (u grows to +x)
    ((0, 1, 1), (0, 1, 1)),                 # +y of the map: up the image, +y here
    ((-1, -2, 3), (-1, -2, 3)),
])
def test01_normal_map_frame(gl_ctx, kind, tangent, world):
    """The shading normal AOV of a quad facing +z with u along +x and v down the image
    (the quad's +y) is the map's normal in (dp/du, n x dp/du, n)."""
    mat = m.Material("diffuse", normal_map=flat_map(tangent))
    film = glrender.render(quad_scene(mat, kind), spp=4, seed=1, aovs=True)
    want = np.asarray(world, np.float64) / np.linalg.norm(world)
    got = film.aov("normal")[2:6, 2:6].reshape(-1, 3)
    # half-float texels: 2^-11 per component, turned by the normalisation
    np.testing.assert_allclose(got, np.broadcast_to(want, got.shape), atol=2e-3)


def test02_normal_scale_and_no_map(gl_ctx):
    mat = m.Material("diffuse", normal_map=flat_map((1, 0, 1)), normal_scale=0.0)
    film = glrender.render(quad_scene(mat, "mesh"), spp=4, seed=1, aovs=True)
    np.testing.assert_allclose(film.aov("normal")[2:6, 2:6].reshape(-1, 3), [[0, 0, 1]] * 16,
                               atol=1e-6)


def test03_normal_map_shades(gl_ctx):
    """A diffuse plane under a directional light along -z: radiance albedo/pi * E * cos, with
    cos the map normal's z (the map turns the normal by 60 degrees: half the light)."""
    tilt = (np.sin(np.radians(60)), 0, np.cos(np.radians(60)))
    for normal_map, factor in ((None, 1.0), (flat_map(tilt), 0.5)):
        scene = quad_scene(m.Material("diffuse", reflectance=(0.5,) * 3, normal_map=normal_map),
                           "mesh")
        scene.lights = [m.Light("directional", direction=(0, 0, -1), irradiance=(2.0,) * 3)]
        got = glrender.render(scene, spp=4, seed=1).mean[2:6, 2:6]
        np.testing.assert_allclose(got, 0.5 / np.pi * 2.0 * factor, rtol=2e-3)


def shadowing_term(cos_tilt: float, cos_l: float) -> float:
    """Conty Estevez et al. (2019): alpha^2 = min(tan^2 tilt / 8, 1), G1 of the light."""
    alpha2 = min((1 - cos_tilt ** 2) / cos_tilt ** 2 / 8, 1.0)
    return 2 / (1 + np.sqrt(1 + alpha2 * (1 - cos_l ** 2) / cos_l ** 2))


@pytest.mark.parametrize("kind", ["mesh", "rectangle"])
def test03b_shadowing_term_shades(gl_ctx, kind):
    """The same plane lit from 50 degrees off its normal, the map tilted by 60 toward the
    light: albedo/pi * E * cos(light, map normal) * the shadowing term of the light's
    angle to the unperturbed normal (the camera's direction plays no part)."""
    tilt, light = np.radians(60), np.radians(50)
    normal_map = flat_map((np.sin(tilt), 0, np.cos(tilt)))
    scene = quad_scene(m.Material("diffuse", reflectance=(0.5,) * 3, normal_map=normal_map,
                                  normal_shadowing=True), kind)
    scene.lights = [m.Light("directional", direction=(-np.sin(light), 0, -np.cos(light)),
                            irradiance=(2.0,) * 3)]
    got = glrender.render(scene, spp=4, seed=1).mean[2:6, 2:6]
    g = shadowing_term(np.cos(tilt), np.cos(light))
    assert 0.85 < g < 0.9
    np.testing.assert_allclose(got, 0.5 / np.pi * 2.0 * np.cos(tilt - light) * g, rtol=3e-3)


def test03c_term_compiled_in_only_when_asked(gl_ctx):
    from glrender.render.renderer import Renderer, settings_from_scene

    for shadowing in (False, True):
        scene = quad_scene(m.Material("diffuse", normal_map=flat_map((1, 0, 1)),
                                      normal_shadowing=shadowing), "mesh")
        r = Renderer(scene, settings_from_scene(scene, spp=1), ctx=gl_ctx)
        try:
            assert ("GLRENDER_NORMAL_SHADOWING" in r.defines) == shadowing
        finally:
            r.release()


@pytest.mark.parametrize("flip", [False, True])
def test03d_flip_invalid_normals(gl_ctx, flip):
    """Seen from 72 degrees off the plane's normal on the -x side, a map normal tilted 79
    degrees toward +x hides the camera: the flip turns it round the unperturbed normal."""
    n = np.array([1.0, 0.0, 0.2]) / np.hypot(1.0, 0.2)
    scene = quad_scene(m.Material("diffuse", normal_map=flat_map(n), normal_flip=flip), "mesh")
    scene.camera = m.Camera(world_from_camera=m.look_at((-3, 0, 1), (0, 0, 0), (0, 1, 0)), fov=10)
    film = glrender.render(scene, spp=4, seed=1, aovs=True)
    normals = film.aov("normal").reshape(-1, 3)
    on_quad = np.linalg.norm(normals, axis=1) > 0.999     # every sample of the pixel hit it
    assert on_quad.sum() >= 8
    want = n * (-1, -1, 1) if flip else n
    np.testing.assert_allclose(normals[on_quad], np.broadcast_to(want, normals[on_quad].shape),
                               atol=3e-3)


def half_cut_opacity() -> m.Texture:
    """Opacity 0 on the left half of the image (u < 1/2), 1 on the right half."""
    image = np.zeros((4, 4, 3), np.float32)
    image[:, 2:] = 1.0
    return m.Texture("bitmap", image=image, filter="nearest")


@pytest.mark.parametrize("kind", ["mesh", "rectangle"])
def test04_alpha_cutout_camera_rays(gl_ctx, kind):
    """Where the opacity is 0 the camera sees the sky (radiance 1) through the quad; where it
    is 1, the diffuse quad under the sky (albedo 0.5)."""
    scene = quad_scene(m.Material("diffuse", reflectance=(0.5,) * 3, opacity=half_cut_opacity()),
                       kind)
    scene.integrator = m.Integrator("path", max_depth=-1)
    film = glrender.render(scene, spp=64, seed=2, sampler="independent")
    # the quad spans the 8x8 image (fov 20 at distance 3: +-0.53 of +-1): columns 0-3 are
    # u < 1/2 (camera +x is the image's left, so the image is mirrored: check both sides)
    left, right = film.mean[:, :3].mean(), film.mean[:, 5:].mean()
    holes, solid = sorted([left, right], reverse=True)
    assert abs(holes - 1.0) < 1e-4                 # the sky, exactly (no surface in the way)
    assert abs(solid - 0.5) < 0.03                 # the diffuse quad lit by the sky


def test05_alpha_cutout_shadow_rays(gl_ctx):
    """A floor under a point light, an occluder between with its left half cut out: the floor
    is lit exactly (I cos / r^2) under the hole and black under the solid half."""
    scene = m.Scene(film=m.Film(16, 16, filter="box"), integrator=m.Integrator("direct"))
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 6), (0, 0, 0), (0, 1, 0)), fov=30)
    floor = m.Material("diffuse", reflectance=(1.0,) * 3)
    cut = m.Material("diffuse", reflectance=(1.0,) * 3, opacity=half_cut_opacity(), two_sided=True)
    scene.materials += [floor, cut]
    big = QUAD_V * [3, 3, 1]
    scene.shapes.append(m.Shape("mesh", vertices=big, triangles=QUAD_T, uvs=QUAD_UV, material=0))
    # the occluder at z = 2, seen edge-on by nobody: the camera looks through it at the floor
    occluder = QUAD_V * [0.5, 0.5, 1] + [0, 0, 2]
    scene.shapes.append(m.Shape("mesh", vertices=occluder, triangles=QUAD_T, uvs=QUAD_UV,
                                material=1))
    scene.lights.append(m.Light("point", position=(0, 0, 4), intensity=(1.0,) * 3))
    floor_only = m.Scene(film=scene.film, integrator=scene.integrator, camera=scene.camera,
                         materials=[floor], shapes=[scene.shapes[0]], lights=scene.lights)
    free = glrender.render(floor_only, spp=1, seed=1).mean
    shadowed = glrender.render(scene, spp=1, seed=1).mean
    scene.materials[1] = m.Material("diffuse", reflectance=(1.0,) * 3, two_sided=True)
    opaque = glrender.render(scene, spp=1, seed=1).mean
    # the camera looks through the cutout's holes at the floor and sees the occluder's solid
    # half: compare pixels that show the floor in all three renders' geometry
    full_shadow = (opaque == 0).all(axis=-1)
    cut_shadow = (shadowed == 0).all(axis=-1)
    assert full_shadow.sum() >= 8
    assert not (cut_shadow & ~full_shadow).any()          # holes add no shadow
    through = full_shadow & ~cut_shadow                   # light through the holes
    assert 0.3 < through.sum() / full_shadow.sum() < 0.7  # half the occluder is cut out
    np.testing.assert_allclose(shadowed[through], free[through], rtol=1e-5)


def test06_cutouts_on_other_shapes_are_refused():
    from glrender.errors import SceneError
    from glrender.gpu.pack import pack_scene

    scene = quad_scene(m.Material("diffuse", opacity=half_cut_opacity()), "mesh")
    scene.shapes = [m.Shape("sphere")]
    with pytest.raises(SceneError, match="opacity cutouts apply to meshes and rectangles"):
        pack_scene(scene)
