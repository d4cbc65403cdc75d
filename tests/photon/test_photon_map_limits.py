"""Photon maps against the device's limits (glrender/photon/photon.py): traced through a
storage buffer of at most one binding, dispatch by dispatch (a dispatch that overflows it
is traced again into a fresh one: the same photons), and held in buffer textures (one per
map, GL_MAX_TEXTURE_BUFFER_SIZE / 3 photons: 44.7M on llvmpipe) read through map_record
(shaders/photon/map_layout.glsl).

Tracing in pieces changes neither which photons are stored nor the order the lookups
visit them (the grid order of the whole map), so the image is bitwise the one traced in
one piece, for a fixed radius, kNN and the final gather alike. The tests lower the binding
limit (PhotonRenderer._map_binding_limit) and the dispatch size so that small maps are
traced in pieces and dispatches overflow, and the texel limit so that a map is refused.
"""
import numpy as np
import pytest

from glrender.errors import UsageError
from glrender.photon import PhotonRenderer, PhotonSettings
from glrender.photon import photon as photon_module

from test_photon import caustic_scene

PHOTONS, CAUSTIC = 6000, 60000


def render(scene, gl_ctx, **photon):
    r = PhotonRenderer(scene, photon=PhotonSettings(photons=PHOTONS, caustic_photons=CAUSTIC, photon_view=True,
                                                   **photon),
                       ctx=gl_ctx, seed=5)
    try:
        r.step(2)
        film = r.film()
        return (film.mean.copy(), film.aovs["photons"].copy(), [r.map_records(w) for w in (0, 1)],
                dict(r.counters), r.memory())
    finally:
        r.release()


@pytest.mark.parametrize("mode", [dict(radius=0.05), dict(knn=16), dict(radius=0.05, final_gather=True)],
                         ids=["radius", "knn", "final-gather"])
def test01_maps_traced_in_pieces_render_bitwise_the_same(gl_ctx, monkeypatch, mode):
    """The caustic scene's maps traced in one piece, then with a tracing buffer of a third
    of the global map and half the caustic map and dispatches of 512 photons (so the
    buffer overflows and dispatches are traced again): the same photon records in the
    same order, the same image and photon-map view, bit for bit."""
    scene = caustic_scene(16)
    whole = render(scene, gl_ctx, **mode)
    stored = whole[3]["stored"]
    assert whole[3]["retraced"] == [0, 0] and stored[1] > 0
    piece = max(-(-stored[0] // 3), -(-stored[1] // 2))
    monkeypatch.setattr(PhotonRenderer, "_map_binding_limit", lambda self: 48 * piece)
    monkeypatch.setattr(photon_module, "PHOTONS_PER_DISPATCH", 512)
    split = render(scene, gl_ctx, **mode)
    assert split[3]["stored"] == stored
    assert split[4]["trace_photons_limit"] == piece and split[4]["bytes_per_photon"] == 48
    assert min(split[3]["retraced"]) > 0          # the overflow path ran for both maps
    for which in (0, 1):
        np.testing.assert_array_equal(split[2][which], whole[2][which])
        assert len(whole[2][which]) == stored[which]
    np.testing.assert_array_equal(split[0], whole[0])
    np.testing.assert_array_equal(split[1], whole[1])
    assert whole[0].max() > 0 and whole[1].max() > 0


def test02_a_map_beyond_a_buffer_texture_is_refused(gl_ctx, monkeypatch):
    """A map that would take more texels than a buffer texture holds: one line naming the
    option."""
    monkeypatch.setattr(PhotonRenderer, "_texel_limit", lambda self: 3 * 1500)
    with pytest.raises(UsageError, match=r"--photons 6000: the global map stores \d+ photons, above "
                                         r"the 1500 a buffer texture holds on this device"):
        PhotonRenderer(caustic_scene(8), photon=PhotonSettings(photons=PHOTONS), ctx=gl_ctx, seed=5)


def test03_canonical_order_is_independent_of_the_stored_order():
    """Records that share x and y (a floor at y = 0, equal x) and whole duplicates: the
    canonical order of any permutation of them gives the same sequence of records."""
    from glrender.photon.photon import canonical_order

    rng = np.random.default_rng(4)
    records = rng.random((4000, 12), dtype=np.float32)
    records[:600, 1] = 0.0
    records[:600, 0] = records[:600:3, 0].repeat(3)[:600]     # triples at equal x and y
    records[600:700] = records[700:800]                       # whole duplicates
    first = records[canonical_order(records)]
    for seed in range(3):
        shuffled = records[np.random.default_rng(seed).permutation(len(records))]
        np.testing.assert_array_equal(shuffled[canonical_order(shuffled)], first)
