"""Renderer features one by one: AOVs, non-finite samples, pixel filters, spot and
directional lights, the thin lens, motion blur, and the direct strategies on Veach's scene."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.scene import model as m
from glrender.testing.images import compare_images
from render_scenes import plane_points, plane_under_light

ROOT = Path(__file__).resolve().parents[2]


def cornell(width=32, height=32):
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film.width, scene.film.height = width, height
    return scene


def test01_aovs(gl_ctx):
    """First-hit albedo, shading normal and depth, averaged over each pixel's samples."""
    scene = cornell()
    film = glrender.render(scene, spp=8, seed=1, aovs=True)
    albedo, normal, depth = film.aov("albedo"), film.aov("normal"), film.aov("depth")
    assert albedo.shape == (32, 32, 3) and depth.shape == (32, 32)
    # the pixel in the middle of the back wall sees the white material straight on
    np.testing.assert_allclose(albedo[8, 16], [0.885809, 0.698859, 0.666422], rtol=1e-5)
    np.testing.assert_allclose(normal[8, 16], [0, 0, 1], atol=1e-5)
    # depth along the ray: camera at z = 3.9, back wall at z = -1
    assert 4.9 < depth[8, 16] < 5.0
    assert np.all(film.variance >= 0)
    with pytest.raises(glrender.UsageError, match="AOV 'albedo' was not rendered"):
        glrender.render(scene, spp=1, seed=1).aov("albedo")


def test02_nonfinite_samples_are_dropped_and_counted(gl_ctx):
    scene = cornell(16, 16)
    settings = settings_from_scene(scene, spp=14, seed=2, sampler="independent")
    bad = replace(settings, debug_nonfinite=4)        # samples 3 and 10 of every pixel are NaN
    r = Renderer(scene, bad)
    r.step(14)
    f = r.film()
    r.release()
    assert f.nonfinite_total == 2 * 16 * 16 and (f.count == 12).all()
    assert np.all(np.isfinite(f.mean)) and np.all(np.isfinite(f.variance))


def filter_1d(kind, x, radius, stddev=0.5, b=1 / 3, c=1 / 3):
    """The filters' 1D profiles as Mitsuba defines them (the 2D filter is separable)."""
    x = np.abs(x)
    if kind == "box":
        return (x <= radius).astype(float)
    if kind == "tent":
        return np.maximum(0.0, 1.0 - x / radius)
    if kind == "gaussian":
        return np.maximum(0.0, np.exp(-x * x / (2 * stddev ** 2)) - np.exp(-radius ** 2 / (2 * stddev ** 2)))
    y = 2 * x / radius
    return np.where(y > 2, 0.0, np.where(
        y > 1, (-b - 6 * c) * y ** 3 + (6 * b + 30 * c) * y ** 2 + (-12 * b - 48 * c) * y + (8 * b + 24 * c),
        (12 - 9 * b - 6 * c) * y ** 3 + (-18 + 12 * b + 6 * c) * y ** 2 + (6 - 2 * b))) / 6


