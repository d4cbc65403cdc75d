"""The command line's options of the integrators with settings of their own: photon mapping
(``glrender render --integrator photon`` and ``--integrator sppm``) and vertex connection and
merging (``--integrator vcm``, which shares SPPM's iterations and radius schedule)."""
from __future__ import annotations

from typing import Any

from ..errors import UsageError
from ..photon.photon import PhotonSettings
from ..photon.sppm import SppmSettings
from ..vcm.vcm import DEFAULT_ALPHA, MAX_CACHE_CONNECTIONS, MAX_LIGHT_PATHS, MODES, VcmSettings

SPPM_OPTIONS = ("iterations", "initial_radius", "alpha")
PHOTON_OPTIONS = ("caustic_photons", "radius", "knn", "final_gather")
SHARED_OPTIONS = ("photons_per_iteration", "kernel", "volume_radius")   # --photons: per iteration (sppm) or per map
VCM_OPTIONS = ("vcm_mode", "light_paths", "light_vertex_cache")   # vcm takes SPPM_OPTIONS too
OPTIONS = SHARED_OPTIONS + SPPM_OPTIONS + PHOTON_OPTIONS + VCM_OPTIONS   # saved in checkpoints
#: the options each of these integrators takes
TAKES = {"sppm": SHARED_OPTIONS + SPPM_OPTIONS, "photon": SHARED_OPTIONS + PHOTON_OPTIONS,
         "vcm": SPPM_OPTIONS + VCM_OPTIONS}
AOVS = ("radius", "photons")   # SPPM's search radius; the photon-map view (sppm and photon)


