"""Photon tracing and density estimation: photon mapping (the two-pass method) and
stochastic progressive photon mapping (SPPM)."""
from .photon import PhotonRenderer, PhotonSettings
from .sppm import SppmRenderer, SppmSettings

__all__ = ["PhotonRenderer", "PhotonSettings", "SppmRenderer", "SppmSettings"]
