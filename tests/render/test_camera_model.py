"""The camera's integrals one by one: the shutter's time density (camera/camera.glsl
sample_shutter_time) run on the device against its closed form, a motion-blurred edge
against the shutter function's cumulative distribution, and the orthographic projection's
pixel footprints against the exact coverage of a quad (and refused where light paths must
reach a lens)."""
import sys
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.gpu import bindings, layout
from glrender.render.params import shader_defines
from glrender.scene import model as m
from glrender.testing.chi2 import ChiSquareTest, LineDomain
from glrender.testing.harness import run_glsl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "cli"))
from cli_run import glrender as glrender_cli, one_error_line  # noqa: E402


def shutter_pdf(function, t):
    """The shutter function S(t) as a density on [0, 1]: box 1, tent 4t then 4(1 - t)."""
    t = np.asarray(t, np.float64)
    if function == "box":
        return np.ones_like(t)
    return np.where(t < 0.5, 4 * t, 4 * (1 - t))


def shutter_cdf(function, t):
    t = np.clip(np.asarray(t, np.float64), 0.0, 1.0)
    if function == "box":
        return t
    return np.where(t < 0.5, 2 * t * t, 1 - 2 * (1 - t) ** 2)


def sample_shutter_time(gl_ctx, function, u):
    """camera.glsl's sample_shutter_time(u) with the parameter block's shutter set."""
    prm = np.zeros(1, layout.RENDER_PARAMS)[0]
    prm["shutter"][:3] = (0.0, 1.0, 1.0 if function == "tent" else 0.0)
    block = gl_ctx.gl.buffer(prm.tobytes())
    try:
        block.bind_to_uniform_block(bindings.UBO_RENDER_PARAMS)
        return run_glsl("sample_shutter_time(u)", {"u": np.asarray(u, np.float32).reshape(-1)},
                        {"t": "float"}, includes=["common/params.glsl", "camera/camera.glsl"],
                        defines=shader_defines(), ctx=gl_ctx)["t"]
    finally:
        block.release()


@pytest.mark.parametrize("function", ["box", "tent"])
def test01_shutter_times_follow_the_shutter_function(gl_ctx, function):
    """A chi-square test of 10^6 times against S(t) over 101 cells, false alarm rate
    1e-3 per case; the known values of the warp's ends and middle besides. With 10^6
    samples a 1% change of the density's mass in a tenth of [0, 1] is seen."""
    u = np.array([0.0, 0.125, 0.5, 0.875, 1 - 2 ** -24], np.float32)
    t = sample_shutter_time(gl_ctx, function, u)
    u64 = u.astype(np.float64)      # the inverse of the CDF: t = 0, 1/4, 1/2, 3/4, ~1 for the tent
    want = u64 if function == "box" else np.where(u64 < 0.5, np.sqrt(u64 / 2), 1 - np.sqrt((1 - u64) / 2))
    np.testing.assert_allclose(t, want, atol=1e-6)
    test = ChiSquareTest(LineDomain((0.0, 1.0)), lambda u: sample_shutter_time(gl_ctx, function, u),
                         lambda x: shutter_pdf(function, x), sample_dim=1, sample_count=1_000_000,
                         res=101, alpha=1e-3, name=f"shutter {function}")
    assert test.run(), test.messages


def sliding_edge(function, width=32):
    """A pinhole camera 4 units above an emitting half plane (x < 0, radiance 1) moves by
    4 units along x over the shutter: a point of the image is lit while the camera's
    offset keeps its ray on the half plane, a step in time whose mean is S's CDF."""
    scene = m.Scene(film=m.Film(width=width, height=1, filter="box"), source="<sliding edge>",
                    integrator=m.Integrator(max_depth=1))
    eye_open, eye_close = np.array([-2.0, 0, 4]), np.array([2.0, 0, 4])
    scene.camera = m.Camera(world_from_camera=m.look_at(eye_open, eye_open - [0, 0, 1], (0, 1, 0)),
                            fov=60, fov_axis="x")
    scene.camera.world_from_camera_close = m.look_at(eye_close, eye_close - [0, 0, 1], (0, 1, 0))
    black = scene.add_material(m.Material("diffuse", reflectance=(0, 0, 0)))
    # a 20 x 20 rectangle whose right edge is x = 0, facing +z
    scene.shapes.append(m.Shape("rectangle", material=black, emission=m.Emission((1.0,) * 3),
                                world_from_object=m.translate((-10, 0, 0)) @ m.scale(10.0)))
    scene.shutter = m.Shutter(0.0, 1.0, function)
    return scene


@pytest.mark.parametrize("function", ["box", "tent"])
def test02_motion_blurred_edge_is_the_shutter_cdf(gl_ctx, function):
    """Pixel j's value is the pixel average of F((2 - x)/4), F the shutter's CDF and x
    the world offset of its ray on the plane. Each sample is 0 or 1, so the count of lit
    samples is binomial with that mean: an exact two-sided binomial test per pixel, Sidak
    over the 32 pixels (alpha 1e-3). At 1024 spp a tent sampled as a box (0.125 apart at
    the quartiles, 8 standard deviations) fails many pixels."""
    from scipy.stats import binomtest

    from glrender.render.renderer import camera_tangents
    from glrender.testing.stats import sidak_alpha

    scene = sliding_edge(function)
    w, n = scene.film.width, 1024
    film = glrender.render(scene, spp=n, seed=3, sampler="independent")
    lit = film.mean[0, :, 0] * n
    np.testing.assert_array_equal(lit, np.round(lit))
    tx, _ = camera_tangents(scene.camera, w, 1)
    f = np.arange(w)[:, None] + (np.arange(256) + 0.5)[None, :] / 256   # film x in pixels
    left = scene.camera.world_from_camera[0, 0]          # world x of camera +x (image left)
    x = 4.0 * left * (1 - 2 * f / w) * tx                # the ray's world x offset on the plane
    want = shutter_cdf(function, (2.0 - x) / 4.0).mean(axis=1)
    p = np.array([binomtest(int(k), n, min(max(q, 1e-12), 1 - 1e-12)).pvalue for k, q in zip(lit, want)])
    assert p.min() >= sidak_alpha(1e-3, w), (lit / n, want, p)


