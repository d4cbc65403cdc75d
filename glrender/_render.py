"""The implementation of :func:`glrender.render` (a module of its own: the name ``render``
is also the subpackage glrender/render/)."""
from __future__ import annotations

import inspect
import os
import time as _time
from typing import Callable

from .drivers import create_driver
from .errors import UsageError
from .film import Film
from .render.job import Job, JobOptions, Timings
from .render.renderer import settings_from_scene
from .scene import load
from .scene.model import Scene

#: ``progress(spp_done, seconds)``: called after every pass of :func:`render`.
ProgressCallback = Callable[[int, float], None]

# the further keyword options render() passes to settings_from_scene
_SETTINGS_OPTIONS = set(inspect.signature(settings_from_scene).parameters) - {
    "scene", "integrator", "spp", "seed", "sampler", "max_depth", "strategy", "aovs"}


def render(scene: Scene | str | os.PathLike[str], spp: int | None = None, *,
           time: float | None = None, integrator: str | None = None, seed: int | None = None,
           sampler: str | None = None, max_depth: int | None = None,
           strategy: str | None = None, aovs: bool = False,
           device: str | int | None = None,
           integrator_options: object = None,
           progress: bool | ProgressCallback = True,
           callback: Callable[[int, int], None] | None = None,
           **options: object) -> Film:
    """Render a scene (or a scene file path) and return its :class:`Film`.

    Args:
        scene: a :class:`Scene`, or the path of a scene file (loaded with :func:`load`).
        spp: samples per pixel (default: the scene's sampler). With ``time`` and no
            ``spp``, the render runs until the time budget ends.
        time: a budget in seconds of rendering (loading, building and compiling not
            counted): rendering stops before the pass that would end past it (the first
            pass always completes, so the image has samples).
        integrator: a name from :func:`glrender.integrators.names` (``"path"``,
            ``"direct"``, ``"ao"``, ``"lighttrace"``, ``"bdpt"``, ``"photon"``, ``"sppm"``;
            default: the scene's). SPPM's ``spp`` is its number of iterations.
        seed: the sampler's seed; the same scene, seed and spp give the same image, bitwise,
            on the same device.
        sampler: ``"independent"``, ``"stratified"`` or ``"sobol"``.
        max_depth: path segments (Mitsuba's convention: 1 = emitters seen directly,
            2 = direct lighting, -1 = unbounded).
        strategy: direct-lighting weighting: ``"light"``, ``"bsdf"``, ``"mis-balance"``,
            ``"mis-power"``.
        aovs: also record first-hit albedo, normal (world space), depth (metres along
            the ray) and the emission the camera sees, read with :meth:`Film.aov`.
        device: ``"auto"``, ``"cpu"`` (llvmpipe), ``"gpu"`` or an EGL device index.
        integrator_options: the photon integrators' own settings, a
            :class:`glrender.photon.PhotonSettings` or :class:`glrender.photon.SppmSettings`
            (None: their defaults).
        progress: True: a progress bar on standard error when it is a terminal; False:
            nothing; a callable: ``progress(spp_done, seconds)`` after every pass.
        callback: ``callback(spp_done, spp_target)`` after every pass.
        options: other overrides of :func:`glrender.settings_from_scene` (``rr_depth``, ``rr``,
            ``light_samples``, ``split``, ``light_selection``, ``area_sampling``,
            ``hide_emitters``, ...).

    Returns:
        The image and its per-pixel statistics; ``film.stats`` holds what ``glrender render
        --stats`` records: the device, the settings, the timings (seconds by phase), the
        sample rate (samples/s), the passes and why the render stopped.

    Raises:
        SceneError: the scene file or scene is invalid.
        UsageError: an argument is out of range.
        DeviceError: no OpenGL device could be opened.
        ShaderError: the kernel did not compile.
    """
    t_start = _time.perf_counter()
    if time is not None and not (isinstance(time, (int, float)) and time > 0 and time < float("inf")):
        raise UsageError(f"time: expected a positive number of seconds, got {time!r}")
    if spp is not None and (not isinstance(spp, int) or isinstance(spp, bool) or spp < 1):
        raise UsageError(f"spp: expected a positive integer, got {spp!r}")
    timings = Timings()
    if not isinstance(scene, Scene):
        if not isinstance(scene, (str, os.PathLike)):
            raise UsageError(f"render: expected a Scene or a scene file path, got "
                             f"{type(scene).__name__}")
        with timings("load"):
            scene = load(scene)
    scene.validate()
    unknown = sorted(set(options) - _SETTINGS_OPTIONS)
    if unknown:
        raise UsageError(f"render: unknown option {', '.join(unknown)} (expected "
                         f"{', '.join(sorted(_SETTINGS_OPTIONS))})")

    def after_pass(done: int, seconds: float) -> None:
        if callable(progress):
            progress(done, seconds)
        if callback is not None:
            callback(done, job.target)      # the job below, made before its first pass

    settings = dict(sampler=sampler, max_depth=max_depth, strategy=strategy, aovs=aovs,
                    **options)
    with Job(scene, JobOptions(integrator=integrator, spp=spp, seed=seed, settings=settings,
                               integrator_options=integrator_options, seconds=time,
                               device=device, progress_bar=progress is True,
                               on_pass=after_pass, timings=timings, started=t_start),
             create_driver) as job:
        outcome = job.run()
    outcome.film.stats = outcome.stats or {}
    return outcome.film