@pytest.mark.parametrize("filter_kind", ["box", "tent", "gaussian", "mitchell"])
def test03_pixel_filters(gl_ctx, filter_kind):
    """Filter importance sampling: each pixel converges to the filter-weighted average of
    the image around its centre, integral(f L) / integral(f), computed here by quadrature
    of the analytic radiance of a point-lit plane."""
    light = m.Light("point", position=(0.3, -0.2, 3.0), intensity=(30.0,) * 3)
    scene = plane_under_light(light, kind="direct", strategy="light", max_depth=2, width=24, height=24)
    scene.film.filter = filter_kind
    radius = scene.film.radius
    imgs = np.stack([glrender.render(scene, spp=64, seed=s, sampler="independent").mean for s in range(4)])
    # quadrature over the filter's support, 64 nodes per axis, in the camera's pixel units
    from glrender.render.renderer import camera_tangents

    w = h = 24
    tx, ty = camera_tangents(scene.camera, w, h)
    nodes = (np.arange(64) + 0.5) / 64 * 2 * radius - radius
    f1 = filter_1d(filter_kind, nodes, radius)
    px = np.arange(w)[:, None] + 0.5 + nodes[None, :]
    py = np.arange(h)[:, None] + 0.5 + nodes[None, :]
    X, Y = px[None, :, None, :] / w, py[:, None, :, None] / h          # (h, w, 64, 64)
    d = np.stack(np.broadcast_arrays((1 - 2 * X) * tx, (1 - 2 * Y) * ty, np.ones_like(X)), -1)
    M = scene.camera.world_from_camera
    d = d @ M[:3, :3].T
    p = M[:3, 3] + (-M[2, 3] / d[..., 2])[..., None] * d
    d2 = ((p - np.array([0.3, -0.2, 3.0])) ** 2).sum(-1)
    L = 0.5 / np.pi * 30.0 * 3.0 / d2 ** 1.5
    weights = f1[:, None] * f1[None, :]
    ref = (L * weights).sum((-1, -2)) / weights.sum()
    ref = np.repeat(ref[..., None], 3, -1)
    inner = np.zeros((24, 24), bool)
    inner[3:-3, 3:-3] = True               # the filter support stays on the plane
    c = compare_images(imgs, ref, block=4, mask=inner)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def test04_spot_light_falloff(gl_ctx):
    """A spot light straight above the plane: full intensity inside the beam width,
    nothing outside the cutoff, and between them Mitsuba 3's ramp, linear in the angle:
    (cutoff - theta) / (cutoff - beam_width)."""
    spot = m.Light("spot", intensity=(20.0,) * 3, cutoff_angle=10.0, beam_width=6.0,
                   world_from_light=m.look_at((0, 0, 5), (0, 0, 0), (0, 1, 0)))
    scene = plane_under_light(spot, kind="direct", strategy="light", max_depth=2, width=32, height=32)
    scene.camera.fov = 6       # 2.1 wide at the plane; the cone meets it at radius 0.88
    film = glrender.render(scene, spp=256, seed=1, sampler="independent").mean[..., 0]
    p = plane_points(scene, supersample=4)
    r = np.hypot(p[..., 0], p[..., 1])
    angle = np.degrees(np.arctan2(r, 5.0))
    falloff = np.clip((10.0 - angle) / (10.0 - 6.0), 0.0, 1.0)
    expected = (0.5 / np.pi * 20.0 * 5.0 / (r ** 2 + 25.0) ** 1.5 * falloff).mean(-1)
    # pixels wholly inside the beam, on the ramp, and wholly outside the cone. The only noise
    # is where in its pixel each sample lands: on the ramp the image changes by up to 18% of
    # its peak across a pixel, so 256 samples give sigma ~0.35% of the peak (2% is > 5 sigma);
    # a smooth step in the cosine is 7-9% of the peak off at the ramp's quarter points
    inside, ramp, outside = angle.max(-1) < 6.0, (angle.min(-1) > 6.0) & (angle.max(-1) < 10.0), angle.min(-1) > 10.3
    assert ramp.sum() > 100
    np.testing.assert_allclose(film[inside], expected[inside], rtol=0.02)
    np.testing.assert_allclose(film[ramp], expected[ramp], rtol=0, atol=0.02 * expected.max())
    assert film[outside].max() == 0.0


def test05_directional_light(gl_ctx):
    """Irradiance E from a direction theta off the normal: L = rho E cos(theta) / pi."""
    sun = m.Light("directional", direction=(0.6, 0.0, -0.8), irradiance=(3.0,) * 3)
    scene = plane_under_light(sun, kind="direct", strategy="light", max_depth=2, width=16, height=16)
    film = glrender.render(scene, spp=4, seed=1).mean
    np.testing.assert_allclose(film, 0.5 * 3.0 * 0.8 / np.pi, rtol=1e-5)


