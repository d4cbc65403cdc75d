// Every binding of the render kernels and the structs behind them: the device side
// of the host/device contract. glrender/gpu/layout.py mirrors it field by field
// (numpy dtypes, binding numbers); tests/gpu/test_layout.py checks that they agree
// on the device. Nothing else declares a binding.
//
// Binding spaces are separate in GL: uniform blocks, storage blocks and texture
// units each count from 0; their numbers are named in common/bindings.glsl.
#include "common/bindings.glsl"

// ---- uniform block 0: per-dispatch parameters (std140) -------------------------
layout(std140, binding = UBO_RENDER_PARAMS) uniform RenderParams {
    mat4 camera_open;      // world_from_camera at shutter open (Mitsuba camera frame: +z forward, +x left)
    mat4 camera_close;     // world_from_camera at shutter close
    vec4 camera_screen;    // x, y: half the film's extent along camera x, y (perspective: on the plane z = 1, tan(fov / 2);
                           // orthographic: in camera units), z: lens radius, w: focus distance
    vec4 camera_clip;      // x: near clip, y: far clip
    vec4 shutter;          // x: open, y: close, z: shutter function (0 box, 1 tent), w: the uniform number
                           // whose shutter time every sample of the pass takes (GLRENDER_SHARED_TIME)
    vec4 filter_params;    // x: radius in pixels, y: gaussian stddev, z: Mitchell B, w: Mitchell C
    uvec4 image;           // x: width, y: height, z: tiles along x, w: tile rows in the accumulation
    uvec4 samples;         // x: first sample index, y: samples per pixel this pass, z: spp of one randomization, w: strata columns
    uvec4 dispatch;        // x: first tile (permuted order), y: tiles in this dispatch, z: seed, w: tile permutation seed
    uvec4 counts;          // x: lights, y: materials, z: environment light index + 1 (0: none), w: first tile row in the accumulation
    vec4 scene_sphere;     // bounding sphere of the scene: centre xyz, radius w
    float ao_distance;     // the ambient-occlusion integrator's reach
    float sample_clamp;    // a sample's largest RGB component is scaled down to it (0: off)
    uint camera_projection;  // kCameraPerspective or kCameraOrthographic (camera/camera.glsl)
    float unused;
} u_params;

// ---- uniform block 2: participating media (std140; media/medium.glsl reads them) ------
// Scenes whose shapes or camera name media (GLRENDER_MEDIA); a material record of a shape
// that bounds media names them in MaterialData.info.y (kMaterialInteriorShift).
const int kMaxMedia = 64;    // glrender/gpu/layout.py MAX_MEDIA
const uint kSupervoxel = 8u;   // voxels along a side of a supervoxel (layout.py SUPERVOXEL)
struct MediumData {
    vec4 sigma_t;   // xyz: extinction per unit length (scale applied; heterogeneous: the scale,
                    // which multiplies the grid's values), w: the phase function's g
    vec4 sigma_s;   // xyz: scattering coefficient (albedo times sigma_t; heterogeneous: the
                    // constant albedo, when there is no albedo grid), w: -
    uvec4 info;     // x: kind (kMedium*), y: phase function (kPhase*), z: flags (kMediumFlag*), w: -
    mat4 grid_from_world;   // heterogeneous: world to the grids' unit cube
    uvec4 sigma_grid;       // heterogeneous: x the sigma_t grid's first texel in u_media_grids, yzw its voxels along x, y, z
    uvec4 albedo_grid;      // x: the albedo grid's first texel + 1 (0: constant albedo), yzw: its voxels
    vec4 majorant;          // x: heterogeneous: a bound on sigma_t over the grid, every channel (scale applied),
                            // y: the mean extinction (over channels and voxels) that the MIS weights of
                            // bidirectional strategies assume (media/medium.glsl medium_mis_transmittance)
    uvec4 majorant_grid;    // heterogeneous: x the first texel of its supervoxels' bounds (one texel each,
                            // in .r), yzw the supervoxels along x, y, z (kSupervoxel voxels a side)
};
layout(std140, binding = UBO_MEDIA) uniform Media {
    uvec4 media_counts;    // x: media, y: the camera's medium + 1 (0: none)
    MediumData media[kMaxMedia];
} u_media;

// ---- storage blocks (std430) ---------------------------------------------------
// 0, 1: accumulation per pixel, exact 128-bit fixed-point sums (film/accum.glsl):
//   accum_sum[4 i + c] = sum of channel c (r, g, b) of the finite samples, c < 3;
//   accum_sum[4 i + 3] = (count of finite samples, count of dropped samples, 0, 0)
//   accum_sq[3 i + c]  = sum of the squares of channel c
layout(std430, binding = SSBO_ACCUM_SUM) buffer AccumSum { uvec4 accum_sum[]; };
layout(std430, binding = SSBO_ACCUM_SQ) buffer AccumSq { uvec4 accum_sq[]; };

// 2: materials. kind: see kMaterial* in bsdf/bsdf.glsl.
struct MaterialData {
    vec3 color0;            // diffuse reflectance (diffuse, plastics) | conductor eta | specular reflectance (dielectrics) | base colour (metallicroughness)
    float opacity_texture;  // the opacity texture + 1 (0: none; alpha cutouts)
    vec3 color1;            // specular reflectance (conductors, plastics) | specular transmittance (dielectrics) | (-, roughness, metallic) (metallicroughness)
    float alpha_cutoff;     // an opacity below it is a hole
    vec3 color2;            // conductor k (rgb) | plastic, roughplastic, metallicroughness: x specular sampling weight, y internal reflectance
    float normal_scale;     // the normal map's strength (scales its x and y)
    vec3 params;            // x: alpha u, y: alpha v, z: relative IOR int/ext
    float normal_map;       // the normal map texture + 1 (0: none)
    uvec4 info;             // x: kind, y: flags (kMaterialFlag*), z: color0 texture + 1 (0: none), w: color1 texture + 1
    float table[64];        // roughplastic: the coating's transmittance T(cos theta) at cos theta = i / 63
};
layout(std430, binding = SSBO_MATERIALS) readonly buffer Materials { MaterialData materials[]; };

