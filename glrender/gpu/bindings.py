"""Every binding point and flag bit of the host/device contract, by name: the host side of
``shaders/common/bindings.glsl``, which states the same names as macros (binding points) and
``k``-constants (flag bits). ``tests/gpu/test_bindings.py`` checks that the two agree, that
every ``layout(binding = ...)`` in the shaders names one of these macros, and that no kernel
sees two blocks or samplers on one binding point.

GL counts three binding spaces apart: uniform blocks (``UBO_*``), storage blocks (``SSBO_*``)
and texture units (``TEX_*``). The render kernel's scene owns uniform block 0, storage blocks
0-7 and texture units 0-10 and 16-31 (the geometry's further parts); the kernels beside it (bdpt's strategy images, the photon map and
SPPM kernels) number theirs from there and never meet in one kernel, so storage blocks 8 and
up and texture units 11 and up are each used by more than one of them.
"""
from __future__ import annotations

# ---- uniform blocks (std140) ------------------------------------------------------------
UBO_RENDER_PARAMS = 0       # RenderParams u_params (scene/layout.glsl): every kernel
UBO_PHOTON_PARAMS = 1       # PhotonParams u_photon (photon/layout.glsl): SPPM's kernels
UBO_PHOTON_MAP_PARAMS = 1   # PhotonMapParams u_map (photon/map_layout.glsl): photon mapping
UBO_VCM_PARAMS = 1          # VcmParams u_vcm (integrators/vcm_layout.glsl): vcm's kernels
UBO_MEDIA = 2               # Media u_media (scene/layout.glsl): the render kernel in scenes with media

# ---- storage blocks (std430) ------------------------------------------------------------
# the scene and the accumulation (scene/layout.glsl)
SSBO_ACCUM_SUM = 0
SSBO_ACCUM_SQ = 1
SSBO_MATERIALS = 2
SSBO_LIGHTS = 3
SSBO_DISTRIBUTIONS = 4
SSBO_ACCUM_AOV = 5
SSBO_DEBUG_COUNTERS = 6
SSBO_ACCUM_SPLAT = 7
# bdpt's strategy images (integrators/strategy_images.glsl)
SSBO_STRATEGY_IMAGES = 8
# SPPM's visible points, grid and deposits (photon/layout.glsl)
SSBO_VP_POSITION = 8
SSBO_VP_SHADING = 9
SSBO_VP_EXTRA = 10
SSBO_VP_RADIANCE = 11
SSBO_VP_RADIUS2 = 12
SSBO_GRID_CELLS = 13
SSBO_DEPOSITS = 14
SSBO_PHOTON_RECORDS = 15
# photon mapping's tracing kernel and counters (photon/map_layout.glsl)
SSBO_TRACED_PHOTONS = 8
SSBO_MAP_COUNTERS = 12
# the wavefront executor's paths (in and out), shadow rays, counters and hits (kernels/wavefront.comp.glsl)
SSBO_WAVE_PATHS_IN = 8
SSBO_WAVE_PATHS_OUT = 9
SSBO_WAVE_SHADOWS = 10
SSBO_WAVE_COUNTERS = 11
SSBO_WAVE_HITS = 12
# vcm's stored light subpaths, merge points, their grid and counters (integrators/vcm_layout.glsl;
# from 9: bdpt's strategy images keep 8)
SSBO_VCM_VERTICES = 9
SSBO_VCM_PATHS = 10
SSBO_VCM_MERGE_KEYS = 11
SSBO_VCM_MERGE_DATA = 12
SSBO_VCM_GRID = 13
SSBO_VCM_COUNTERS = 14
SSBO_VCM_MERGE_SORT = 15
SSBO_VCM_CACHE = 15         # the camera pass's light vertex cache, in the light pass's merge sort block

# ---- texture units ----------------------------------------------------------------------
# the BVH (geometry/bvh_layout.glsl; unit 3 is reserved for geometry)
TEX_BVH_NODES = 0
TEX_BVH_TRIANGLES = 1
TEX_BVH_INSTANCES = 2
TEX_GEOMETRY_RESERVED = 3
# per-triangle shading data (geometry/bvh_layout.glsl), environment and surface textures
# (scene/layout.glsl)
TEX_TRI_NORMALS = 4
TEX_TRI_UVS = 5
TEX_TRI_INFO = 6
TEX_ENVMAP = 7
TEX_TEXTURES = 8
TEX_TEXTURE_RECORDS = 9
# the coating tables of per-texel rough plastic (scene/layout.glsl)
TEX_MICROFACET_TABLES = 10
# photon mapping's maps and their hash tables (photon/map_layout.glsl)
TEX_GLOBAL_MAP = 11
TEX_CAUSTIC_MAP = 12
TEX_GLOBAL_CELLS = 13
TEX_CAUSTIC_CELLS = 14
TEX_MEDIA_GRIDS = 15        # the voxels of heterogeneous media (scene/layout.glsl)
# the further parts of the BVH and per-triangle data past one buffer texture's limit
# (geometry/bvh_layout.glsl): each kind's from its unit up to the next one's, the last up to the
# device's GL_MAX_COMPUTE_TEXTURE_IMAGE_UNITS (32 on llvmpipe and NVIDIA)
TEX_BVH_NODES_MORE = 16
TEX_BVH_TRIANGLES_MORE = 19
TEX_TRI_NORMALS_MORE = 23
TEX_TRI_UVS_MORE = 27
TEX_TRI_INFO_MORE = 30

# ---- flag bits --------------------------------------------------------------------------
# MaterialData.info.y (bsdf/bsdf_common.glsl)
MATERIAL_FLAG_TWO_SIDED = 1
MATERIAL_FLAG_GGX = 2
MATERIAL_FLAG_NONLINEAR = 4
MATERIAL_FLAG_NORMAL_SHADOWING = 8   # the normal map's shadowing term (bsdf/bsdf.glsl)
MATERIAL_FLAG_NORMAL_FLIP = 16       # the normal map's flip of invalid normals (bsdf/normal_map.glsl)
MATERIAL_FLAG_ALPHA_TABLE = 32       # roughplastic reads the coating table over alpha (set on the
                                     # device, bsdf/metallic_roughness.glsl)
# MaterialData.info.y bits 16-23 and 24-31: the interior and exterior medium + 1 of the shape
# the record is for (0: none)
MATERIAL_INTERIOR_SHIFT = 16
MATERIAL_EXTERIOR_SHIFT = 24
# MediumData.info.z (media/medium.glsl)
MEDIUM_FLAG_SAMPLE_EMITTERS = 1
MEDIUM_FLAG_NEAREST = 2              # its grids' lookups take the nearest voxel (else trilinear)
# LightData.info.y (lights/light.glsl)
LIGHT_FLAG_TWO_SIDED = 1
LIGHT_FLAG_RECTANGLE = 2             # a parallelogram with orthogonal edges, sampled as a
                                     # spherical rectangle (set per render: area_sampling)


def binding_points() -> dict[str, int]:
    """Every ``UBO_*``, ``SSBO_*`` and ``TEX_*`` name with its number."""
    return {k: v for k, v in globals().items()
            if k.startswith(("UBO_", "SSBO_", "TEX_")) and isinstance(v, int)}


def flag_bits() -> dict[str, int]:
    """Every ``*_FLAG_*`` name with its bit."""
    return {k: v for k, v in globals().items() if "_FLAG_" in k and isinstance(v, int)}
