"""Photon tracing and density estimation: stochastic progressive photon mapping (SPPM)."""
from .sppm import SppmRenderer, SppmSettings

__all__ = ["SppmRenderer", "SppmSettings"]