def test06_thin_lens_blurs_out_of_focus_only(gl_ctx):
    """With the lens focused on the plane the image equals the pinhole image; focused
    elsewhere, a sharp edge spreads over the circle of confusion."""
    light = m.Light("point", position=(0.0, 0.0, 1.0), intensity=(5.0,) * 3)
    scene = plane_under_light(light, kind="direct", strategy="light", max_depth=2, width=32, height=32)
    pin = glrender.render(scene, spp=64, seed=1, sampler="sobol").mean
    scene.camera.aperture_radius, scene.camera.focus_distance = 0.5, 20.0
    focused = glrender.render(scene, spp=64, seed=1, sampler="sobol").mean
    np.testing.assert_allclose(focused, pin, rtol=0.01)
    scene.camera.focus_distance = 5.0
    blurred = glrender.render(scene, spp=64, seed=1, sampler="sobol").mean
    # the bright centre spreads over the circle of confusion: its peak drops
    assert blurred.max() < 0.9 * pin.max()


@pytest.mark.slow
@pytest.mark.parametrize("shape", ["sphere", "mesh"])
def test07_motion_blur_averages_over_the_shutter(gl_ctx, shape):
    """An object moving across the frame (a sphere by translation; a mesh by translation
    and a quarter turn) leaves a trail equal to the average of still frames at the
    times the shutter samples (the mesh's transform interpolated as the BVH does)."""
    import trimesh

    from glrender.accel import MotionInstance

    ico = trimesh.creation.icosphere(subdivisions=1, radius=0.45)
    open_ = m.translate((-1.5, 0, 0))
    close = m.translate((1.5, 0, 0)) @ m.rotate((0, 0, 1), 90)
    if shape == "sphere":
        close = m.translate((1.5, 0, 0))
    motion = MotionInstance(ico.vertices, ico.faces, open_, close)

    def scene_with(world_open, world_close, shutter, eye=(0, 0, 6), target=(0, 0, 0), specks=False):
        sc = m.Scene(film=m.Film(width=32, height=16, filter="box"), source="<motion>")
        sc.camera = m.Camera(world_from_camera=m.look_at(eye, target, (0, 1, 0)), fov=40)
        mat = sc.add_material(m.Material("diffuse", reflectance=(0.8,) * 3))
        if shape == "sphere":
            obj = m.Shape("sphere", material=mat, radius=0.4, world_from_object=world_open)
        else:
            vertices, triangles = ico.vertices, ico.faces
            if specks:
                # two specks (triangles 1e-4 across) in the mesh, at the corners of a world
                # box around every pose of it (one behind the camera, one below the view
                # behind the mesh): the BVH's bounding box, compiled into the kernel, is then
                # the same in every still, and the stills share one kernel (48 otherwise).
                # Out of view, out of the directional light's shadow rays, each covering
                # ~1e-9 sr of the environment: no change the comparison below could see.
                tiny = np.array([[0, 0, 0], [1e-4, 0, 0], [0, 1e-4, 0]])
                corners = np.concatenate([c + tiny for c in ([-2.5, -1.5, -1.0], [2.5, 1.0, 7.0])])
                local = (np.linalg.inv(world_open) @ np.c_[corners, np.ones(6)].T).T[:, :3]
                vertices = np.concatenate([vertices, local])
                n = len(ico.vertices)
                triangles = np.concatenate([triangles, [[n, n + 1, n + 2], [n + 3, n + 4, n + 5]]])
            obj = m.Shape("mesh", material=mat, vertices=vertices, triangles=triangles,
                          world_from_object=world_open, face_normals=True)
        obj.world_from_object_close = world_close
        sc.shapes.append(obj)
        sc.lights.append(m.Light("directional", direction=(-0.3, -0.4, -1.0), irradiance=(2.0,) * 3))
        sc.lights.append(m.Light("constant", radiance=(0.3,) * 3))
        sc.shutter = shutter
        sc.integrator = m.Integrator(max_depth=2)
        return sc

    moving = scene_with(open_, close, m.Shutter(0, 1))
    blur = np.stack([glrender.render(moving, spp=64, seed=s, sampler="independent").mean for s in range(4)])
    stills = []
    for t in (np.arange(48) + 0.5) / 48:
        W = np.vstack([motion.world_from_object(t), [0, 0, 0, 1]])
        if shape == "sphere":
            # the sphere still at the origin, the camera moved by minus its centre (the
            # directional and constant lights do not change under a translation): the
            # centre is compiled into the kernel, the camera is not, so the stills share one
            c = W[:3, 3]
            still = scene_with(np.eye(4), None, m.Shutter(), eye=(-c[0], -c[1], 6 - c[2]),
                               target=(-c[0], -c[1], -c[2]))
        else:
            still = scene_with(W, None, m.Shutter(), specks=True)
        stills.append(glrender.render(still, spp=16, seed=7).mean)
    ref = np.mean(stills, axis=0)
    # the still average is itself a 48-point quadrature of the shutter integral: allow for it
    c = compare_images(blur, ref, block=4, eps=0.02, check_mse=False)
    assert c.passed, c.summary()
    assert blur.mean(0)[8].std() < 0.5 * np.stack(stills)[24][8].std()   # the trail is smooth


