// Bindings of the photon integrator (integrators/photon.glsl) and its photon tracing
// kernel (photon/photon_store.comp.glsl): the device side of their host/device contract,
// mirrored by glrender/photon/layout.py. Beside the render kernels' bindings
// (scene/layout.glsl: uniform block 0, storage blocks 0-7).
// ---- uniform block 1: the photon maps' parameters (std140) ----------------------------
layout(std140, binding = 1) uniform PhotonMapParams {
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
    uvec4 pages;          // x, y: the global map's first record in its pages 1 and 2, z: the
                          // caustic map's in its page 1 (0xffffffff: no such page), w: -
} u_map;

// 8, 10: photons of the global and caustic maps in their grid's order, 3 records each
// (a map longer than one storage-block binding continues in pages 13, 14 and 15 below):
//   [3 k] = (position xyz, type as uint bits: 0 direct, 1 caustic, 2 indirect),
//   [3 k + 1] = (unit direction back toward where it came from xyz, geometric normal
//   as packSnorm4x8 bits), [3 k + 2] = (power rgb, path segments from the light)
// 9, 11: their grids' hash tables: cells[h] .. cells[h + 1] are the photons under hash h
// (glrender/photon/grid.py build_point_grid).
// The tracing kernel writes the map it traces through binding 8.
layout(std430, binding = 8) buffer GlobalPhotons { vec4 global_photons[]; };
layout(std430, binding = 9) readonly buffer GlobalCells { uint global_cells[]; };
layout(std430, binding = 10) readonly buffer CausticPhotons { vec4 caustic_photons[]; };
layout(std430, binding = 11) readonly buffer CausticCells { uint caustic_cells[]; };
// 13, 14: the global map's pages 1 and 2, 15: the caustic map's page 1; a map's records
// split at photon boundaries (glrender/photon/photon.py), read through map_record.
layout(std430, binding = 13) readonly buffer GlobalPhotons1 { vec4 global_photons_1[]; };
layout(std430, binding = 14) readonly buffer GlobalPhotons2 { vec4 global_photons_2[]; };
layout(std430, binding = 15) readonly buffer CausticPhotons1 { vec4 caustic_photons_1[]; };

// Record k of the global (map 0) or caustic (map 1) map, from the page holding it.
vec4 map_record(uint map, uint k) {
    if (map == 0u) {
        if (k < u_map.pages.x) return global_photons[k];
        if (k < u_map.pages.y) return global_photons_1[k - u_map.pages.x];
        return global_photons_2[k - u_map.pages.y];
    }
    if (k < u_map.pages.z) return caustic_photons[k];
    return caustic_photons_1[k - u_map.pages.z];
}

// 12: counters: [0] photons stored (the tracing kernel), [1] lookup candidates skipped by
// the bound, [2] candidates visited, [3] the most visited by one lookup.
layout(std430, binding = 12) buffer PhotonMapCounters { uint map_counters[]; };

const uint kPhotonDirect = 0u;     // the first surface a photon reaches (NEE's light)
const uint kPhotonCaustic = 1u;    // reached through delta surfaces only: L S+ D
const uint kPhotonIndirect = 2u;   // after at least one non-delta surface
