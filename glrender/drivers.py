"""From an integrator's name to the driver that renders it: the one place that maps the driver
names of :mod:`glrender.integrators` to classes. The command line, the API, the preview and
the cluster make their drivers here and ask :mod:`glrender.integrators` the rest.
"""
from __future__ import annotations

from typing import Any

from . import integrators
from .errors import UsageError
from .photon import PhotonRenderer, PhotonSettings, SppmRenderer, SppmSettings
from .render.driver import RenderDriver
from .render.renderer import Renderer, RenderSettings
from .vcm import VcmRenderer, VcmSettings

#: driver name (IntegratorSpec.driver) -> (class, the class of its own settings or None)
DRIVERS: dict[str, tuple[type, type | None]] = {
    "kernel": (Renderer, None),
    "photon": (PhotonRenderer, PhotonSettings),
    "sppm": (SppmRenderer, SppmSettings),
    "vcm": (VcmRenderer, VcmSettings),
}


def options_class(integrator: str) -> type | None:
    """The settings class of the integrator's own options (PhotonSettings, SppmSettings), or
    None for the render kernel's integrators."""
    return DRIVERS[integrators.get(integrator).driver][1]


def create_driver(scene: Any, settings: RenderSettings, options: Any = None, *,
                  ctx: Any = None, device: str | int | None = None,
                  share: Any = None) -> RenderDriver:
    """The driver of ``settings.integrator.kind`` for ``scene``. ``options``: the
    integrator's own settings (an instance of :func:`options_class`; None: its defaults).
    ``share``: a driver of the same scene whose device data (packed arrays, BVH, textures)
    the new one reuses."""
    kind = settings.integrator.kind
    cls, options_cls = DRIVERS[integrators.get(kind).driver]
    if options_cls is None:
        if options is not None:
            raise UsageError(f"integrator {kind!r} takes no options of its own (got "
                             f"{type(options).__name__})")
        return cls(scene, settings, ctx=ctx, device=device, share=share)
    if options is not None and not isinstance(options, options_cls):
        raise UsageError(f"integrator {kind!r}: its options are a {options_cls.__name__}, "
                         f"got {type(options).__name__}")
    kwargs = {"share": share} if share is not None else {}
    return cls(scene, settings, options, ctx=ctx, device=device, **kwargs)
