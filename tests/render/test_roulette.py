"""Russian roulette by one rule (shaders/integrators/roulette.glsl): the light tracer and bdpt
honour --rr as the path tracer does (tests/render/test_splitting.py), and stay unbiased.

The Cornell box at 32x32, max_depth 5, roulette from 2 segments: it plays at most vertices of
the light tracer's paths and of both bdpt subpaths. Every vertex draws its roulette number
whatever the rule, so the renders of one seed under two rules share their random numbers up
to the first vertex where the rules decide differently, and their difference is small. The
per-seed differences rule - throughput (the default) are independent over the seeds: their
mean, with sigma from their spread over twelve seeds, must be 0 in every 8x8 block and channel
and over the image, at a Šidák-corrected alpha of 0.01 over every comparison of this file
(glrender.testing.images.compare_images; the image mean's sigma from the seeds' own image
means, as a light path splats into several pixels). Each comparison can see an image-mean bias
of 1% of the throughput rule's image (asserted; 0.1-0.2% measured): a rule that forgot to
divide by its survival probability darkens the image by about 10%.
"""
import numpy as np
import pytest

from glrender.testing.images import compare_images

from bidir_scenes import cornell, renders

SEEDS = tuple(range(5001, 5013))
SPP = {"bdpt": 128, "lighttrace": 256}
MAX_DEPTH, RR_DEPTH, BLOCK = 5, 2, 8
INTEGRATORS = ("bdpt", "lighttrace")
RULES = ("off", "fixed:0.6")

_cache: dict = {}


def render(integrator: str, rr: str, rr_depth: int = RR_DEPTH) -> np.ndarray:
    """(seeds, H, W, 3): one render per seed, kept for the module's other tests."""
    key = (integrator, rr, rr_depth)
    if key not in _cache:
        _cache[key] = renders(cornell(32), integrator, SPP[integrator], SEEDS, max_depth=MAX_DEPTH,
                              rr=rr, rr_depth=rr_depth)
    return _cache[key]


def block_tests() -> int:
    return 3 * (32 // BLOCK) ** 2 + 2


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test01_rule_agrees_with_the_throughput_rule(gl_ctx, integrator, rule):
    base = render(integrator, "throughput")
    diff = render(integrator, rule) - base
    extra = (len(INTEGRATORS) * len(RULES) - 1) * block_tests()
    c = compare_images(diff, np.zeros(diff.shape[1:]), block=BLOCK, extra_tests=extra,
                       correlated_pixels=True)
    detectable = c.mean_threshold * c.mean_sigma / float(base.mean())
    assert c.passed, (f"mean difference {c.mean:+.4g} +- {c.mean_sigma:.3g} (image mean "
                      f"{float(base.mean()):.4g}); worst block z {c.worst_z:.2f} at {c.worst_block} "
                      f"(threshold {c.z_threshold:.2f}); " + "; ".join(c.messages))
    assert 0 < detectable < 0.01, detectable


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test02_the_rule_changes_the_samples(gl_ctx, integrator):
    """Not ignored: every rule gives other bits than the throughput rule, and `off` gives
    exactly the bits of roulette that starts too deep to play (rr_depth past max_depth)."""
    base = render(integrator, "throughput")
    for rule in RULES:
        assert not np.array_equal(render(integrator, rule), base), rule
    never = render(integrator, "throughput", rr_depth=MAX_DEPTH + 1)
    assert np.array_equal(render(integrator, "off"), never)
    assert base.max() > 0