// The members of a MaterialData that every kind reads (all but the table). The
// generated scene code returns it from scene_material(index): constants for scenes
// with few materials, the Materials buffer otherwise.
struct MaterialHeader {
    vec3 color0;
    float opacity_texture;
    vec3 color1;
    float alpha_cutoff;
    vec3 color2;
    float normal_scale;
    vec3 params;
    float normal_map;
    uvec4 info;
};

// 3: lights. kind: see kLight* in lights/light.glsl.
struct LightData {
    vec4 p;         // corner (parallelogram), vertex 0 (triangle), centre (sphere, disk), position (point, spot)
    vec4 e1;        // edge 1 | disk/spot frame x axis; w: sphere / disk radius
    vec4 e2;        // edge 2 | disk/spot frame y axis
    vec4 n;         // unit normal (area) | spot axis | direction (directional); w: area
    vec4 radiance;  // radiance (area, environment), intensity (point, spot), irradiance (directional)
    vec3 params;    // spot: x cos(cutoff), y cos(beam width); environment: x scale
    float selection_pmf;  // the probability that light selection picks it (lights/light_selection.glsl)
    uvec4 info;     // x: kind, y: flags (kLightFlag*), z: primitive id, w: distribution offset
    // Textured emission (parallelograms, triangles): the point p + a e1 + b e2 has the
    // surface uv uv0 + a uv_e1 + b uv_e2, and its radiance is `radiance` times the
    // emission texture there (lights/light.glsl area_light_radiance).
    vec2 uv0;
    vec2 uv_e1;
    vec2 uv_e2;
    float emission_texture;  // the emission texture + 1 (0: none, uniform radiance)
    float pad;
};
layout(std430, binding = SSBO_LIGHTS) readonly buffer Lights { LightData lights[]; };

// 4: packed distributions (light selection alias table, environment map 2D distribution,
// light tree), as 16-byte elements: the light tree reads its nodes 4 elements at a time.
layout(std430, binding = SSBO_DISTRIBUTIONS) readonly buffer Distributions { uvec4 distribution_data[]; };

// 5: first-hit AOVs per pixel, sums over the finite samples as accum_sum's (kAovChannels
//   per pixel, glrender/render/accum.py AOV_CHANNELS): albedo r, g, b, shading normal
//   x, y, z, depth, seen emission r, g, b.
layout(std430, binding = SSBO_ACCUM_AOV) buffer AccumAov { uvec4 accum_aov[]; };
const uint kAovChannels = 10u;

// 6: debug counters per pixel (loop iterations of the worst sample) when enabled.
layout(std430, binding = SSBO_DEBUG_COUNTERS) buffer DebugCounters { uint debug_counters[]; };

// 7: splatted contributions (light tracing, BDPT's t = 1 strategies) for the whole image:
//   per pixel and channel a signed 64-bit fixed-point sum (kSplatScale units) as two
//   words, low then high; integer atomics make the sum independent of the order of
//   the splats (integrators/splat.glsl).
layout(std430, binding = SSBO_ACCUM_SPLAT) buffer AccumSplat { uint accum_splat[]; };

// ---- texture units ---------------------------------------------------------------
// 0-6 and 16-31: BVH nodes and triangles and the triangles' shading data, in BVH order
// (geometry/bvh_layout.glsl).
// 7: environment map (lat-long, linear RGB).
layout(binding = TEX_ENVMAP) uniform sampler2D u_envmap;
// 8: surface textures: one layer per bitmap, each in the corner [0, w) x [0, h) of
// layers as large as the largest (glrender/gpu/textures.py; read by bsdf/texture.glsl).
layout(binding = TEX_TEXTURES) uniform sampler2DArray u_textures;
// 9: texture records, 5 texels each (kind, layer, size; uv transform, filter, wrap; colours).
layout(binding = TEX_TEXTURE_RECORDS) uniform samplerBuffer u_texture_records;
// 10: the coating of per-texel rough plastic (metallic-roughness materials): rows over
// sqrt(alpha), each T(cos theta) at 64 cosines and R_int (glrender/gpu/microfacet_tables.py
// alpha_table; read by bsdf/roughplastic.glsl). Bound only for scenes that use it.
layout(binding = TEX_MICROFACET_TABLES) uniform samplerBuffer u_microfacet_tables;
// 15: the voxels of heterogeneous media's grids, one RGBA32F texel each (x fastest, then y,
// z; a one-channel grid repeats its value in rgb), at MediumData's sigma_grid / albedo_grid.
layout(binding = TEX_MEDIA_GRIDS) uniform samplerBuffer u_media_grids;

// The packed distribution array for sampling/distribution_data.glsl's prototype, and 4
// elements from a multiple of 4 for lights/light_tree.glsl's.
float distribution_fetch(uint i) {
    return uintBitsToFloat(distribution_data[i >> 2u][i & 3u]);
}

uvec4 distribution_fetch4(uint i) {
    return distribution_data[i >> 2u];
}