@pytest.mark.slow
def test08_direct_strategies_converge_on_veachs_scene(gl_ctx):
    """Light, BSDF and MIS sampling give the same image of Veach's scene per 8x8 block,
    and MIS has the lowest total variance (the variances are reported in the message)."""
    scene = glrender.load(ROOT / "scenes" / "veach-mis" / "scene.toml")
    scene.film.width, scene.film.height = 96, 64
    renders, variances = {}, {}
    for k, strategy in enumerate(["mis-power", "light", "bsdf", "mis-balance"]):
        imgs = np.stack([glrender.render(scene, spp=64, seed=10 * k + s, sampler="independent",
                                         strategy=strategy).mean for s in range(4)])
        renders[strategy] = imgs
        variances[strategy] = float(imgs.var(axis=0, ddof=1).mean())
    ref = renders["mis-power"]
    for strategy in ("light", "bsdf", "mis-balance"):
        c = compare_images(renders[strategy], ref.mean(0), ref.std(0, ddof=1) / 2, block=8,
                           extra_tests=6, check_mse=False)
        assert c.passed, f"{strategy}: {c.summary()} {c.messages} variances {variances}"
    assert variances["mis-power"] < min(variances["light"], variances["bsdf"]), variances


def test02b_samples_beyond_the_accumulation_limit_are_dropped(gl_ctx, tmp_path):
    """A sample with a component of 2^30 or more (glrender.render.accum.LIMIT) is dropped
    and counted as the non-finite ones are: the light's own pixels at 1e8 times the Cornell
    box's radiance (1.8e9), not at 1e7 (1.8e8)."""
    from glrender.render import accum

    text = (ROOT / "scenes" / "cornell-box" / "scene.toml").read_text()
    films = {}
    for scale in (1e7, 1e8):
        path = tmp_path / f"bright{scale:g}.toml"
        path.write_text(text.replace("radiance = [18.387, 13.9873, 6.75357]",
                                     f"radiance = [{18.387 * scale}, {13.9873 * scale}, "
                                     f"{6.75357 * scale}]"))
        scene = glrender.load(path)
        scene.film = replace(scene.film, width=32, height=32)
        with Renderer(scene, settings_from_scene(scene, spp=4, seed=2)) as r:
            r.step(4)
            films[scale] = r.film()
    below, above = films[1e7], films[1e8]
    light = below.mean.max(axis=2) > 0.5 * 18.387e7        # pixels that see the light
    assert light.sum() >= 4 and below.nonfinite_total == 0
    assert 18.387e8 >= accum.LIMIT > 18.387e7
    assert (above.nonfinite[light] > 0).all() and (above.count + above.nonfinite == 4).all()
    assert np.isfinite(above.mean).all()