def orthographic_quad(width=40, height=20):
    """An orthographic camera 4 units above an emitting rectangle (radiance 1) of 1.46 x 0.74
    whose edges fall inside pixels: the view is 4 x 2 units (half_extent 2 along x), so a
    pixel is 0.1 units wide."""
    scene = m.Scene(film=m.Film(width=width, height=height, filter="box"), source="<orthographic quad>",
                    integrator=m.Integrator(max_depth=1))
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 4), (0, 0, 0), (0, 1, 0)),
                            kind="orthographic", half_extent=2.0, fov_axis="x")
    black = scene.add_material(m.Material("diffuse", reflectance=(0, 0, 0)))
    scene.shapes.append(m.Shape("rectangle", material=black, emission=m.Emission((1.0,) * 3),
                                world_from_object=m.translate((0.012, -0.031, 0)) @ np.diag([0.73, 0.37, 1, 1])))
    return scene


@pytest.mark.parametrize("integrator", ["path", "bdpt"])
def test03_orthographic_pixels_see_the_quad_s_exact_coverage(gl_ctx, integrator):
    """A pixel of an orthographic camera sees a fixed 0.1 x 0.1 square of the plane, so its
    value is the fraction of that square the quad covers (the camera's +x is the world's -x
    here). Each sample is 0 or 1: an exact binomial test per pixel, Sidak over the 800
    pixels (alpha 1e-3). At 1024 spp an edge moved by a tenth of a pixel (a 1% error of the
    view's size at the quad's edges) fails its row or column of pixels (sigma <= 0.016).
    bdpt sees the quad by its s = 0 strategy alone (no t = 1 through this camera)."""
    from scipy.stats import binomtest

    from glrender.testing.stats import sidak_alpha

    scene = orthographic_quad()
    n = 1024
    lit = glrender.render(scene, spp=n, seed=5, sampler="independent", integrator=integrator).mean[..., 0] * n
    np.testing.assert_array_equal(lit, np.round(lit))
    # pixel (row j, column i) covers world x in -2 + 0.1 [i, i + 1] (the image's left, camera
    # +x, is world -x looking down), y in 1 - 0.1 [j + 1, j]
    xs = -2.0 + 0.1 * np.arange(41)
    ys = 1.0 - 0.1 * np.arange(21)
    x0, x1, y0, y1 = 0.012 - 0.73, 0.012 + 0.73, -0.031 - 0.37, -0.031 + 0.37
    cover_x = np.clip(np.minimum(xs[1:], x1) - np.maximum(xs[:-1], x0), 0, None) / 0.1
    cover_y = np.clip(np.minimum(ys[:-1], y1) - np.maximum(ys[1:], y0), 0, None) / 0.1
    want = np.round(cover_y[:, None] * cover_x[None, :], 9)      # 1 - 1e-16 is 1
    # 16 x 9 pixels touched, every edge inside a pixel: the border's 46 pixels are partly covered
    assert (want > 0).sum() == 16 * 9 and ((want > 0) & (want < 1)).sum() == 2 * (16 + 9) - 4
    p = np.array([binomtest(int(k), n, min(max(q, 1e-12), 1 - 1e-12)).pvalue
                  for k, q in zip(lit.ravel(), want.ravel())])
    assert p.min() >= sidak_alpha(1e-3, p.size), (np.argwhere(p < sidak_alpha(1e-3, p.size)), lit / n)


def test04_light_tracing_cannot_reach_an_orthographic_camera(gl_ctx):
    """lighttrace's image is made of connections to the lens, which needs a camera that a
    scene point can see: refused in one line naming the camera and the integrator (bdpt
    keeps its other strategies: tests/parity, integrator-bdpt-orthographic)."""
    with pytest.raises(glrender.UsageError) as info:
        glrender.render(orthographic_quad(), spp=1, integrator="lighttrace")
    line = str(info.value)
    assert line.startswith("camera: an orthographic camera cannot be rendered by lighttrace")
    assert "\n" not in line and "bdpt" in line.split("; use ")[1]


def test05_command_line_refuses_in_one_line(tmp_path):
    """The scene file's orthographic camera and --integrator lighttrace: exit 2, one line,
    before any kernel is compiled."""
    scene = tmp_path / "o.toml"
    scene.write_text('[camera]\nkind = "orthographic"\nhalf_extent = 2\n[materials.black]\ntype = "diffuse"\n'
                     'reflectance = [0, 0, 0]\n[[shapes]]\ntype = "rectangle"\nmaterial = "black"\n'
                     'emission = { radiance = [1, 1, 1] }\n')
    line = one_error_line(glrender_cli("render", scene, "-o", tmp_path / "o.pfm", "--integrator", "lighttrace"))
    assert "camera: an orthographic camera cannot be rendered by lighttrace" in line
    assert not (tmp_path / "o.pfm").exists()
