// Every binding point and flag bit of the host/device contract, by name: the device side
// of glrender/gpu/bindings.py, which states the same names (tests/gpu/test_bindings.py
// checks that they agree, and that every layout(binding = ...) names one of these).
//
// GL counts three binding spaces apart: uniform blocks (UBO_*), storage blocks (SSBO_*)
// and texture units (TEX_*). The render kernel's scene owns uniform block 0, storage
// blocks 0-7 and texture units 0-10 and 16-31 (the geometry's further parts); bdpt's strategy images and the photon kernels number
// theirs from there and never meet in one kernel.

// ---- uniform blocks (std140) ------------------------------------------------------------
#define UBO_RENDER_PARAMS 0
#define UBO_PHOTON_PARAMS 1
#define UBO_PHOTON_MAP_PARAMS 1
#define UBO_VCM_PARAMS 1
#define UBO_MEDIA 2

// ---- storage blocks (std430) ------------------------------------------------------------
// the scene and the accumulation (scene/layout.glsl)
#define SSBO_ACCUM_SUM 0
#define SSBO_ACCUM_SQ 1
#define SSBO_MATERIALS 2
#define SSBO_LIGHTS 3
#define SSBO_DISTRIBUTIONS 4
#define SSBO_ACCUM_AOV 5
#define SSBO_DEBUG_COUNTERS 6
#define SSBO_ACCUM_SPLAT 7
// bdpt's strategy images (integrators/strategy_images.glsl)
#define SSBO_STRATEGY_IMAGES 8
// SPPM's visible points, grid and deposits (photon/layout.glsl)
#define SSBO_VP_POSITION 8
#define SSBO_VP_SHADING 9
#define SSBO_VP_EXTRA 10
#define SSBO_VP_RADIANCE 11
#define SSBO_VP_RADIUS2 12
#define SSBO_GRID_CELLS 13
#define SSBO_DEPOSITS 14
#define SSBO_PHOTON_RECORDS 15
// photon mapping's tracing kernel and counters (photon/map_layout.glsl)
#define SSBO_TRACED_PHOTONS 8
#define SSBO_MAP_COUNTERS 12
// the wavefront executor's paths (in and out), shadow rays, counters and hits (kernels/wavefront.comp.glsl)
#define SSBO_WAVE_PATHS_IN 8
#define SSBO_WAVE_PATHS_OUT 9
#define SSBO_WAVE_SHADOWS 10
#define SSBO_WAVE_COUNTERS 11
#define SSBO_WAVE_HITS 12
// vcm's stored light subpaths, merge points, their grid and counters
// (integrators/vcm_layout.glsl; from 9: bdpt's strategy images keep 8)
#define SSBO_VCM_VERTICES 9
#define SSBO_VCM_PATHS 10
#define SSBO_VCM_MERGE_KEYS 11
#define SSBO_VCM_MERGE_DATA 12
#define SSBO_VCM_GRID 13
#define SSBO_VCM_COUNTERS 14
#define SSBO_VCM_MERGE_SORT 15
// the camera pass's light vertex cache, in the light pass's merge sort block
#define SSBO_VCM_CACHE 15

// ---- texture units ----------------------------------------------------------------------
// the BVH (geometry/bvh_layout.glsl; unit 3 is reserved for geometry)
#define TEX_BVH_NODES 0
#define TEX_BVH_TRIANGLES 1
#define TEX_BVH_INSTANCES 2
#define TEX_GEOMETRY_RESERVED 3
// per-triangle shading data (geometry/bvh_layout.glsl), environment and surface
// textures (scene/layout.glsl)
#define TEX_TRI_NORMALS 4
#define TEX_TRI_UVS 5
#define TEX_TRI_INFO 6
#define TEX_ENVMAP 7
#define TEX_TEXTURES 8
#define TEX_TEXTURE_RECORDS 9
// the coating tables of per-texel rough plastic (scene/layout.glsl)
#define TEX_MICROFACET_TABLES 10
// photon mapping's maps and their hash tables (photon/map_layout.glsl)
#define TEX_GLOBAL_MAP 11
#define TEX_CAUSTIC_MAP 12
#define TEX_GLOBAL_CELLS 13
#define TEX_CAUSTIC_CELLS 14
// the grids of heterogeneous media (scene/layout.glsl)
#define TEX_MEDIA_GRIDS 15
// the further parts of the BVH and per-triangle data past one buffer texture's limit
// (geometry/bvh_layout.glsl): each kind's from its unit up to the next one's, the last up
// to the device's GL_MAX_COMPUTE_TEXTURE_IMAGE_UNITS
#define TEX_BVH_NODES_MORE 16
#define TEX_BVH_TRIANGLES_MORE 19
#define TEX_TRI_NORMALS_MORE 23
#define TEX_TRI_UVS_MORE 27
#define TEX_TRI_INFO_MORE 30

// ---- flag bits --------------------------------------------------------------------------
// MaterialData.info.y
const uint kMaterialFlagTwoSided = 1u;
const uint kMaterialFlagGgx = 2u;
const uint kMaterialFlagNonlinear = 4u;
const uint kMaterialFlagNormalShadowing = 8u;   // the normal map's shadowing term (bsdf/bsdf.glsl)
const uint kMaterialFlagNormalFlip = 16u;       // the normal map's flip of invalid normals
const uint kMaterialFlagAlphaTable = 32u;       // roughplastic reads the coating table over alpha
// MaterialData.info.y bits 16-23 and 24-31: the interior and exterior medium + 1 of the
// shape the material record is for (0: none; the shape bounds no medium on that side)
const uint kMaterialInteriorShift = 16u;
const uint kMaterialExteriorShift = 24u;
// MediumData.info.z
const uint kMediumFlagSampleEmitters = 1u;   // next-event estimation from the medium's points
const uint kMediumFlagNearest = 2u;          // its grids' lookups take the nearest voxel
// LightData.info.y
const uint kLightFlagTwoSided = 1u;
const uint kLightFlagRectangle = 2u;   // a parallelogram with orthogonal edges (spherical rectangle)
