"""Host mirror of ``shaders/integrators/vcm_layout.glsl``: the std140 uniform block of vcm's
kernels and the sizes of its stored records (binding numbers: :mod:`glrender.gpu.bindings`)."""
from __future__ import annotations

import numpy as np

VCM_PARAMS = np.dtype([
    ("paths", "<u4", 4),       # light paths, vertex capacity, merge point capacity, splat (1)
    ("grid_size", "<u4", 4),   # 0, 0, 0 (unbounded cells), hash table size
    ("grid_lo", "<f4", 4),     # corner xyz, cell edge
    ("merge", "<f4", 4),       # radius, radius^2, eta = pi r^2 N, 1 / eta
    ("lens", "<f4", 4),        # N / (W H), W H / N (the lens connections' density, splat weight)
    ("cache", "<u4", 4),       # the light vertex cache's entries, 0, 0, 0
])
assert VCM_PARAMS.itemsize == 96

#: bytes per stored light vertex (kVcmVertexTexels records of 16 bytes; 7 in scenes whose
#: normal maps have the shadowing term, which keeps the unperturbed normal, and in scenes with
#: participating media, which keep the MIS transmittance of the segment before the vertex)
def vertex_bytes(normal_shadowing: bool, media: bool = False) -> int:
    return 16 * (7 if normal_shadowing or media else 6)


MERGE_KEY_BYTES = 16       # position and (light path * 32 + vertex index)
MERGE_DATA_BYTES = 64      # kVcmMergeTexels records: direction and density, throughput and
                           # area factor, normal and light-side sum, strategy flag, segments
                           # and the vertex's info word (kind and medium)
MERGE_SORT_BYTES = 8       # its key and its grid cell's hash, for the host's two sorts
MERGE_BYTES = MERGE_KEY_BYTES + MERGE_DATA_BYTES + MERGE_SORT_BYTES
PATH_BYTES = 8             # per light path: first vertex slot, vertex count
CACHE_ENTRY_BYTES = 4      # per stored light vertex past the light: its slot
COUNTER_WORDS = 4          # vertices stored, merge points stored, candidates skipped, visited
MAX_PATH_VERTICES = 32     # a key holds the vertex index in 5 bits (bdpt's cap: 17 vertices)
