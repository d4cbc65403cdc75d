"""Host mirror of ``shaders/scene/layout.glsl``: numpy dtypes and binding numbers.

Each structured dtype has exactly the std430 (storage blocks) or std140 (the
uniform block) layout of its GLSL struct; ``tests/gpu/test_layout.py`` writes every
field from numpy and reads it back on the device to prove it. GLSL matrices are
column-major: store ``M.T`` in a ``(4, 4)`` field.
"""
from __future__ import annotations

import numpy as np

# ---- binding numbers (three separate GL binding spaces) ----------------------------
UBO_PARAMS = 0

SSBO_ACCUM_MEAN = 0
SSBO_ACCUM_M2 = 1
SSBO_MATERIALS = 2
SSBO_LIGHTS = 3
SSBO_DISTRIBUTIONS = 4
SSBO_AOV = 5
# vec4s per pixel in SSBO_AOV (kAovVec4s): albedo (rgb, -), normal (xyz, depth), emission (rgb, -)
AOV_VEC4S = 3
AOV_BYTES = 16 * AOV_VEC4S
SSBO_DEBUG = 6
SSBO_SPLAT = 7

TEX_TRI_NORMALS = 4
TEX_TRI_UVS = 5
TEX_TRI_INFO = 6
TEX_ENVMAP = 7
TEX_TEXTURES = 8
TEX_TEXTURE_RECORDS = 9

SSBO_BINDINGS = {
    "AccumMean": SSBO_ACCUM_MEAN, "AccumM2": SSBO_ACCUM_M2, "Materials": SSBO_MATERIALS,
    "Lights": SSBO_LIGHTS, "Distributions": SSBO_DISTRIBUTIONS, "AccumAov": SSBO_AOV,
    "DebugCounters": SSBO_DEBUG, "AccumSplat": SSBO_SPLAT,
}
UBO_BINDINGS = {"RenderParams": UBO_PARAMS}
TEXTURE_BINDINGS = {
    "u_tri_normals": TEX_TRI_NORMALS, "u_tri_uvs": TEX_TRI_UVS, "u_tri_info": TEX_TRI_INFO,
    "u_envmap": TEX_ENVMAP, "u_textures": TEX_TEXTURES, "u_texture_records": TEX_TEXTURE_RECORDS,
}

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
    ("misc", *_V4),
])

MATERIAL = np.dtype([
    ("color0", *_V4),
    ("color1", *_V4),
    ("color2", *_V4),
    ("params", *_V4),
    ("info", *_U4),
    ("table", "<f4", (64,)),   # roughplastic transmittance table (glrender/gpu/microfacet_tables.py)
])

LIGHT = np.dtype([
    ("p", *_V4),
    ("e1", *_V4),
    ("e2", *_V4),
    ("n", *_V4),
    ("radiance", *_V4),
    ("params", *_V4),
    ("info", *_U4),
])

# std430/std140 sizes of the GLSL structs (16-byte vectors and matrices; MaterialData ends
# with a float[64], std430 stride 4).
SIZES = {"RenderParams": 288, "MaterialData": 336, "LightData": 112}
for _name, _dtype in (("RenderParams", RENDER_PARAMS), ("MaterialData", MATERIAL),
                      ("LightData", LIGHT)):
    assert _dtype.itemsize == SIZES[_name], (_name, _dtype.itemsize)

# ---- enumerations shared with GLSL (bsdf/bsdf.glsl, lights/light.glsl) ---------------------
MATERIAL_KINDS = {
    "diffuse": 0, "conductor": 1, "roughconductor": 2, "dielectric": 3, "roughdielectric": 4,
    "thindielectric": 5, "plastic": 6, "roughplastic": 7, "null": 8,
}
MATERIAL_FLAG_TWO_SIDED = 1
MATERIAL_FLAG_GGX = 2
MATERIAL_FLAG_NONLINEAR = 4
MATERIAL_FLAG_NORMAL_SHADOWING = 8   # bsdf/bsdf.glsl bsdf_normal_shadowing
MATERIAL_FLAG_NORMAL_FLIP = 16       # bsdf/normal_map.glsl apply_normal_map

LIGHT_KINDS = {
    "parallelogram": 0, "triangle": 1, "sphere": 2, "disk": 3, "point": 4, "spot": 5,
    "directional": 6, "constant": 7, "envmap": 8,
}
LIGHT_FLAG_TWO_SIDED = 1


def aov_images(aov: np.ndarray, height: int, width: int) -> dict[str, np.ndarray]:
    """The first-hit AOV images of an SSBO_AOV accumulation (float32, AOV_VEC4S vec4s a
    pixel, rows top to bottom): albedo, normal, emission (H, W, 3) and depth (H, W)."""
    a = np.asarray(aov, np.float32).reshape(height, width, AOV_VEC4S, 4)
    return {"albedo": a[:, :, 0, :3].copy(), "normal": a[:, :, 1, :3].copy(),
            "depth": a[:, :, 1, 3].copy(), "emission": a[:, :, 2, :3].copy()}


def zeros(dtype: np.dtype, count: int = 1) -> np.ndarray:
    return np.zeros(max(count, 1), dtype)
