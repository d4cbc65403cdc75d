"""The photon integrators and vcm in the preview, in a real window under Xvfb (as
tests/preview/test_window.py). SPPM: the preview drives SppmRenderer iteration by
iteration, a piece of work per frame, so the window keeps answering keys while it
renders; photon: a PhotonRenderer (its maps traced once) accumulated like the path
tracer; vcm: a VcmRenderer, one iteration (light pass, grid, camera pass) per pass. The screenshot is the headless renderer's image at the same spp (SPPM's float
atomics: equal to their summation order); a drag restarts it from the new view."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import glrender
from glrender.photon import PhotonRenderer, PhotonSettings, SppmRenderer
from glrender.preview.app import PREVIEW_PHOTONS
from glrender.render.renderer import settings_from_scene
from glrender.vcm import VcmRenderer, VcmSettings

from preview_x11 import Xvfb, missing_tools
from test_window import CORNELL, Preview

pytestmark = pytest.mark.slow
SIZE, ITERATIONS = 48, 12


@pytest.fixture(scope="module", params=["sppm", "photon", "vcm"])
def preview(request, tmp_path_factory):
    missing = missing_tools()
    if missing:
        pytest.skip(f"{' and '.join(missing)} not installed (./dev.sh test installs them)")
    server = Xvfb()
    out = tmp_path_factory.mktemp("preview-sppm")
    p = Preview(server.display, CORNELL, "--integrator", request.param, "--width", SIZE, "--height", SIZE,
                "--spp", ITERATIONS, "--screenshot-dir", out / "shots")
    yield p
    if p.proc.poll() is None:
        p.proc.kill()
        p.proc.wait()
    server.close()


def headless(meta: dict) -> np.ndarray:
    scene = glrender.load(CORNELL)
    scene.film = replace(scene.film, width=meta["width"], height=meta["height"])
    scene.camera = replace(scene.camera, world_from_camera=np.array(meta["world_from_camera"]))
    kind = meta["integrator"]
    settings = settings_from_scene(scene, integrator=kind, max_depth=meta["max_depth"],
                                   sampler=meta["sampler"], seed=meta["seed"], spp=meta["spp"])
    if kind == "sppm":
        r = SppmRenderer(scene, settings)
    elif kind == "vcm":
        r = VcmRenderer(scene, replace(settings, aovs=True), VcmSettings())
    else:
        r = PhotonRenderer(scene, replace(settings, aovs=True), PhotonSettings(photons=PREVIEW_PHOTONS))
    try:
        r.step(meta["spp"])
        return r.film().mean
    finally:
        r.release()


def test01_screenshot_is_the_headless_image(preview):
    title = preview.wait_title(f"{ITERATIONS}/{ITERATIONS} spp - done", timeout=180)
    shot = preview.screenshot()
    meta, mean = shot["meta"], shot["layers"]["RGB"]
    assert f"- {meta['integrator']}, " in title and ", depth" in title
    assert meta["spp"] == ITERATIONS and meta["integrator"] in ("sppm", "photon", "vcm")
    assert mean.shape == (SIZE, SIZE, 3) and mean.mean() > 0.1
    np.testing.assert_allclose(mean, headless(meta), rtol=1e-4, atol=1e-5)


def test02_keys_answer_while_it_renders_and_a_drag_restarts(preview):
    """Pause, drag (a restart: 0 iterations), resume: it renders the new view to the end."""
    preview.key("space")
    preview.wait_title("- paused")
    preview.drag((120, 120), 40, 0)
    preview.wait_title(f"0/{ITERATIONS} spp - paused")
    preview.key("space")
    preview.wait_title(f"{ITERATIONS}/{ITERATIONS} spp - done", timeout=180)
    shot = preview.screenshot()
    np.testing.assert_allclose(shot["layers"]["RGB"], headless(shot["meta"]), rtol=1e-4, atol=1e-5)
