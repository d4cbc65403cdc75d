// The photon integrator's density estimate: radiance leaving a surface point toward wo
// from the photons of a map around it (Jensen 2001, ch. 7),
//     L = 1 / (pi r^2) sum_p K(d_p / r) f(wo, wi_p) Phi_p,
// with Phi_p = beta_p / (photons emitted) and K a kernel of mean 1 over the disk
// (photon/density.glsl). Either a fixed radius r, or the k nearest photons within the
// map's largest radius (r: the k-th's distance; the largest radius and all photons
// found when fewer lie within it).
//
// The map's grid has cells of twice the largest radius, each photon listed once in its
// cell (glrender/photon/grid.py build_point_grid): the lookup visits the 2 x 2 x 2
// cells around the point, each hash bucket once, and at most kRadiusCandidates
// (kKnnCandidates for kNN, whose max-heap adds up to log2 k steps a candidate) entries
// in all, far below llvmpipe's silent ~65,535-iteration cap; skipped entries are
// counted (map_counters[1]).
//
// Surface density estimation: photons count only within a disk, |n . (x_p - x)| below
// kDiscThickness r, with geometric normals that agree (kNormalAgreement), so a photon
// across a thin wall or on the other wall of a corner does not leak in.
//
// Volume density estimation (kMedia, at a camera path's scattering event x in medium m):
// the in-scattered radiance toward wo from the volume photons of the same medium in the
// ball of radius r around x (their own grid and radius),
//     L_s = 1 / ((4/3) pi r^3) sum_p K3(d_p / r) p(wo, wi_p) Phi_p / sigma_s(x_p),
// Phi_p / sigma_s as stored (media/medium.glsl medium_over_sigma_s): the photons
// are stored at scattering events only, whose density weighted by their power is
// sigma_s L_i, hence the division by sigma_s (not sigma_t). The camera path's throughput at
// its own event carries sigma_s T over the density it sampled x with, so beta L_s is that
// event's share of the pixel, as the path tracer's estimate (Jensen & Christensen 1998).
#include "photon/map_layout.glsl"
#include "photon/density.glsl"
#include "photon/grid_buckets.glsl"
#include "integrators/integrator_common.glsl"
#include "media/medium.glsl"

const uint kRadiusCandidates = 4096u;
const uint kKnnCandidates = 2048u;
const int kMaxKnn = 64;               // the largest k (glrender/photon/photon.py MAX_KNN)
const float kDiscThickness = 0.25;    // the disk's half thickness over its radius
const uint kGlobalMap = 0u;
const uint kCausticMap = 1u;

// What the lookup needs of a surface point: position, geometric normal, BSDF and the
// outgoing direction in its shading frame; of a point in a medium (kMedia): position, its
// medium and wo_l the world direction toward the camera (ng 0).
struct GatherPoint {
    vec3 p;
    vec3 ng;
    Bsdf b;
    Frame frame;
    vec3 wo_l;
    int medium;      // kNoMedium: a surface point
};

// Whether photon k of `map` counts at point g within squared radius r2 (disk, normal,
// type in `types` (a bit per kPhoton* type), at most `segments` light segments): its
// squared distance in d2.
bool photon_candidate(uint map, uint k, GatherPoint g, float r2, uint types, float segments, out float d2) {
    vec4 a = map_record(map, k);
    d2 = 0.0;
    if ((types & (1u << floatBitsToUint(a.w))) == 0u) return false;
    vec3 dp = a.xyz - g.p;
    d2 = dot(dp, dp);
    if (d2 > r2) return false;
    if (kMedia && g.medium != kNoMedium)    // a volume photon (by its type) of the same medium
        return floatBitsToInt(map_record(map, k + 1u).w) == g.medium && map_record(map, k + 2u).w <= segments;
    float h = dot(dp, g.ng);
    if (h * h > kDiscThickness * kDiscThickness * r2) return false;
    vec4 b = map_record(map, k + 1u);
    if (dot(unpackSnorm4x8(floatBitsToUint(b.w)).xyz, g.ng) < kNormalAgreement) return false;
    return map_record(map, k + 2u).w <= segments;
}

// The photon's contribution (kernel weight w) at g: f Phi w.
vec3 photon_term(uint map, uint k, GatherPoint g, float w) {
    if (kMedia && g.medium != kNoMedium)
        return medium_phase(g.medium, -g.wo_l, map_record(map, k + 1u).xyz) * map_record(map, k + 2u).rgb * w;
    vec3 f;
    if (!photon_bsdf(g.b, g.frame, g.wo_l, g.ng, map_record(map, k + 1u).xyz, f)) return vec3(0.0);
    return f * map_record(map, k + 2u).rgb * w;
}

