"""The integrators, by name: the one table that the scene loaders, the renderer, the command
line, the API, the preview and the cluster ask about an integrator.

An entry says which GLSL file defines the integrator's ``integrator_li`` and which driver runs
it (``"kernel"``: the render kernel's, :class:`glrender.render.renderer.Renderer`; the photon
integrators name their own, :mod:`glrender.drivers` maps driver names to classes), and the
facts that callers would otherwise test names for. A new integrator that runs in the render
kernel is its GLSL file, one :func:`register` call here, and its test.

This module sits at the bottom of the layers (it imports nothing of glrender's but its
errors), so that the scene loaders can check a scene's integrator name against it.
"""
from __future__ import annotations

from dataclasses import dataclass

from .errors import UsageError


@dataclass(frozen=True)
class IntegratorSpec:
    """What the rest of glrender needs to know about one integrator."""

    name: str
    #: the GLSL file (under shaders/) that defines ``integrator_li`` for the camera kernel;
    #: None for a driver with kernels of its own (sppm)
    glsl: str | None
    #: the driver that runs it: "kernel" (the render kernel) or a name in glrender.drivers
    driver: str = "kernel"
    #: its light paths splat onto the whole film (integrators/splat.glsl): no --crop, and a
    #: cluster renders whole frames
    splatting: bool = False
    #: it records the emission the camera sees at the first hit in its emission AOV, so a
    #: denoised render adds back a seen-emission pass (glrender.render.emission_pass)
    emission_aov: bool = True
    #: it connects subpaths by strategies (s, t): one image per strategy (--strategy-images),
    #: and a sample's connections grow with the square of the depth (fewer per invocation)
    strategies: bool = False
    #: light samples per vertex and BSDF branches at the first vertex (--light-samples,
    #: --split) apply to it
    splitting: bool = False
    #: its emission AOV follows delta surfaces to the emitter behind them, and it renders
    #: that seen emission alone (emission_only: the seen-emission pass of a denoised render)
    seen_emission_pass: bool = False
    #: its image comes from light-path vertices connected to a lens point alone
    #: (camera/importance.glsl camera_connect): a camera whose rays share one direction
    #: (orthographic) cannot be rendered (bdpt drops those strategies and keeps the others)
    needs_lens: bool = False
    #: a cluster can render it (glrender.distributed)
    distributed: bool = True
    #: a time budget without a sample count renders until the budget ends (sppm: its
    #: iterations, given as spp, are the target either way)
    open_ended: bool = True
    #: the direct-lighting strategy (--strategy) and the depth (--max-depth) matter to it
    #: (what the preview's title shows)
    uses_strategy: bool = True
    uses_depth: bool = True
    #: the most segments one of its paths may have, whatever the depth asks (the
    #: integrators' kUnboundedDepthCap, bdpt's kBdptDepthCap: fixed loop bounds and vertex
    #: arrays); None where paths are short by construction
    depth_cap: int | None = 256
    #: it counts the paths its cap cut short (Film.truncated, --stats truncated_paths)
    counts_truncation: bool = False
    #: it renders participating media (scenes whose shapes or camera name media)
    media: bool = False
    #: one line for --help and the docs
    summary: str = ""

    def cap_binds(self, max_depth: int) -> bool:
        """Whether the depth cap can end paths at ``max_depth`` (-1: unbounded)."""
        return self.depth_cap is not None and (max_depth < 0 or max_depth > self.depth_cap)


_REGISTRY: dict[str, IntegratorSpec] = {}


def register(spec: IntegratorSpec) -> IntegratorSpec:
    """Add ``spec`` to the table (names are unique)."""
    if spec.name in _REGISTRY:
        raise ValueError(f"integrator {spec.name!r} is registered already")
    _REGISTRY[spec.name] = spec
    return spec


def names() -> tuple[str, ...]:
    """Every integrator's name, in registration order."""
    return tuple(_REGISTRY)


def get(name: str) -> IntegratorSpec:
    """The entry of integrator ``name``; a :class:`~glrender.errors.UsageError` naming the
    known ones when there is none."""
    spec = _REGISTRY.get(name)
    if spec is None:
        raise UsageError(f"integrator {name!r}: expected one of {', '.join(_REGISTRY)}")
    return spec


def running_on(driver: str) -> tuple[str, ...]:
    """The names of the integrators that ``driver`` runs."""
    return tuple(n for n, s in _REGISTRY.items() if s.driver == driver)


register(IntegratorSpec("path", "integrators/path.glsl", splitting=True, seen_emission_pass=True,
                        counts_truncation=True, media=True,
                        summary="unidirectional path tracing with next-event estimation and MIS"))
register(IntegratorSpec("direct", "integrators/direct.glsl",
                        uses_depth=False, depth_cap=None, media=True,
                        summary="direct lighting only, by light, BSDF or MIS sampling"))
register(IntegratorSpec("ao", "integrators/ao.glsl", emission_aov=False, uses_strategy=False,
                        uses_depth=False, depth_cap=None,
                        summary="ambient occlusion: the unoccluded fraction of a cosine lobe"))
register(IntegratorSpec("lighttrace", "integrators/lighttrace.glsl", splatting=True,
                        emission_aov=False, counts_truncation=True, needs_lens=True, media=True,
                        summary="light tracing: paths from the lights connected to the lens"))
register(IntegratorSpec("bdpt", "integrators/bdpt.glsl", splatting=True, strategies=True,
                        depth_cap=16, counts_truncation=True, media=True,
                        summary="bidirectional path tracing, every strategy weighted by MIS"))
register(IntegratorSpec("sppm", None, driver="sppm",
                        emission_aov=False, distributed=False, open_ended=False,
                        uses_strategy=False, media=True,
                        summary="stochastic progressive photon mapping (iterations as spp)"))
register(IntegratorSpec("photon", "integrators/photon.glsl", driver="photon", uses_strategy=False,
                        media=True,
                        summary="photon mapping: global and caustic maps, then camera paths"))
register(IntegratorSpec("vcm", "integrators/vcm.glsl", driver="vcm", splatting=True,
                        strategies=True, depth_cap=16, counts_truncation=True, media=True,
                        summary="vertex connection and merging: bdpt's connections and photon "
                                "merges under one MIS (iterations as spp)"))
