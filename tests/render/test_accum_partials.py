"""The path tracer's 64-bit partial sums (shaders/film/accum.glsl): samples below
kAccumFast are summed in 64 bits and added to the 128-bit sums every kAccumFlush samples
and at the end of a pass, brighter ones go to the 128-bit sums at once; the sums are the
same bits as the host's sum of every sample's fixed-point value, however the samples are
split into passes."""
from dataclasses import replace
from pathlib import Path

import numpy as np

import glrender
from glrender.render import accum
from glrender.render.renderer import Renderer, settings_from_scene

ROOT = Path(__file__).resolve().parents[2]
FAST = 2048.0          # kAccumFast
SPP = 40               # more than two flushes of 16 in one pass


def test01_partial_sums_are_the_sum_of_every_sample_bitwise(gl_ctx, tmp_path):
    text = (ROOT / "scenes" / "cornell-box" / "scene.toml").read_text()
    path = tmp_path / "bright.toml"      # the light at 4x: its pixels' squares pass kAccumFast
    path.write_text(text.replace("radiance = [18.387, 13.9873, 6.75357]",
                                 "radiance = [73.548, 55.9492, 27.01428]"))
    scene = glrender.load(path)
    scene.film = replace(scene.film, width=24, height=24)
    states = {}
    for per_pass in (SPP, 1):
        with Renderer(scene, settings_from_scene(scene, spp=SPP, seed=5, aovs=True,
                                                 samples_per_pass=per_pass,
                                                 time_target=100.0)) as r:
            r.step(SPP)
            states[per_pass] = r.state()
            if per_pass == 1:
                samples = []               # every sample's values: one-sample ranges
                for i in range(SPP):
                    r.reset(start=i)
                    r.step(1)
                    s = r.state()
                    mean, _, _, _, aovs = accum.statistics(s["sums"], s["squares"], s["aov"])
                    samples.append((mean, aovs))
    n = 24 * 24
    sums = np.zeros((n, 3, 4), np.uint32)
    squares = np.zeros((n, 3, 4), np.uint32)
    aov = np.zeros((n, accum.AOV_CHANNELS, 4), np.uint32)
    for mean, aovs in samples:
        sums, squares = accum.add(sums, accum.fixed(mean)), accum.add(squares, accum.fixed(mean * mean))
        aov = accum.add(aov, accum.fixed(aovs))
    x = np.stack([m for m, _ in samples])                    # (SPP, n, 3)
    slow = (x * x).max(axis=2) >= FAST
    mixed = slow.any(axis=0) & ~slow.all(axis=0)
    assert mixed.sum() >= 4                   # pixels with samples on both paths
    assert (np.stack([a for _, a in samples]) < 0).any()     # negative values (normals)
    for state in states.values():
        s = state["sums"].reshape(n, 4, 4)
        np.testing.assert_array_equal(s[:, :3], sums)
        np.testing.assert_array_equal(state["squares"].reshape(n, 3, 4), squares)
        np.testing.assert_array_equal(state["aov"].reshape(n, accum.AOV_CHANNELS, 4), aov)
        assert (s[:, 3, 0] == SPP).all()
