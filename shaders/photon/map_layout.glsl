// Bindings of the photon integrator (integrators/photon.glsl) and its photon tracing
// kernel (photon/photon_store.comp.glsl): the device side of their host/device contract,
// mirrored by glrender/photon/layout.py. Beside the render kernels' bindings
// (scene/layout.glsl: uniform block 0, storage blocks 0-7), named in common/bindings.glsl.
#include "common/bindings.glsl"
// ---- uniform block 1: the photon maps' parameters (std140) ----------------------------
layout(std140, binding = UBO_PHOTON_MAP_PARAMS) uniform PhotonMapParams {
    uvec4 trace;          // x: first photon of this dispatch, y: photons in it, z: photons of the pass,
                          // w: the map traced (0 global, 1 caustic)
    uvec4 store;          // x: capacity of the map being stored (photons), y: max depth (segments),
                          // z: photon-map view (1), w: the first photon it splats (those
                          // before were splatted by an earlier dispatch that overflowed)
    uvec4 global_size;    // global map's grid: xyz cells along each axis, w: hash table size (0: empty)
    vec4 global_lo;       // xyz: corner of cell (0, 0, 0), w: cell edge
    uvec4 caustic_size;   // the caustic map's grid, the same way
    vec4 caustic_lo;
    vec4 radius;          // x, y: lookup radius of the global and caustic maps (the kNN search's
                          // largest), z, w: 1 / photons emitted for each map
    uvec4 mode;           // x: density kernel, y: k nearest neighbours (0: fixed radius),
                          // z: final gather (1), w: direct light from the photons (1) or NEE (0)
    // volume photons (kMedia): each map's own grid over them, the same way
    uvec4 global_volume_size;
    vec4 global_volume_lo;
    uvec4 caustic_volume_size;
    vec4 caustic_volume_lo;
    vec4 volume_radius;   // x, y: lookup radius of the global and caustic maps' volume photons
    uvec4 volume_table;   // x, y: the first entry of the global and caustic maps' volume grids'
                          // hash tables in their cells textures (after the surface grid's)
} u_map;

// The global and caustic maps' photons in their grid's order, 3 texels each, in buffer
// textures (random reads from a buffer texture are faster than from a storage block on
// llvmpipe, and one holds 44M photons there, GL_MAX_TEXTURE_BUFFER_SIZE / 3):
//   [3 k] = (position xyz, type as uint bits: 0 direct, 1 caustic, 2 indirect),
//   [3 k + 1] = (unit direction back toward where it came from xyz, geometric normal
//   as packSnorm4x8 bits), [3 k + 2] = (power rgb, path segments from the light)
// and their grids' hash tables: cells[h] .. cells[h + 1] are the photons under hash h
// (glrender/photon/grid.py build_point_grid). Texture units 10-13.
// Volume photons (kMedia: photons at scattering events in media) follow a map's surface
// photons in the same texture, types kPhotonVolume + (0 direct, 1 caustic, 2 indirect),
// their medium's index (int bits) in place of the normal and their power over sigma_s
// (media/medium.glsl medium_over_sigma_s); their grid's hash table follows the
// surface grid's (u_map.volume_table) and its entries count from the first photon.
layout(binding = TEX_GLOBAL_MAP) uniform samplerBuffer u_global_map;
layout(binding = TEX_CAUSTIC_MAP) uniform samplerBuffer u_caustic_map;
layout(binding = TEX_GLOBAL_CELLS) uniform usamplerBuffer u_global_cells;
layout(binding = TEX_CAUSTIC_CELLS) uniform usamplerBuffer u_caustic_cells;
// 8: the tracing kernel's photons, the same 3 records each, in the order stored.
layout(std430, binding = SSBO_TRACED_PHOTONS) buffer TracedPhotons { vec4 traced_photons[]; };

// Record k of the global (map 0) or caustic (map 1) map.
vec4 map_record(uint map, uint k) {
    if (map == 0u) return texelFetch(u_global_map, int(k));
    return texelFetch(u_caustic_map, int(k));
}

// Entry h of the global (map 0) or caustic (map 1) map's hash table.
uint map_cell(uint map, uint h) {
    if (map == 0u) return texelFetch(u_global_cells, int(h)).x;
    return texelFetch(u_caustic_cells, int(h)).x;
}

// 12: counters: [0] photons stored (the tracing kernel), [1] lookup candidates skipped by
// the bound, [2] candidates visited, [3] the most visited by one lookup.
layout(std430, binding = SSBO_MAP_COUNTERS) buffer PhotonMapCounters { uint map_counters[]; };

const uint kPhotonDirect = 0u;     // the first surface a photon reaches (NEE's light)
const uint kPhotonCaustic = 1u;    // reached through delta surfaces only: L S+ D
const uint kPhotonIndirect = 2u;   // after at least one non-delta surface
const uint kPhotonVolume = 3u;     // added to the type of a photon at a scattering event in a medium
