"""Vertex connection and merging: bdpt's connections and photon mapping's merges under one
MIS weight (:mod:`glrender.vcm.vcm`)."""
from .vcm import VcmRenderer, VcmSettings

__all__ = ["VcmRenderer", "VcmSettings"]
