"""Host mirror of ``shaders/photon/layout.glsl`` and ``map_layout.glsl``: the std140 uniform
blocks of the photon kernels and their record sizes (tests/photon/test_photon_trace.py
checks the block on the device; binding numbers: :mod:`glrender.gpu.bindings`)."""
from __future__ import annotations

import numpy as np

# bytes per pixel of the SPPM device buffers: position 16, shading 32, extra 32,
# radiance 16, radius^2 4, deposits 16 (the grid adds 4 per listed cell and entry)
BYTES_PER_PIXEL = 16 + 32 + 32 + 16 + 4 + 16
WIDEST_PER_PIXEL = 32      # the largest of those: a slice of pixels fits one binding of it
BYTES_PER_RECORD = 16      # a photon's emission record (tests, photon statistics)
RECORD_HEADER_WORDS = 4    # counters before the records: skipped, visited, max visited, -

PHOTON_PARAMS = np.dtype([
    ("photons", "<u4", 4),     # first, count, per iteration, iteration
    ("grid_size", "<u4", 4),   # cells xyz, hash table size
    ("grid_lo", "<f4", 4),     # corner xyz, cell edge
    ("options", "<u4", 4),     # deposit from segment, max segments, record emission, photon view
    ("estimate", "<u4", 4),    # density kernel, camera slice: first pixel row, rows; -
])
assert PHOTON_PARAMS.itemsize == 80

# density estimation kernels (kKernel* in shaders/photon/density.glsl)
KERNELS = {"uniform": 0, "cone": 1, "epanechnikov": 2}

# the photon integrator (shaders/photon/map_layout.glsl): the maps' records in grid order
BYTES_PER_PHOTON = 48       # position and type, direction and normal, power and segments
TEXELS_PER_PHOTON = 3
MAP_COUNTER_WORDS = 4       # stored, candidates skipped, visited, most visited by one lookup

PHOTON_MAP_PARAMS = np.dtype([
    ("trace", "<u4", 4),         # first, count, photons of the pass, map (0 global, 1 caustic)
    ("store", "<u4", 4),         # capacity, max depth, photon view, -
    ("global_size", "<u4", 4),   # cells xyz, hash table size
    ("global_lo", "<f4", 4),     # corner xyz, cell edge
    ("caustic_size", "<u4", 4),
    ("caustic_lo", "<f4", 4),
    ("radius", "<f4", 4),        # lookup radius global, caustic; 1 / photons global, caustic
    ("mode", "<u4", 4),          # kernel, k nearest (0: fixed radius), final gather, direct by photons
    ("global_volume_size", "<u4", 4),    # the volume photons' grids, the same way
    ("global_volume_lo", "<f4", 4),
    ("caustic_volume_size", "<u4", 4),
    ("caustic_volume_lo", "<f4", 4),
    ("volume_radius", "<f4", 4),  # lookup radius of the global and caustic maps' volume photons; -, -
    ("volume_table", "<u4", 4),   # their grids' first hash-table entry in the cells textures; -, -
])
assert PHOTON_MAP_PARAMS.itemsize == 224
PHOTON_VOLUME = 3            # kPhotonVolume: added to a volume photon's type (map_layout.glsl)
