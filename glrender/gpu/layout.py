"""Host mirror of ``shaders/scene/layout.glsl``: numpy dtypes of its structs and the kinds
of materials and lights (binding numbers and flag bits: :mod:`glrender.gpu.bindings`).

Each structured dtype has exactly the std430 (storage blocks) or std140 (the
uniform block) layout of its GLSL struct; ``tests/gpu/test_layout.py`` writes every
field from numpy and reads it back on the device to prove it. GLSL matrices are
column-major: store ``M.T`` in a ``(4, 4)`` field.
"""
from __future__ import annotations

import numpy as np

_V4 = ("<f4", 4)
_U4 = ("<u4", 4)

RENDER_PARAMS = np.dtype([
    ("camera_open", "<f4", (4, 4)),
    ("camera_close", "<f4", (4, 4)),
    ("camera_screen", *_V4),
    ("camera_clip", *_V4),
    ("shutter", *_V4),
    ("filter_params", *_V4),
    ("image", *_U4),
    ("samples", *_U4),
    ("dispatch", *_U4),
    ("counts", *_U4),
    ("scene_sphere", *_V4),
    ("ao_distance", "<f4"),
    ("sample_clamp", "<f4"),
    ("camera_projection", "<u4"),   # CAMERA_PROJECTIONS
    ("unused", "<f4"),
])

# RenderParams.camera_projection: kCamera* in camera/camera.glsl
CAMERA_PROJECTIONS = {"perspective": 0, "orthographic": 1}

MATERIAL = np.dtype([
    ("color0", "<f4", 3),
    ("opacity_texture", "<f4"),   # texture index + 1 (0: none)
    ("color1", "<f4", 3),
    ("alpha_cutoff", "<f4"),
    ("color2", "<f4", 3),
    ("normal_scale", "<f4"),
    ("params", "<f4", 3),         # alpha u, alpha v, eta
    ("normal_map", "<f4"),        # texture index + 1 (0: none)
    ("info", *_U4),
    ("table", "<f4", (64,)),   # roughplastic transmittance table (glrender/gpu/microfacet_tables.py)
])

LIGHT = np.dtype([
    ("p", *_V4),
    ("e1", *_V4),
    ("e2", *_V4),
    ("n", *_V4),
    ("radiance", *_V4),
    ("params", "<f4", 3),
    ("selection_pmf", "<f4"),
    ("info", *_U4),
    ("uv0", "<f4", 2),            # textured emission: uv at p and its change along e1, e2
    ("uv_e1", "<f4", 2),
    ("uv_e2", "<f4", 2),
    ("emission_texture", "<f4"),  # texture index + 1 (0: none)
    ("pad", "<f4"),
])

MAX_MEDIA = 64    # kMaxMedia: the media uniform block's records
SUPERVOXEL = 8    # kSupervoxel: voxels along a side of a heterogeneous medium's supervoxel
MEDIUM = np.dtype([
    ("sigma_t", *_V4),   # xyz: extinction (scale applied; heterogeneous: the scale), w: phase g
    ("sigma_s", *_V4),   # xyz: albedo times sigma_t (heterogeneous: the constant albedo)
    ("info", *_U4),      # MEDIUM_KINDS, PHASE_KINDS, bindings.MEDIUM_FLAG_*, -
    ("grid_from_world", "<f4", (4, 4)),   # heterogeneous: world to the grids' unit cube (stored .T)
    ("sigma_grid", *_U4),    # first texel in the grid texture, voxels x, y, z
    ("albedo_grid", *_U4),   # first texel + 1 (0: constant albedo), voxels x, y, z
    ("majorant", *_V4),      # x: a bound on sigma_t over the grid (every channel, scale applied),
                             # y: the mean extinction that bidirectional MIS weights assume
    ("majorant_grid", *_U4),  # first texel of the supervoxels' bounds, supervoxels x, y, z
])
MEDIA = np.dtype([
    ("media_counts", *_U4),   # media, the camera's medium + 1 (0: none)
    ("media", MEDIUM, (MAX_MEDIA,)),
])

# std430/std140 sizes of the GLSL structs (16-byte vectors and matrices; MaterialData ends
# with a float[64], std430 stride 4).
SIZES = {"RenderParams": 288, "MaterialData": 336, "LightData": 144, "MediumData": 176,
         "Media": 16 + 176 * MAX_MEDIA}
for _name, _dtype in (("RenderParams", RENDER_PARAMS), ("MaterialData", MATERIAL),
                      ("LightData", LIGHT), ("MediumData", MEDIUM), ("Media", MEDIA)):
    assert _dtype.itemsize == SIZES[_name], (_name, _dtype.itemsize)

# ---- enumerations shared with GLSL (bsdf/bsdf.glsl, lights/light.glsl) ---------------------
MATERIAL_KINDS = {
    "diffuse": 0, "conductor": 1, "roughconductor": 2, "dielectric": 3, "roughdielectric": 4,
    "thindielectric": 5, "plastic": 6, "roughplastic": 7, "null": 8, "metallicroughness": 9,
}
MEDIUM_KINDS = {"homogeneous": 0, "heterogeneous": 1}   # kMedium* in media/medium.glsl
PHASE_KINDS = {"isotropic": 0, "hg": 1}                  # kPhase* in media/medium.glsl
LIGHT_KINDS = {
    "parallelogram": 0, "triangle": 1, "sphere": 2, "disk": 3, "point": 4, "spot": 5,
    "directional": 6, "constant": 7, "envmap": 8,
}


def zeros(dtype: np.dtype, count: int = 1) -> np.ndarray:
    return np.zeros(max(count, 1), dtype)
