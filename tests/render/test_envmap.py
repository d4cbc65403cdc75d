"""Environment maps: the Radiance HDR reader, Mitsuba's lat-long orientation, importance
sampling (light, BSDF and MIS strategies agree) and the white furnace."""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.film.radiance_hdr import read_hdr, write_hdr
from glrender.scene import model as m
from glrender.testing.images import compare_images

ROOT = Path(__file__).resolve().parents[2]
HDR = ROOT / "scenes" / "envmap" / "royal_esplanade_1k.hdr"

# Pixels of royal_esplanade_1k.hdr as decoded by an independent reader (OpenCV 4's
# imread, RGB order): (row, column) -> linear RGB.
KNOWN_PIXELS = {
    (0, 0): (0.56640625, 0.85546875, 0.859375),
    (100, 200): (0.796875, 0.9921875, 0.9921875),
    (255, 511): (0.9921875, 0.9921875, 0.9921875),
    (511, 1023): (0.052734375, 0.3515625, 0.419921875),
    (137, 42): (0.41796875, 0.75390625, 0.63671875),
}


def test01_radiance_hdr_known_pixels():
    img = read_hdr(HDR)
    assert img.shape == (512, 1024, 3) and img.dtype == np.float32
    for (y, x), rgb in KNOWN_PIXELS.items():
        np.testing.assert_array_equal(img[y, x], np.float32(rgb))


def test02_hdr_round_trip_and_errors(tmp_path):
    rng = np.random.default_rng(3)
    img = (rng.random((7, 9, 3)) * np.array([1.0, 50.0, 1e-3])).astype(np.float32)
    write_hdr(tmp_path / "x.hdr", img)
    back = read_hdr(tmp_path / "x.hdr")
    # one shared exponent, 8-bit mantissas: each channel within 2^-7 of its pixel's largest
    assert np.all(np.abs(back - img) <= 2 ** -7 * img.max(axis=-1, keepdims=True))
    (tmp_path / "bad.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 10 +X 10\n\x02\x02")
    with pytest.raises(glrender.UsageError, match=r"bad.hdr: scanline 0"):
        read_hdr(tmp_path / "bad.hdr")
    (tmp_path / "huge.hdr").write_bytes(b"#?RADIANCE\n\n-Y 1000000 +X 1000000\n")
    with pytest.raises(glrender.UsageError, match=r"huge.hdr: 1000000 x 1000000 pixels is more than "
                                                  r"the 268,435,456 \(16384 x 16384\)"):
        read_hdr(tmp_path / "huge.hdr")
    (tmp_path / "text.hdr").write_bytes(b"hello")
    with pytest.raises(glrender.UsageError, match=r"text.hdr: not a Radiance HDR file"):
        read_hdr(tmp_path / "text.hdr")


def env_scene(image, shapes=(), width=48, height=24, fov=70, **integrator):
    scene = m.Scene(film=m.Film(width=width, height=height, filter="box"),
                    integrator=m.Integrator(**integrator), source="<envmap test>")
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 0), (0.3, 0.2, -1), (0, 1, 0)), fov=fov)
    scene.lights.append(m.Light("envmap", image=image, world_from_light=m.rotate((0, 1, 0), 30)))
    for shape, material in shapes:
        shape.material = scene.add_material(material)
        scene.shapes.append(shape)
    return scene


def bilinear(image, uv):
    """Mitsuba 3's bilinear lookup of a lat-long image: columns centred at (i + 0.5) / width
    (u repeats), rows at v = j / (height - 1) (the first and last on the poles)."""
    h, w = image.shape[:2]
    x = uv[..., 0] * w - 0.5
    y = uv[..., 1] * (h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    def at(yy, xx):
        return image[np.clip(yy, 0, h - 1), np.mod(xx, w)]
    return ((1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
            fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1)))


@pytest.mark.parametrize("image_kind", ["hdr", "coarse"])
def test03_directly_seen_environment_follows_mitsubas_convention(gl_ctx, image_kind):
    # a coarse image (8 x 16 texels) makes the placement of its rows visible
    image = read_hdr(HDR) if image_kind == "hdr" else \
        np.random.default_rng(5).uniform(0.1, 1.0, (8, 16, 3)).astype(np.float32)
    scene = env_scene(image, max_depth=1)
    film = glrender.render(scene, spp=64, seed=1, sampler="sobol")
    from glrender.render.renderer import camera_tangents

    w, h, s = scene.film.width, scene.film.height, 16
    tx, ty = camera_tangents(scene.camera, w, h)
    off = (np.arange(s) + 0.5) / s
    X, Y = np.meshgrid((np.arange(w)[:, None] + off).reshape(-1) / w, (np.arange(h)[:, None] + off).reshape(-1) / h)
    d = np.stack([(1 - 2 * X) * tx, (1 - 2 * Y) * ty, np.ones_like(X)], -1) @ scene.camera.world_from_camera[:3, :3].T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    local = d @ scene.lights[0].world_from_light[:3, :3]          # world -> light frame (rotation)
    u = np.mod(np.arctan2(local[..., 0], -local[..., 2]) / (2 * np.pi), 1.0)
    v = np.arccos(np.clip(local[..., 1], -1, 1)) / np.pi
    expected = bilinear(image, np.stack([u, v], -1)).reshape(h, s, w, s, 3).mean(axis=(1, 3))
    # the pixel footprint is integrated by both; remaining differences are the 64-sample
    # estimate of a bilinear texture over a pixel: bounded by its variation (tested by block)
    diff = np.abs(film.mean - expected)
    assert np.median(diff / np.maximum(expected, 1e-3)) < 0.01
    assert np.mean(diff) < 0.01 * expected.mean()


