// Bindings of the photon kernels (photon tracing, SPPM camera and photon passes): the
// device side of their host/device contract, mirrored by glrender/photon/layout.py.
// They sit beside the render kernels' bindings (scene/layout.glsl, which owns uniform
// block 0 and storage blocks 0-7) in the numbers those leave free (common/bindings.glsl).
#include "common/bindings.glsl"

// ---- uniform block 1: per-dispatch photon parameters (std140) -----------------------
layout(std140, binding = UBO_PHOTON_PARAMS) uniform PhotonParams {
    uvec4 photons;        // x: first photon of this dispatch, y: photons in it, z: photons per iteration, w: iteration
    uvec4 grid_size;      // xyz: cells along each axis, w: hash table size (0: no grid)
    vec4 grid_lo;         // xyz: corner of cell (0, 0, 0), w: cell edge length
    uvec4 options;        // x: deposit from this photon segment on (2: skip direct light),
                          // y: camera segments allowed (max depth), z: record emission (1),
                          // w: splat the photon-map view into storage block 7 (1)
    uvec4 estimate;       // x: density kernel (kKernel*, photon/density.glsl), y: first pixel
                          // row of the camera pass's slice, z: its rows, w: unused
} u_photon;

// ---- storage blocks (std430) ----------------------------------------------------------
// 8: visible points' positions per pixel: xyz, w = camera segments to the point (0: none;
// kMedia: minus the camera segments for a point in a medium, whose records below hold
// (wo, the medium as int bits), zeros, zeros and (beta, 0)).
layout(std430, binding = SSBO_VP_POSITION) buffer VisiblePositions { vec4 vp_position[]; };

// 9: what the gather needs of each visible point, two records per pixel:
//   [2 i]     = (wo xyz toward the camera, material index as float bits)
//   [2 i + 1] = (shading normal xyz, uv.x); uv.y, geometric normal and beta follow in vp_extra
layout(std430, binding = SSBO_VP_SHADING) buffer VisibleShading { vec4 vp_shading[]; };
//   [2 i] = (geometric normal xyz, uv.y), [2 i + 1] = (beta rgb, the BSDF's n0: vp_pack_unit)
layout(std430, binding = SSBO_VP_EXTRA) buffer VisibleExtra { vec4 vp_extra[]; };

// A unit vector in one float: its octahedral map (Meyer et al. 2010) quantized to 11 bits
// per coordinate, stored as an integer below 2^22, exact in a float (about 1e-3 rad).
float vp_pack_unit(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    vec2 q = round(clamp(e * 0.5 + 0.5, 0.0, 1.0) * 2047.0);
    return q.x * 2048.0 + q.y;
}

vec3 vp_unpack_unit(float code) {
    float qx = floor(code / 2048.0);
    vec2 e = vec2(qx, code - qx * 2048.0) / 2047.0 * 2.0 - 1.0;
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

// 11: the camera pass's own radiance per pixel this iteration (emission seen through
// specular chains, direct light at the visible point): rgb, w unused.
layout(std430, binding = SSBO_VP_RADIANCE) buffer VisibleRadiance { vec4 vp_radiance[]; };

// 12: search radius squared per pixel (the host's SPPM state).
layout(std430, binding = SSBO_VP_RADIUS2) readonly buffer SearchRadius { float vp_radius2[]; };

// 13: the hash grid over the visible points: cell_offsets[h] .. cell_offsets[h + 1]
// index into grid_entries (pixel indices), for each hash h (glrender/photon/grid.py).
layout(std430, binding = SSBO_GRID_CELLS) readonly buffer GridCells { uint grid_cells[]; };

// 14: flux deposited this iteration per pixel: 4 floats (Phi rgb weighted by the
// visible point's beta, M: photons counted), float atomics.
layout(std430, binding = SSBO_DEPOSITS) buffer Deposits { float deposit_flux[]; };

// 15: counters and per-photon records: [0] candidates skipped by the gather's bound,
// [1] candidates visited, [2] largest number visited by one photon; from 4 on, when
// options.z records emission, per photon (beta rgb, light index) as 4 words.
layout(std430, binding = SSBO_PHOTON_RECORDS) buffer PhotonRecords { uint photon_records[]; };
