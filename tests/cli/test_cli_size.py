"""--width or --height alone keeps the scene's aspect ratio (the same view, another size);
both together are used as given."""
from __future__ import annotations

import pytest

from cli_run import ROOT, glrender
from glrender.film.io import read_image
from glrender.scene import model as m

ENCLOSURE = ROOT / "scenes" / "enclosure" / "scene.toml"     # 128 x 96


@pytest.mark.parametrize("width, height, expected", [
    (320, None, (320, 240)), (None, 100, (133, 100)), (1, None, (1, 1)),
    (65536, None, (65536, 49152)), (50, 10, (50, 10)), (None, None, (640, 480)),
])
def test01_film_resized(width, height, expected):
    film = m.Film(640, 480, filter="box")
    out = film.resized(width, height)
    assert (out.width, out.height) == expected and out.filter == "box"
    assert film.width == 640 and film.height == 480          # a copy: the scene's film is kept


@pytest.mark.parametrize("args, shape", [
    (["--width", 32], (24, 32)), (["--height", 12], (12, 16)), (["--width", 20, "--height", 20], (20, 20)),
])
def test02_render_size(tmp_path, args, shape):
    out = tmp_path / "x.pfm"
    r = glrender("render", ENCLOSURE, "-o", out, "--spp", 1, "--quiet", *args)
    assert r.returncode == 0, r.stderr
    assert read_image(out).shape[:2] == shape
