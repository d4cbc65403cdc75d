"""The command line's photon mapping options (``glrender render --integrator sppm``)."""
from __future__ import annotations

from dataclasses import replace
from typing import Any

from ..errors import UsageError
from .sppm import SppmSettings

OPTIONS = ("iterations", "photons_per_iteration", "initial_radius", "alpha", "kernel")
AOVS = ("radius", "photons")   # SPPM's pictures: search radius, photon-map view


def add_arguments(parser: Any) -> None:
    """The photon mapping options, as an argument group of ``glrender render``."""
    g = parser.add_argument_group("photon mapping (--integrator sppm)")
    g.add_argument("--iterations", type=int, default=None, metavar="N",
                   help="SPPM iterations (one camera sample per pixel and a photon pass each; "
                        "default: the scene's spp)")
    g.add_argument("--photons-per-iteration", "--photons", dest="photons_per_iteration", type=int,
                   default=None, metavar="N", help="photons per iteration (default: one per pixel, "
                                                   "at least 16384)")
    g.add_argument("--initial-radius", type=float, default=None, metavar="R",
                   help="initial search radius in scene units (default: 2 pixel footprints at the "
                        "scene's centre)")
    g.add_argument("--kernel", choices=("uniform", "cone", "epanechnikov"), default=None,
                   help="density estimation kernel over each pixel's disk (default: uniform)")
    g.add_argument("--alpha", type=float, default=None, metavar="A",
                   help="fraction of new photons kept per iteration, in (0, 1) (default 0.7)")


def photon_settings(args: Any, settings: Any) -> tuple[Any, SppmSettings | None]:
    """The render settings (iterations as the sample count) and SPPM's own settings for
    ``args``; photon options without ``--integrator sppm`` are refused."""
    given = [name for name in OPTIONS if getattr(args, name, None) is not None]
    aovs = [n.strip() for n in (getattr(args, "aov", None) or "").split(",") if n.strip() in AOVS]
    if settings.integrator.kind != "sppm":
        if given:
            raise UsageError(f"--{given[0].replace('_', '-')}: only with --integrator sppm")
        if aovs:
            raise UsageError(f"--aov {aovs[0]}: only with --integrator sppm")
        return settings, None
    iterations = getattr(args, "iterations", None)
    if iterations is not None:
        if iterations < 1:
            raise UsageError(f"--iterations {iterations}: expected a positive number of iterations")
        settings = replace(settings, sampler=replace(settings.sampler, spp=iterations))
    sppm = SppmSettings(photons_per_iteration=getattr(args, "photons_per_iteration", None),
                        initial_radius=getattr(args, "initial_radius", None),
                        alpha=0.7 if getattr(args, "alpha", None) is None else args.alpha,
                        photon_view="photons" in aovs, kernel=getattr(args, "kernel", None) or "uniform")
    return settings, sppm