@pytest.mark.parametrize("strategy", ["light", "mis-power"])
def test04_white_environment_furnace(gl_ctx, strategy):
    """An all-ones environment image behaves as a constant environment of radiance 1: a
    convex sphere of albedo 0.8 reflects 0.8 and the background is 1 (σ from 4 seeds)."""
    image = np.ones((16, 32, 3), np.float32)
    sphere = m.Shape("sphere", center=(0.0, 0.0, -6))   # 9.6 degrees: about 7.6 pixels radius
    scene = env_scene(image, shapes=[(sphere, m.Material("diffuse", reflectance=(0.8,) * 3))],
                      width=24, height=24, fov=30, max_depth=-1, strategy=strategy)
    scene.camera = m.Camera(world_from_camera=m.look_at((0, 0, 0), (0, 0, -1), (0, 1, 0)), fov=30)
    imgs = np.stack([glrender.render(scene, spp=32, seed=s, sampler="independent").mean for s in range(4)])
    r = np.hypot(*np.meshgrid(np.arange(24) - 11.5, np.arange(24) - 11.5))
    inside, outside = r < 6.0, r > 10.0   # the sphere covers r < ~7.7 pixels
    expected = np.where(inside[..., None], 0.8, 1.0) * np.ones((24, 24, 3))
    c = compare_images(imgs, expected, block=4, mask=inside | outside, eps=1e-5, extra_tests=1)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


@pytest.mark.parametrize("strategy", ["light", "bsdf"])
def test05_strategies_agree_under_an_environment(gl_ctx, strategy):
    """A diffuse sphere lit by the real environment: light sampling alone and BSDF sampling
    alone converge to what MIS gives (σ from independent seeds for both sides)."""
    image = read_hdr(HDR)
    sphere = m.Shape("sphere", center=(0.3, 0.2, -3))
    mat = m.Material("diffuse", reflectance=(0.7, 0.6, 0.5))
    def renders(strat, seeds):
        scene = env_scene(image, shapes=[(sphere, mat)], width=24, height=24, fov=30, max_depth=2,
                          strategy=strat, hide_emitters=True)
        return np.stack([glrender.render(scene, spp=32, seed=s, sampler="independent").mean for s in seeds])
    mis = renders("mis-power", range(4))
    single = renders(strategy, range(10, 14))   # independent of the MIS renders
    ref = mis.mean(axis=0)
    ref_se = mis.std(axis=0, ddof=1) / 2.0
    c = compare_images(single, ref, ref_se, block=4, extra_tests=1)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def test06_coarse_importance_table_stays_unbiased(gl_ctx, monkeypatch):
    """A map with more texels than the importance table's limit gets a table of blocks
    (each the maximum of its texels): light sampling through it still converges to what
    BSDF sampling gives (σ from independent seeds for both sides)."""
    from glrender.gpu import envmap

    image = read_hdr(HDR)[::4, ::4]            # 256 x 128 texels
    monkeypatch.setattr(envmap, "MAX_CELLS", 700)   # blocks of 7 x 7 texels: 37 x 19 cells
    assert envmap.importance_weights(image).shape == (19, 37)
    sphere = m.Shape("sphere", center=(0.3, 0.2, -3))
    mat = m.Material("diffuse", reflectance=(0.7, 0.6, 0.5))

    def renders(strategy, seeds):
        scene = env_scene(image, shapes=[(sphere, mat)], width=24, height=24, fov=30,
                          max_depth=2, strategy=strategy, hide_emitters=True)
        return np.stack([glrender.render(scene, spp=32, seed=s, sampler="independent").mean
                         for s in seeds])

    light = renders("light", range(4))
    bsdf = renders("bsdf", range(10, 14))
    c = compare_images(light, bsdf.mean(axis=0), bsdf.std(axis=0, ddof=1) / 2.0, block=4,
                       extra_tests=1)
    assert c.passed, c.summary() + " " + "; ".join(c.messages)


def test07_envmap_table_weights_cover_every_bright_texel():
    """Every texel with light lies in a table cell of positive weight, at full and at block
    resolution (a zero cell under a bright texel would bias light sampling)."""
    from glrender.gpu import envmap

    rng = np.random.default_rng(3)
    image = np.zeros((50, 70, 3), np.float32)
    bright = rng.random((50, 70)) < 0.01
    bright[:, :20] = True                      # and a bright band that fills whole blocks
    image[bright] = 5.0
    for cells, f in ((1 << 22, 1), (300, 4)):
        w = envmap.importance_weights(image, max_cells=cells)
        ys, xs = np.nonzero(bright)
        assert (w[ys // f, xs // f] > 0).all()
    with pytest.raises(glrender.SceneError, match=r"x.toml: the environment image is 70 x 50"):
        envmap.check_texture_size(image, 64, "x.toml")
