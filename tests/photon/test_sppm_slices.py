"""SPPM on images whose visible points do not fit one storage-block binding.

An iteration then runs a camera pass per slice of pixel rows and traces the same
photons (the same sample numbers) into each slice's visible points; a slice whose grid
does not fit one binding is traced grid by grid. Every deposit lands where it would in
the one-slice render, so with a device limit lowered to a few rows the photon counts,
and therefore the radii, equal the one-slice render's exactly, the photon-map view (64-bit
integer sums) equals it bitwise, and the radiance equals it up to the order of the float
atomic additions (float32 sums of a pixel's deposits in another order).
"""
from pathlib import Path

import numpy as np
import pytest

import glrender
from glrender.errors import UsageError
from glrender.photon import SppmRenderer, SppmSettings

ROOT = Path(__file__).resolve().parents[2]
W = H = 40
ITERATIONS = 3
SETTINGS = SppmSettings(photons_per_iteration=1 << 14, initial_radius=0.05)


def cornell():
    scene = glrender.load(ROOT / "scenes" / "cornell-box" / "scene.toml")
    scene.film.width, scene.film.height = W, H
    return scene


def render(gl_ctx, photon_view):
    r = SppmRenderer(cornell(), sppm=SETTINGS, ctx=gl_ctx, seed=7, photon_view=photon_view)
    try:
        r.step(ITERATIONS)
        film = r.film()
        return (r.radiance(), r.radius.copy(), r.n_photons.copy(), film.aovs.get("photons"),
                dict(r.counters), r.slices())
    finally:
        r.release()


@pytest.fixture(scope="module")
def whole(gl_ctx):
    return render(gl_ctx, photon_view=True)


@pytest.mark.parametrize("limit, slices", [
    (24 * W * H, [(0, 30), (30, 10)]),             # the photon view still fits: two slices
    (32 * W * 13, [(0, 13), (13, 13), (26, 13), (39, 1)]),   # grids split too
])
def test01_slices_render_the_one_slice_image(gl_ctx, whole, monkeypatch, limit, slices):
    """Lowered binding limits: the slices are as planned, every grid fits the limit (the
    smaller one splits each slice's grid), the photon counts and radii equal the
    one-slice render's exactly and the radiance to float32 summation order (relative
    1e-5: deposits are sums of at most a few thousand float32 terms per pixel)."""
    radiance0, radius0, n0, view0, counters0, slices0 = whole
    assert slices0 == [(0, H)] and counters0["skipped"] == 0
    grids = []
    real_grids = SppmRenderer._grids

    def spy(self, position, first):
        out = real_grids(self, position, first)
        grids.append([g.cells.nbytes for g in out])
        return out

    monkeypatch.setattr(SppmRenderer, "binding_limit", lambda self: limit)
    monkeypatch.setattr(SppmRenderer, "_grids", spy)
    view = limit >= 24 * W * H
    radiance, radius, n, photons, counters, got = render(gl_ctx, photon_view=view)
    assert got == slices
    assert len(grids) == ITERATIONS * len(slices)
    assert all(b <= limit for per_slice in grids for b in per_slice)
    if not view:
        assert max(len(g) for g in grids) > 1      # some slice was traced grid by grid
    assert counters["skipped"] == 0
    np.testing.assert_array_equal(n, n0)
    np.testing.assert_array_equal(radius, radius0)
    np.testing.assert_allclose(radiance, radiance0, rtol=1e-5, atol=1e-7)
    if view:
        np.testing.assert_array_equal(photons, view0)


def test02_photon_view_beyond_one_binding_is_refused(gl_ctx, monkeypatch):
    """The photon-map view is one whole-image buffer: past one binding, a one-line error."""
    monkeypatch.setattr(SppmRenderer, "binding_limit", lambda self: 24 * W * H - 1)
    with pytest.raises(UsageError, match=r"photons AOV of a 40x40 image needs .* leave it out"):
        SppmRenderer(cornell(), sppm=SETTINGS, ctx=gl_ctx, seed=7, photon_view=True)


def test03_stopped_iteration_changes_nothing(gl_ctx, monkeypatch):
    """An iteration stopped between its pieces (here in its second slice) is dropped:
    the state is as before it, and the next iteration is the one an unstopped render
    runs first."""
    monkeypatch.setattr(SppmRenderer, "binding_limit", lambda self: 32 * W * 13)
    r = SppmRenderer(cornell(), sppm=SETTINGS, ctx=gl_ctx, seed=7)
    try:
        asked = []

        def stop():
            asked.append(1)
            return len(asked) >= 3

        assert r.step(1, should_stop=stop) == 0
        assert r.iterations == 0 and not r.iteration_in_progress
        assert np.all(r.radius == r.initial_radius) and not r.tau.any() and not r.ld_sum.any()
        assert r.step(1) == 1
        once = r.radius.copy()
    finally:
        r.release()
    s = SppmRenderer(cornell(), sppm=SETTINGS, ctx=gl_ctx, seed=7)
    try:
        s.step(1)
        np.testing.assert_array_equal(s.radius, once)
    finally:
        s.release()


@pytest.mark.parametrize("limit", [None, 32 * W * 5])
def test04_a_band_of_rows_renders_the_whole_image_s_pixels(gl_ctx, whole, monkeypatch, limit):
    """reset(rows=...) (--crop): tile rows 1-3 (pixel rows 8-31) alone, in one slice and in
    slices of 5 rows: the band's photon counts and radii are the whole image's exactly,
    its radiance to float summation order, its photon-map view bitwise."""
    radiance0, radius0, n0, view0, _, _ = whole
    if limit is not None:
        monkeypatch.setattr(SppmRenderer, "binding_limit", lambda self: limit)
    r = SppmRenderer(cornell(), sppm=SETTINGS, ctx=gl_ctx, seed=7, photon_view=limit is None)
    try:
        r.reset(rows=(1, 3))
        assert r.band_height == 24
        assert r.slices() == ([(8, 24)] if limit is None else [(8, 5), (13, 5), (18, 5), (23, 5), (28, 4)])
        r.step(ITERATIONS)
        film = r.film()
        band = slice(8 * W, 32 * W)
        np.testing.assert_array_equal(r.n_photons, n0[band])
        np.testing.assert_array_equal(r.radius, radius0[band])
        np.testing.assert_allclose(film.mean, radiance0[8:32], rtol=1e-5, atol=1e-7)
        if limit is None:
            np.testing.assert_array_equal(film.aovs["photons"], view0[8:32])
        with pytest.raises(UsageError, match="start 3"):
            r.reset(start=3)
    finally:
        r.release()