def add_arguments(parser: Any) -> None:
    """The photon mapping options, as an argument group of ``glrender render``."""
    g = parser.add_argument_group("photon mapping and vcm (--integrator photon, sppm, vcm)")
    g.add_argument("--photons-per-iteration", "--photons", dest="photons_per_iteration", type=int,
                   default=None, metavar="N",
                   help="sppm: photons per iteration (default: one per pixel, at least 16384); "
                        "photon: photons traced for the global map (default 262144)")
    g.add_argument("--kernel", choices=("uniform", "cone", "epanechnikov"), default=None,
                   help="density estimation kernel over each search disk (default: uniform)")
    g.add_argument("--volume-radius", type=float, default=None, metavar="R",
                   help="sppm: initial search radius of points in participating media (default: 3 "
                        "times --initial-radius, at most 3%% of the scene's radius); photon: lookup "
                        "radius of the volume photons (default: --radius, or the radius holding 64 "
                        "of them around those in their denser part)")
    g.add_argument("--iterations", type=int, default=None, metavar="N",
                   help="sppm, vcm: iterations (one camera sample per pixel and a photon or light "
                        "pass each; default: the scene's spp)")
    g.add_argument("--initial-radius", type=float, default=None, metavar="R",
                   help="sppm, vcm: initial search (merge) radius in scene units (default: 2 pixel "
                        "footprints at the scene's centre)")
    g.add_argument("--alpha", type=float, default=None, metavar="A",
                   help="sppm: fraction of new photons kept per iteration, in (0, 1) (default "
                        f"0.7); vcm: the radius falls as iteration^((A - 1) / 2) (default "
                        f"{DEFAULT_ALPHA})")
    g.add_argument("--vcm-mode", choices=tuple(MODES), default=None,
                   help="vcm: connections and merges (vcm, the default), connections alone (bpt: "
                        "bdpt itself) or merges alone (vm: progressive photon mapping)")
    g.add_argument("--light-paths", type=int, default=None, metavar="N",
                   help="vcm: light paths per iteration (default: one per pixel; more: more merge "
                        "points and lens connections, fewer: pixels share the one they connect to)")
    g.add_argument("--light-vertex-cache", type=int, default=None, metavar="M",
                   help="vcm: connect each camera vertex to M light vertices drawn from all the "
                        "iteration's light subpaths instead of to every vertex of its pixel's own "
                        f"(1-{MAX_CACHE_CONNECTIONS}; default: its own subpath)")
    g.add_argument("--caustic-photons", type=int, default=None, metavar="N",
                   help="photon: photons traced for the caustic map (default: as --photons)")
    g.add_argument("--radius", type=float, default=None, metavar="R",
                   help="photon: fixed lookup radius in scene units (default: the radius holding "
                        "64 photons around a typical photon of each map)")
    g.add_argument("--knn", type=int, default=None, metavar="K",
                   help="photon: estimate from the K nearest photons (1-64) instead of a fixed "
                        "radius")
    g.add_argument("--final-gather", action="store_const", const=True, default=None,
                   help="photon: indirect light through one gather ray per sample (the global "
                        "map looked up where it lands) instead of at the first surface")


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def photon_options(args: Any, kind: str) -> tuple[int | None, SppmSettings | PhotonSettings | None]:
    """For the ``kind`` integrator: the iterations that stand for its samples per pixel
    (sppm's --iterations; None: as --spp or the scene's) and the photon integrators' own
    settings from ``args`` (None for the others, whose photon options are refused)."""
    given = [name for name in OPTIONS if getattr(args, name, None) is not None]
    aovs = [n.strip() for n in (getattr(args, "aov", None) or "").split(",") if n.strip() in AOVS]
    for name in given:
        if name not in TAKES.get(kind, ()):
            takers = [k for k, names in TAKES.items() if name in names]
            raise UsageError(f"{_flag(name)}: only with --integrator {' or '.join(takers)}")
    if kind not in ("sppm", "photon") and aovs:
        raise UsageError(f"--aov {aovs[0]}: only with --integrator sppm or photon")
    if kind not in TAKES:
        return None, None
    iterations = getattr(args, "iterations", None)
    if iterations is not None and iterations < 1:
        raise UsageError(f"--iterations {iterations}: expected a positive number of iterations")
    volume_radius = getattr(args, "volume_radius", None)
    if volume_radius is not None and not volume_radius > 0:
        raise UsageError(f"--volume-radius {volume_radius}: expected a positive number of scene units")
    if kind == "vcm":
        radius, alpha = getattr(args, "initial_radius", None), getattr(args, "alpha", None)
        if radius is not None and not radius > 0:
            raise UsageError(f"--initial-radius {radius}: expected a positive number of scene units")
        if alpha is not None and not 0 < alpha < 1:
            raise UsageError(f"--alpha {alpha}: expected a number in (0, 1)")
        paths = getattr(args, "light_paths", None)
        if paths is not None and not 1 <= paths <= MAX_LIGHT_PATHS:
            raise UsageError(f"--light-paths {paths}: expected an integer in [1, {MAX_LIGHT_PATHS}]")
        mode = getattr(args, "vcm_mode", None) or "vcm"
        cache = getattr(args, "light_vertex_cache", None)
        if cache is not None and not 1 <= cache <= MAX_CACHE_CONNECTIONS:
            raise UsageError(f"--light-vertex-cache {cache}: expected an integer in "
                             f"[1, {MAX_CACHE_CONNECTIONS}] connections per camera vertex")
        if cache is not None and mode != "vcm":
            raise UsageError(f"--light-vertex-cache: only with --vcm-mode vcm (connections and "
                             f"merges), not {mode}")
        return iterations, VcmSettings(mode=mode, initial_radius=radius,
                                       alpha=DEFAULT_ALPHA if alpha is None else alpha,
                                       light_paths=paths, cache_connections=cache or 0)
    if kind == "photon":
        if "radius" in aovs:
            raise UsageError("--aov radius: only with --integrator sppm (the photon integrator's "
                             "radius is one number per map, in --stats)")
        photons = getattr(args, "photons_per_iteration", None)
        if photons is not None and photons < 1:
            raise UsageError(f"--photons {photons}: expected a positive number of photons")
        caustic = getattr(args, "caustic_photons", None)
        if caustic is not None and caustic < 1:
            raise UsageError(f"--caustic-photons {caustic}: expected a positive number of photons")
        radius, knn = getattr(args, "radius", None), getattr(args, "knn", None)
        if radius is not None and knn is not None:
            raise UsageError("--radius and --knn: give one (a fixed radius or the k nearest photons)")
        if radius is not None and not radius > 0:
            raise UsageError(f"--radius {radius}: expected a positive number of scene units")
        if knn is not None and not 1 <= knn <= 64:
            raise UsageError(f"--knn {knn}: expected an integer in [1, 64]")
        kw = {} if photons is None else {"photons": photons}
        return None, PhotonSettings(caustic_photons=caustic, radius=radius, knn=knn,
                                    kernel=getattr(args, "kernel", None) or "uniform",
                                    final_gather=bool(getattr(args, "final_gather", None)),
                                    photon_view="photons" in aovs, volume_radius=volume_radius, **kw)
    sppm = SppmSettings(photons_per_iteration=getattr(args, "photons_per_iteration", None),
                        initial_radius=getattr(args, "initial_radius", None),
                        alpha=0.7 if getattr(args, "alpha", None) is None else args.alpha,
                        photon_view="photons" in aovs, kernel=getattr(args, "kernel", None) or "uniform",
                        volume_radius=volume_radius)
    return iterations, sppm
