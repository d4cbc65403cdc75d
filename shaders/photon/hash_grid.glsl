// A uniform grid over the visible points, stored as a hash table of cells
// (Teschner et al. 2003's spatial hash): the host builds it (glrender/photon/grid.py)
// with the same hash, each visible point listed in every cell its search sphere
// overlaps; a photon looks up the one cell it lies in.
#include "photon/layout.glsl"
#include "common/hash.glsl"

// The grid cell holding world point p; false outside the grid (no visible point's
// sphere reaches p there) or when there is no grid.
bool grid_cell_of(vec3 p, out uvec3 cell) {
    cell = uvec3(0u);
    if (u_photon.grid_size.w == 0u) return false;
    vec3 rel = (p - u_photon.grid_lo.xyz) / u_photon.grid_lo.w;
    if (any(lessThan(rel, vec3(0.0))) || any(greaterThanEqual(rel, vec3(u_photon.grid_size.xyz))))
        return false;
    cell = min(uvec3(rel), u_photon.grid_size.xyz - 1u);
    return true;
}

// The range [begin, end) of grid_cells holding the pixel indices listed under cell's hash
// (other cells with the same hash included: the gather checks distances).
uvec2 grid_cell_range(uvec3 cell) {
    uint h = grid_hash(cell) % u_photon.grid_size.w;
    return uvec2(grid_cells[h], grid_cells[h + 1u]);
}