// The kernel weight at squared distance q2 of the radius (a ball's for volume photons).
float gather_kernel(bool volume, float q2) {
    return volume ? density_kernel_3d(u_map.mode.x, q2) : density_kernel(u_map.mode.x, q2);
}

// The estimate from photons of `map` of the types in `types` that took at most
// `segments` segments from their light (at a point in a medium: its volume photons of
// those types).
vec3 photon_estimate(uint map, GatherPoint g, uint types, int segments) {
    uint buckets[8];
    bool volume = kMedia && g.medium != kNoMedium;
    uint table = 0u;   // the first entry of the grid's hash table in the cells texture
    float r_max = map == kGlobalMap ? u_map.radius.x : u_map.radius.y;
    if (volume) {
        types <<= kPhotonVolume;
        grid_buckets(g.p, map == kGlobalMap ? u_map.global_volume_lo : u_map.caustic_volume_lo,
                     map == kGlobalMap ? u_map.global_volume_size : u_map.caustic_volume_size, buckets);
        table = map == kGlobalMap ? u_map.volume_table.x : u_map.volume_table.y;
        r_max = map == kGlobalMap ? u_map.volume_radius.x : u_map.volume_radius.y;
    } else {
        grid_buckets(g.p, map == kGlobalMap ? u_map.global_lo : u_map.caustic_lo,
                     map == kGlobalMap ? u_map.global_size : u_map.caustic_size, buckets);
    }
    float inv_photons = map == kGlobalMap ? u_map.radius.z : u_map.radius.w;
    float r2 = r_max * r_max, seg = float(segments);
    uint knn = u_map.mode.y;
    uint budget = knn == 0u ? kRadiusCandidates : kKnnCandidates, visited = 0u, skipped = 0u;
    vec3 sum = vec3(0.0);
    float heap_d2[kMaxKnn];
    uint heap_k[kMaxKnn];
    uint found = 0u;
    for (int i = 0; i < 8; ++i) {
        if (buckets[i] == kNoBucket) continue;
        uint begin = map_cell(map, table + buckets[i]), end = map_cell(map, table + buckets[i] + 1u);
        uint visit = min(end - begin, budget - visited);
        skipped += end - begin - visit;
        for (uint e = begin; e < begin + visit; ++e) {
            LOOP_TICK();
            uint k = 3u * e;
            float d2;
            if (!photon_candidate(map, k, g, r2, types, seg, d2)) continue;
            if (knn == 0u) {
                sum += photon_term(map, k, g, gather_kernel(volume, d2 / r2));
                continue;
            }
            // a max-heap of the knn nearest by squared distance
            uint at;
            if (found < knn) {
                at = found++;
                while (at > 0u && heap_d2[(at - 1u) / 2u] < d2) {
                    LOOP_TICK();
                    heap_d2[at] = heap_d2[(at - 1u) / 2u];
                    heap_k[at] = heap_k[(at - 1u) / 2u];
                    at = (at - 1u) / 2u;
                }
            } else {
                if (d2 >= heap_d2[0]) continue;
                at = 0u;
                for (;;) {
                    LOOP_TICK();
                    uint c = 2u * at + 1u;
                    if (c >= knn) break;
                    if (c + 1u < knn && heap_d2[c + 1u] > heap_d2[c]) c += 1u;
                    if (heap_d2[c] <= d2) break;
                    heap_d2[at] = heap_d2[c];
                    heap_k[at] = heap_k[c];
                    at = c;
                }
            }
            heap_d2[at] = d2;
            heap_k[at] = k;
        }
        visited += visit;
    }
    if (knn != 0u) {
        // the k-th nearest sets the radius and is left out: (k - 1) / (pi r_k^2) is unbiased
        // for an even density (counting it too is k / (k - 1) too bright with the uniform kernel)
        uint first = 0u;
        if (found == knn) {
            r2 = heap_d2[0];
            first = 1u;
        }
        for (uint i = first; i < found; ++i) {
            LOOP_TICK();
            sum += photon_term(map, heap_k[i], g, gather_kernel(volume, heap_d2[i] / r2));
        }
    }
    if (skipped > 0u) atomicAdd(map_counters[1], skipped);
    if (visited > 0u) {
        atomicAdd(map_counters[2], visited);
        atomicMax(map_counters[3], visited);
    }
    if (!(r2 > 0.0)) return vec3(0.0);
    vec3 L = sum * inv_photons / (volume ? (4.0 / 3.0) * kPi * r2 * sqrt(r2) : kPi * r2);
    return is_finite(L) ? L : vec3(0.0);
}
