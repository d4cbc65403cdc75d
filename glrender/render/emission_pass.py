"""The seen-emission pass of a denoised render (:mod:`glrender.denoise` says why): the emission
the camera sees, rendered on its own by the path tracer with ``emission_only`` at more samples
per pixel than the render, and added back after the reflected light is filtered."""
from __future__ import annotations

from dataclasses import replace

from .. import integrators
from .renderer import Renderer

# the seen-emission pass: samples per pixel for a render of `spp`
EMISSION_SPP_FACTOR = 4
EMISSION_SPP_MIN = 64


def emission_spp(spp: int) -> int:
    """Samples per pixel of the seen-emission pass for a render of ``spp``."""
    return max(EMISSION_SPP_MIN, EMISSION_SPP_FACTOR * int(spp))


def emission_settings(settings):
    """The :class:`~glrender.render.renderer.RenderSettings` of the seen-emission pass
    for a render with ``settings``: the path tracer with ``emission_only`` (through delta
    surfaces for the path tracer, the first hit for the direct, photon and BDPT
    integrators, as their emission AOVs), same sampler, seed and emitter visibility, at :func:`emission_spp`.
    None where the pass has nothing to add: integrators whose emission AOV is 0 (AO,
    light tracing, SPPM) and clamped renders (the clamp scales the AOV with the sample)."""
    integ = settings.integrator
    if not integrators.get(integ.kind).emission_aov or settings.clamp is not None:
        return None
    # the path tracer's AOV follows delta surfaces to its own depth; the others' is the first hit
    max_depth = integ.max_depth if integrators.get(integ.kind).seen_emission_pass else 1
    return replace(settings, integrator=replace(integ, kind="path", max_depth=max_depth),
                   sampler=replace(settings.sampler, spp=emission_spp(settings.sampler.spp)),
                   aovs=False, count_loops=False, debug_nonfinite=0, emission_only=True)


def render_seen_emission(scene, settings, *, ctx=None, rows: tuple[int, int] | None = None,
                         share=None):
    """The emission the camera sees, as the :class:`~glrender.film.film.Film` of the
    seen-emission pass for a render with ``settings`` (its ``mean``; the tile rows
    ``rows`` only, as ``Renderer.reset(rows=...)``); None where :func:`emission_settings`
    is None. ``share``: a renderer of the same scene whose device data (BVH, textures)
    the pass reuses instead of building its own."""
    pass_settings = emission_settings(settings)
    if pass_settings is None:
        return None
    with Renderer(scene, pass_settings, ctx=ctx, share=share) as r:
        if rows is not None:
            r.reset(rows=rows)
        r.step(pass_settings.sampler.spp)
        return r.film()
