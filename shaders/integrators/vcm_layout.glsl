// Bindings of vertex connection and merging's two kernels: the light pass
// (kernels/vcm_light.comp.glsl) stores light subpaths and their merge points, the camera
// pass (the render kernel with integrators/vcm.glsl) connects to them and merges with
// them. The device side of their host/device contract, mirrored by glrender/vcm/layout.py.
// Beside the render kernels' bindings (scene/layout.glsl: uniform block 0, storage blocks
// 0-7; bdpt's strategy images: 8), named in common/bindings.glsl.
#include "common/bindings.glsl"
#include "common/hash.glsl"

// ---- uniform block 1: one iteration's parameters (std140) -----------------------------
layout(std140, binding = UBO_VCM_PARAMS) uniform VcmParams {
    uvec4 paths;       // x: light paths of the iteration, y: vertex capacity, z: merge point
                       // capacity, w: splat the lens connections (1; 0 when an iteration whose
                       // buffers overflowed is traced again)
    uvec4 grid_size;   // the merge points' grid: xyz 0 (unbounded: grid_buckets), w: hash table
                       // size (the merge point capacity; 0 in the camera pass: no merge points)
    vec4 grid_lo;      // xyz: corner of cell (0, 0, 0), w: cell edge (twice the radius at least)
    vec4 merge;        // x: radius, y: radius^2, z: eta = pi r^2 (light paths), the merges' density
                       // factor in the MIS weights, w: 1 / eta, the merge's kernel normalisation
    vec4 lens;         // x: (light paths) / (W H), the lens connections' density factor, y: its
                       // inverse, each splat's weight (the film counts W H light paths)
    uvec4 cache;       // x: the light vertex cache's entries (the camera pass's, with
                       // kVcmCacheConnections > 0), yzw: 0
} u_vcm;

// ---- storage blocks (std430) ----------------------------------------------------------
// 9: the light subpaths' vertices, kVcmVertexTexels records each (integrators/vcm.glsl
// vcm_store_vertex: position, normals, frame, throughput, densities, suffix sum), each
// path's vertices one after another from its first slot.
layout(std430, binding = SSBO_VCM_VERTICES) buffer VcmVertices { vec4 vcm_vertices[]; };

// 10: per light path: (first vertex slot, vertex count).
layout(std430, binding = SSBO_VCM_PATHS) buffer VcmPaths { uvec2 vcm_paths[]; };

// 11: merge points' positions. The light pass appends them in any order: (position xyz,
// key as uint bits: light path index * 32 + vertex index, the canonical order the host
// sorts them by); the camera pass reads them in the grid's order: (position xyz, the merge
// point's index into 12 as uint bits).
layout(std430, binding = SSBO_VCM_MERGE_KEYS) buffer VcmMergeKeys { vec4 vcm_merge_keys[]; };

// 12: what a merge needs of a merge point, kVcmMergeTexels records each (vcm_store_merge).
layout(std430, binding = SSBO_VCM_MERGE_DATA) buffer VcmMergeData { vec4 vcm_merge_data[]; };

// 13: the merge points' grid: vcm_grid[h] .. vcm_grid[h + 1] are the positions in 11
// (grid-ordered) of the merge points under hash h, for each hash h < table size.
layout(std430, binding = SSBO_VCM_GRID) readonly buffer VcmGrid { uint vcm_grid[]; };

// 14: counters: [0] vertices stored, [1] merge points stored, [2] merge candidates skipped
// by the bound, [3] merge candidates visited.
layout(std430, binding = SSBO_VCM_COUNTERS) buffer VcmCounters { uint vcm_counters[]; };

// 15: per merge point as the light pass stored it: (key, as in 11; its grid cell's hash
// < grid_size.w). The host orders the merge points by key, then stably by hash (two
// integer sorts), and kernels/vcm_order.comp.glsl writes 11's grid-ordered copy.
// In the camera pass with a light vertex cache the same binding (SSBO_VCM_CACHE) holds the
// cache, two entries to a record (vcm_cache_entry): the slot in 9 of every stored light
// vertex past the light (u_vcm.cache.x of them), light path by light path in the order of
// their indices, each path's vertices in order (glrender/vcm/vcm.py writes them). One
// block for both: a kernel has 16 storage blocks, and every block that any function of it
// names counts, called or not.
layout(std430, binding = SSBO_VCM_MERGE_SORT) buffer VcmMergeSort { uvec2 vcm_merge_sort[]; };

uint vcm_cache_entry(uint e) {
    return vcm_merge_sort[e >> 1u][e & 1u];
}

// The grid cell of world point p (the merge grid of u_vcm: fixed before the light pass,
// cells of edge grid_lo.w from the corner grid_lo.xyz of a box around the scene's bounding
// sphere, unbounded: merge points in a medium around the scene lie beyond that box).
ivec3 vcm_grid_cell(vec3 p) {
    return ivec3(floor((p - u_vcm.grid_lo.xyz) / u_vcm.grid_lo.w));
}

// A grid cell's bucket in the table of grid_size.w entries.
uint vcm_grid_hash(ivec3 c) {
    return grid_hash(uvec3(c)) % u_vcm.grid_size.w;
}
