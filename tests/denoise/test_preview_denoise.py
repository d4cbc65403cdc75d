"""The preview's denoise key (N) in a real window under Xvfb, driven by xdotool.

A still view of the Cornell box (256x256, so samples arrive over seconds, not frames).
With denoising on, two consecutive denoised images of one accumulation (a new one each
time its samples double; the title names the spp of the one the window shows) are
captured from the window. The noisy pair it is measured against is rendered headless
from the same scene at exactly those two sample counts, through the same display
transform, so the comparison does not hang on when a capture of a running view lands.
Measured offline from 1 to 32 spp (8-bit display values, the emission kept out of the
filter as the preview does), the noisy view changes 7-10x more than the denoised one
between doublings; the test asks for 3x. Pressing N again turns denoising off.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "preview"))
from preview_x11 import Xvfb, capture, missing_tools, wait_for  # noqa: E402
from test_window import CORNELL, Preview  # noqa: E402

import glrender  # noqa: E402
from glrender.film.tonemap import tonemap  # noqa: E402
from glrender.render.renderer import Renderer, settings_from_scene  # noqa: E402

pytestmark = pytest.mark.slow
FACTOR = 3.0


@pytest.fixture(scope="module")
def preview(tmp_path_factory):
    missing = missing_tools()
    if missing:
        pytest.skip(f"{' and '.join(missing)} not installed (./dev.sh test installs them)")
    server = Xvfb()
    p = Preview(server.display, CORNELL, "--screenshot-dir", tmp_path_factory.mktemp("shots"))
    yield p
    if p.proc.poll() is None:
        p.proc.kill()
        p.proc.wait()
    server.close()


def _title_number(preview, pattern: str, at_least: int) -> int:
    """Wait until the title shows ``pattern`` (one number group) with a value >= at_least."""
    def ready():
        m = re.search(pattern, preview.title())
        return int(m.group(1)) if m and int(m.group(1)) >= at_least else None
    return wait_for(ready, 120.0, what=f"{pattern} >= {at_least} in the title")


def _frame(preview) -> np.ndarray:
    return capture(preview.display, preview.window).astype(np.float64)


def _denoised_frame(preview, spp: int) -> np.ndarray:
    """A capture of the denoised view made at ``spp``: the window redraws after its title
    changes, so wait until two captures in a row are the same picture (the denoised view
    holds still until the next one) while the title still names that spp."""
    def settled():
        a = _frame(preview)
        b = _frame(preview)
        same = np.array_equal(a, b) and re.search(rf"denoised at {spp} spp", preview.title())
        return (a,) if same else None
    return wait_for(settled, 60.0, what=f"a still denoised view at {spp} spp")[0]


def _noisy_views(counts: tuple[int, ...], shape: tuple[int, ...]) -> list[np.ndarray]:
    """The scene rendered headless (its own seed, as the preview renders it), displayed
    as the preview displays it, at each of ``counts`` spp of one accumulation; each
    scaled (nearest) to the window capture's ``shape`` where the window is larger."""
    scene = glrender.load(CORNELL)
    views = []
    with Renderer(scene, settings_from_scene(scene)) as renderer:
        for spp in counts:
            renderer.step(spp - renderer.spp_done)
            view = tonemap(renderer.film().mean).astype(np.float64)
            ys = np.arange(shape[0]) * view.shape[0] // shape[0]
            xs = np.arange(shape[1]) * view.shape[1] // shape[1]
            views.append(view[ys][:, xs])
    return views


def test01_denoise_key_steadies_the_view(preview):
    # no restart here: every denoised image is then of the one accumulation running
    preview.key("n")
    preview.wait_line(r"denoising with Open Image Denoise", 60.0)
    first = _title_number(preview, r"denoised at (\d+) spp", 2)
    on_a = _denoised_frame(preview, first)
    second = _title_number(preview, r"denoised at (\d+) spp", 2 * first)
    on_b = _denoised_frame(preview, second)

    # N again: denoising off
    preview.key("n")
    wait_for(lambda: "denois" not in preview.title(), 60.0, what="the title without denoising")
    off_a, off_b = _noisy_views((first, second), on_a.shape)

    diff_on = np.abs(on_a - on_b).mean()
    diff_off = np.abs(off_a - off_b).mean()
    assert diff_off > 0 and diff_on * FACTOR < diff_off, (first, second, diff_on, diff_off)


def test02_summary_counts_the_denoised_images(preview):
    from preview_x11 import request_close

    request_close(preview.display, preview.window)
    assert preview.proc.wait(60) == 0
    line = preview.wait_line(r"preview closed at", 10.0)
    assert re.search(r"[1-9]\d* denoised images", line), line
