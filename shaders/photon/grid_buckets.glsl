// The lookup of a point grid (glrender/photon/grid.py build_point_grid: each point listed
// once, in its cell; cells of at least twice the lookup radius): the hash buckets of the
// 2 x 2 x 2 cells around a point, each bucket once. The photon integrator's maps
// (photon/photon_gather.glsl) and vcm's merge points (integrators/vcm.glsl) use it.
#include "common/hash.glsl"

const uint kNoBucket = 0xffffffffu;

// The buckets around p in the grid with corner lo.xyz, cell edge lo.w, size.xyz cells
// (0: unbounded, cells on every side of lo) and a table of size.w hashes (kNoBucket: a cell
// outside the grid, a bucket seen already, or no grid).
void grid_buckets(vec3 p, vec4 lo, uvec4 size, out uint buckets[8]) {
    ivec3 base = ivec3(floor((p - lo.xyz) / lo.w - 0.5));
    bool bounded = size.x != 0u;
    for (int i = 0; i < 8; ++i) {
        ivec3 c = base + ivec3(i & 1, (i >> 1) & 1, i >> 2);
        buckets[i] = kNoBucket;
        if (size.w == 0u ||
            (bounded && (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(size.xyz))))))
            continue;
        uint h = grid_hash(uvec3(c)) % size.w;
        for (int j = 0; j < i; ++j)
            if (buckets[j] == h) h = kNoBucket;
        buckets[i] = h;
    }
}
