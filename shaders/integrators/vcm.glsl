// Vertex connection and merging (Georgiev, Křivánek, Davidovič and Slusallek 2012): the
// camera pass of one iteration. Each iteration a light pass (kernels/vcm_light.comp.glsl)
// traces one light subpath per pixel, splats its lens connections (t = 1) and stores its
// vertices and merge points, each with its cell's hash in a grid of cell 2r; the host
// orders them by cell (glrender/vcm/vcm.py) and kernels/vcm_order.comp.glsl copies them
// in that order. Here each pixel's camera subpath takes every strategy of
// bdpt (integrators/bidir.glsl: s = 0, next-event estimation, connections to the light
// subpath of the same index) and merges at each of its non-delta surface vertices with
// the light vertices within the iteration's radius r:
//     L_merge = beta_camera f(wo, wi_light) beta_light / (pi r^2 N),
// N the iteration's light paths, and at each of its scattering events in a medium with the
// light subpaths' scattering events in the same medium within the ball of radius r:
//     L_merge = beta_camera p(wo, wi_light) beta_light / (sigma_s(x_light) (4/3) pi r^3 N)
// (both subpaths' throughputs carry a scattering coefficient at the merged vertex, the
// path one). Connections and merges share one MIS weight
// (integrators/bdpt_vertex.glsl VM_TERM: a merge's density is a connection's times
// p eta, eta = pi r^2 N on surfaces), each O(1) from the subpaths' suffix sums and the quantities the
// light pass stored with each merge point (vcm_merge_weight). kVcmMode 2 keeps the merges
// and s = 0 alone (progressive photon mapping under the same weights).
//
// A light path and the camera subpath it connects to share a shutter time (the light
// pass takes the camera sample's); scenes with moving geometry are refused (merges would
// join light vertices of other times).
#include "integrators/bidir.glsl"
#include "photon/density.glsl"
#include "photon/grid_buckets.glsl"

// records per stored light vertex (96 or 112 bytes: the seventh keeps the unperturbed normal
// of a normal map's shadowing term and the MIS transmittance of media)
const int kVcmVertexTexels = GLRENDER_NORMAL_SHADOWING != 0 || GLRENDER_MEDIA != 0 ? 7 : 6;
const int kVcmMergeTexels = 4;      // records per merge point (64 bytes, and 16 of its key)
const uint kVcmMergeCandidates = 1024u;   // merge candidates visited per camera vertex at most
const uint kVcmLightSeed = 0x2f6b8e13u;   // the light pass's sampler stream: the seed xor this
const float kDiscThickness = 0.25;        // a merge disk's half thickness over its radius

// The light path that the camera samples of `pixel` connect to: its index in the image,
// modulo the light paths (fewer light paths than pixels: several pixels share one).
uint vcm_light_path_of(uvec2 pixel) {
    return (pixel.y * u_params.image.x + pixel.x) % u_vcm.paths.x;
}

// Stored light vertex `slot`: vertex i of a light subpath (delta_light: that subpath starts
// on a delta light), and its suffix sum (g_light_mis).
void vcm_store_vertex(uint slot, Vertex v, float mis, int i, bool delta_light) {
    uint k = uint(kVcmVertexTexels) * slot;
    vcm_vertices[k] = vec4(v.p, uintBitsToFloat(v.material));
    vcm_vertices[k + 1u] = vec4(v.ng, uintBitsToFloat(v.info));
    vcm_vertices[k + 2u] = vec4(v.ns, v.pdf_fwd);
    vcm_vertices[k + 3u] = vec4(v.tangent, v.pdf_rev);
    vcm_vertices[k + 4u] = vec4(v.beta, mis);
    vcm_vertices[k + 5u] = vec4(v.uv, float(i), delta_light ? 1.0 : 0.0);
#if GLRENDER_NORMAL_SHADOWING || GLRENDER_MEDIA
    vcm_vertices[k + 6u] = vec4(vertex_ns0(v), vertex_tr_mis(v));
#endif
}

Vertex vcm_load_vertex(uint slot, out float mis) {
    uint k = uint(kVcmVertexTexels) * slot;
    vec4 a = vcm_vertices[k], b = vcm_vertices[k + 1u], c = vcm_vertices[k + 2u],
         d = vcm_vertices[k + 3u], e = vcm_vertices[k + 4u], f = vcm_vertices[k + 5u];
    mis = e.w;
#if GLRENDER_NORMAL_SHADOWING || GLRENDER_MEDIA
    vec4 g = vcm_vertices[k + 6u];
#endif
    return Vertex(a.xyz, b.xyz, c.xyz, VERTEX_NS0(g.xyz) d.xyz, e.xyz, f.xy, floatBitsToUint(a.w),
                  floatBitsToUint(b.w), c.w, d.w VERTEX_TR(g.w));
}

// What a merge with light vertex q needs of the subpath behind it, stored by the light
// pass with the merge point (glrender/vcm/layout.py MERGE_DATA):
//   wi: the unit direction toward x_{q-1}; pdf_fwd: x_q's area density from its subpath;
//   beta: the subpath's throughput at x_q; g: the factor from a solid-angle density at
//   x_q toward x_{q-1} to an area density at x_{q-1} (|cos| / d^2; 1 / d^2 off surfaces,
//   1 at infinity); a: the light side's sum of ratios beyond x_{q-1} over
//   (p_fwd(x_{q-1}))^e; ref: 1 when the connection of x_{q-1} to the camera vertex is a
//   strategy (x_{q-1} not delta, connections on), else 0; segments: q; info: x_q's info
//   word (its kind, a surface or a medium vertex, and its medium).
// A merge point in a medium (kMedia) has ng = 0 and its throughput over sigma_s(x_q)
// (media/medium.glsl medium_over_sigma_s).
struct MergePoint {
    vec3 p;
    vec3 wi;
    float pdf_fwd;
    vec3 beta;
    float g;
    vec3 ng;
    float a;
    float ref;
    int segments;
    uint info;
};

void vcm_store_merge(uint index, MergePoint m, uint key) {
    vcm_merge_keys[index] = vec4(m.p, uintBitsToFloat(key));
    uint k = uint(kVcmMergeTexels) * index;
    vcm_merge_data[k] = vec4(m.wi, m.pdf_fwd);
    vcm_merge_data[k + 1u] = vec4(m.beta, m.g);
    vcm_merge_data[k + 2u] = vec4(m.ng, m.a);
    vcm_merge_data[k + 3u] = vec4(m.ref, float(m.segments), uintBitsToFloat(m.info), 0.0);
}

// Merge point `index` at position p (the camera pass reads positions in the grid's order).
MergePoint vcm_load_merge(uint index, vec3 p) {
    uint k = uint(kVcmMergeTexels) * index;
    vec4 a = vcm_merge_data[k], b = vcm_merge_data[k + 1u], c = vcm_merge_data[k + 2u],
         d = vcm_merge_data[k + 3u];
    return MergePoint(p, a.xyz, a.w, b.xyz, b.w, c.xyz, c.w, d.x, int(d.y), floatBitsToUint(d.z));
}

// The merge point of light vertex q >= 1 (mergeable) of the subpath in g_light, after
// bdpt_mis_prepare_light.
MergePoint vcm_merge_point(int q) {
    MergePoint m;
    Vertex x = g_light[q];
    Vertex prev = light_point(q - 1);
    m.p = x.p;
    m.ng = x.ng;
    m.beta = x.beta;
    m.pdf_fwd = x.pdf_fwd;
    m.segments = q;
    m.info = x.info;
#if GLRENDER_MEDIA
    if (vertex_kind(x) == kVertexMedium) m.beta = medium_over_sigma_s(vertex_medium(x), x.p, x.beta);
#endif
    vec3 w = prev.p - x.p;
    float d2 = dot(w, w);
    m.wi = w * inversesqrt(d2);
    if (vertex_kind(prev) == kVertexInfinite) {
        m.g = 1.0;
    } else {
        m.g = 1.0 / d2;
        if (vertex_on_surface(prev)) m.g *= abs(dot(prev.ng, m.wi));
    }
    m.g *= vertex_tr_mis(x);   // the media's MIS transmittance of the segment (kMedia)
    // the light side beyond x_{q-1}: as bdpt_mis_weight_ends's for s = q, less the ratio of
    // x_{q-1}'s reverse density (the camera vertex's BSDF decides it); x_{q-1} is inside
    // the merged path, so the connection that ends the light subpath before it needs it
    // not delta too
    float fwd = g_light[q - 1].pdf_fwd;
    bool delta_prev = info_delta(g_light[q - 1].info);
    bool before = q >= 2 ? info_delta(g_light[max(q - 2, 0)].info) : g_light_delta;
    float rest = (!before && !delta_prev ? VC_AT(q - 1) : 0.0) VM_TERM(q >= 2 && info_merge_inside(g_light[q - 1].info), g_light[q - 1].info, fwd)
               + (q >= 2 ? g_light_mis[max(q - 2, 0)] : 0.0);
    m.a = rest > 0.0 ? rest / mis_ratio(fwd, 1.0) : 0.0;
    m.ref = !delta_prev ? VC_ON : 0.0;
    return m;
}

// The light pass of light path j (kernels/vcm_light.comp.glsl): its subpath at the
// shutter time of the camera sample that connects to it, its lens connections (t = 1)
// splatted, its vertices and merge points stored (merges alone: its merge points). A
// path whose vertices find the buffer full stores none (vcm_paths[j].y = 0), and merge
// points past the capacity are left out: the host reads the counters and traces the
// iteration again into larger buffers.
void vcm_light_path(uint j) {
    uvec2 pixel = uvec2(j % u_params.image.x, j / u_params.image.x);
    uint index = u_params.samples.x;
    // the camera sample's time: its own sampler stream, as the camera pass draws it
    SamplerState sc = pixel_sampler(sampler_pixel_hash(pixel, u_params.dispatch.z), index);
    g_time = camera_sample(pixel, sc).time;
    SamplerState s = pixel_sampler(sampler_pixel_hash(pixel, u_params.dispatch.z ^ kVcmLightSeed), index);
    int n = light_subpath(s);
    bdpt_mis_prepare_light(n);
    if (kVcmMode == 1) {
        strategy_begin(pixel);
        for (int k = 2; k <= n && u_vcm.paths.w != 0u; ++k) {   // not again when traced again
            LOOP_TICK();
            strategy_lens(k, s);
        }
        uint first = n > 0 ? atomicAdd(vcm_counters[0], uint(n)) : 0u;
        bool stored = first + uint(n) <= u_vcm.paths.y;
        vcm_paths[j] = uvec2(first, stored ? uint(n) : 0u);
        if (stored) {
            for (int i = 0; i < n; ++i) {
                LOOP_TICK();
                vcm_store_vertex(first + uint(i), g_light[i], g_light_mis[i], i, g_light_delta);
            }
        }
    }
    uint merges = 0u;
    for (int q = 1; q < n; ++q)
        if (info_mergeable(g_light[q].info)) merges += 1u;
    if (merges == 0u) return;
    uint at = atomicAdd(vcm_counters[1], merges);
    if (at + merges > u_vcm.paths.z) return;
    for (int q = 1; q < n; ++q) {
        LOOP_TICK();
        if (!info_mergeable(g_light[q].info)) continue;
        MergePoint m = vcm_merge_point(q);
        uint key = j * 32u + uint(q);
        vcm_store_merge(at, m, key);
        vcm_merge_sort[at] = uvec2(key, vcm_grid_hash(vcm_grid_cell(m.p)));
        at += 1u;
    }
}

// The light subpath `j` into g_light and g_light_mis (g_light_delta): its vertex count.
int vcm_load_light_path(uint j) {
    uvec2 range = vcm_paths[j];
    int n = int(range.y);
    for (int i = 0; i < n; ++i) {
        LOOP_TICK();
        float mis;
        Vertex v = vcm_load_vertex(range.x + uint(i), mis);
        STORE_AT(g_light, i, v);
        STORE_AT(g_light_mis, i, mis);
    }
    g_light_delta = n > 0 && light_is_delta(g_light[0]);
    return n;
}

// Light vertex cache (Davidovič, Křivánek, Hašan and Slusallek 2014): the light vertex in
// `slot`, vertex i >= 1 of its subpath (returned), into g_light with the two before it
// (one for i = 1) and their suffix sums: all that a connection to it and its MIS weight
// read (g_light_delta its subpath's), at the constant indices 0 .. min(i, 2) (an array
// written at a varying index costs llvmpipe every access to it). There the connection
// with s = min(i, 2) + 1 light vertices reads what the one with s = i + 1 would read at
// its own indices: the MIS weights read x_{s-1}, x_{s-2}, x_{s-3}'s flag and suffix sum.
// Its throughput is scaled by `scale`.
int vcm_load_cached(uint slot, float scale) {
    vec4 at = vcm_vertices[uint(kVcmVertexTexels) * slot + 5u];
    int i = int(at.z);
    g_light_delta = at.w != 0.0;
    bool three = i >= 2;
    float mis;
    Vertex v = vcm_load_vertex(slot, mis);
    v.beta *= scale;
    if (three) { g_light[2] = v; g_light_mis[2] = mis; } else { g_light[1] = v; g_light_mis[1] = mis; }
    v = vcm_load_vertex(slot - 1u, mis);
    if (three) { g_light[1] = v; g_light_mis[1] = mis; } else { g_light[0] = v; g_light_mis[0] = mis; }
    if (three) {
        v = vcm_load_vertex(slot - 2u, mis);
        g_light[0] = v;
        g_light_mis[0] = mis;
    }
    return i;
}

// The connections of camera vertex t - 1 with a light vertex cache: to
// kVcmCacheConnections light vertices drawn uniformly from the cache's entries (every
// stored vertex past the light of the iteration's N light paths), each weighted by
// entries / (kVcmCacheConnections N). In expectation that is the sum of the connections
// to one light subpath's vertices, as without the cache, so the MIS weights are those of
// the connections to the pixel's own subpath.
vec3 vcm_connect_cache(int t, Vertex pt, VertexBsdf pt_bsdf, Vertex pt_minus, inout SamplerState s) {
    uint entries = u_vcm.cache.x;
    vec3 L = vec3(0.0);
    if (entries == 0u) return L;
    float scale = float(entries) / (float(kVcmCacheConnections) * float(u_vcm.paths.x));
    for (int c = 0; c < kVcmCacheConnections; ++c) {
        LOOP_TICK();
        uint e = min(uint(sampler_1d(s) * float(entries)), entries - 1u);
        int i = vcm_load_cached(vcm_cache_entry(e), scale);
        // s = i + 1 light vertices: bdpt's path length cap, as the loop over a whole subpath
        if (i + t <= kBdptMaxSegments)
            L += strategy_connect_as(min(i, 2) + 1, i + 1, t, pt, pt_bsdf, pt_minus);
    }
    return L;
}

// MIS weight of merging camera vertex t - 1 with merge point m: the connection strategy
// that ends the light subpath at x_{q-1} and the camera subpath at x_{t-1} is the
// reference (bdpt_mis_weight_ends), the merge's own term (pt_rev eta)^e over the sum.
float vcm_merge_weight(int t, MergePoint m, float pdf_toward_light, float pt_minus_rev) {
    float own = vcm_merge_ratio(m.info, m.pdf_fwd);
    float cam = camera_side_sum(t, m.pdf_fwd, pt_minus_rev, false);
    float qs_rev = pdf_toward_light * m.g;
    float light = m.a > 0.0 ? mis_ratio(qs_rev, 1.0) * m.a : 0.0;
    return own / (m.ref + cam + light + own);
}

// Whether merge point m is in sight of camera vertex pt: a wall or a partition between
// them (its two sides within r, a room lit on one of them) would leak light through. Both
// ends are offset off their surfaces to the side the light arrives from (m.wi), not by the
// direction between them: that runs along the surface, and either side would do.
bool vcm_merge_visible(Vertex pt, MergePoint m) {
    vec3 o = offset_ray_origin(pt.p, pt.ng, m.wi);
    vec3 e = offset_ray_origin(m.p, m.ng, m.wi);
    vec3 w = e - o;
    float dist = length(w);
    if (!(dist > 0.0)) return true;
    return !scene_occluded(o, w / dist, dist * (1.0 - kShadowEpsilon), g_time, kNoPrimitive);
}

// Whether merge point m may merge with camera vertex pt, both within the radius: at a
// surface, a merge point on it (within a disk, as photon mapping's, photon/photon_gather.glsl:
// light vertices off it or on a surface facing another way, the other wall of a corner, are
// not of this surface's density) arriving from its light side; in a medium (kMedia), a
// scattering event in the same medium.
bool vcm_merge_matches(Vertex pt, MergePoint m, vec3 d, float r2) {
    if (kMedia && vertex_kind(pt) == kVertexMedium)
        return info_kind(m.info) == kVertexMedium && info_medium(m.info) == vertex_medium(pt);
    float h = dot(d, pt.ng);
    return info_kind(m.info) == kVertexSurface && h * h <= kDiscThickness * kDiscThickness * r2 &&
           abs(dot(m.ng, pt.ng)) >= kNormalAgreement && vertex_light_side_valid(pt, m.wi);
}

// The merges at camera vertex t - 1 (a mergeable vertex): every merge point within the
// radius in the 2 x 2 x 2 grid cells around it, at most kVcmMergeCandidates visited (the
// rest counted, vcm_counters[2]). The candidates of the 8 buckets are one loop: a lane that
// ends a bucket moves on to its next one, so the lanes of a vector wait for the longest
// total of candidates, not for the longest list of each bucket in turn (the buckets'
// ranges sit at constant indices, read by unrolled scans).
vec3 vcm_merge(int t, Vertex pt, VertexBsdf pt_bsdf, Vertex pt_minus) {
    uvec4 size = u_vcm.grid_size;
    if (size.w == 0u) return vec3(0.0);
    float r2 = u_vcm.merge.y;
    // the kernel's normalisation: 1 / (pi r^2 N) over a disk, 1 / ((4/3) pi r^3 N) over a ball
    bool volume = kMedia && vertex_kind(pt) == kVertexMedium;
    float kernel = volume ? u_vcm.merge.w * 0.75 / u_vcm.merge.x : u_vcm.merge.w;
    uint buckets[8], begins[8], ends[8];
    grid_buckets(pt.p, u_vcm.grid_lo, size, buckets);
    uint total = 0u;
    for (int i = 0; i < 8; ++i) {
        bool none = buckets[i] == kNoBucket;
        begins[i] = none ? 0u : vcm_grid[buckets[i]];
        ends[i] = none ? 0u : vcm_grid[buckets[i] + 1u];
        total += ends[i] - begins[i];
    }
    uint visit = min(total, kVcmMergeCandidates);
    int max_light_segments = kBdptMaxSegments - (t - 1);
    vec3 sum = vec3(0.0);
    int bucket = -1;
    uint e = 0u, end = 0u;
    for (uint n = 0u; n < visit; ++n, ++e) {
        LOOP_TICK();
        if (e >= end) {   // the next bucket with candidates
            int next = 8;
            for (int k = 7; k >= 0; --k) {
                if (k > bucket && begins[k] < ends[k]) {
                    next = k;
                    e = begins[k];
                    end = ends[k];
                }
            }
            bucket = next;
        }
        {
            vec4 key = vcm_merge_keys[e];
            vec3 d = key.xyz - pt.p;
            if (dot(d, d) > r2) continue;
            MergePoint m = vcm_load_merge(floatBitsToUint(key.w), key.xyz);
            if (m.segments > max_light_segments || !vcm_merge_matches(pt, m, d, r2)) continue;
            float pdf_light, pdf_back;
            // at a surface f |cos| toward the light vertex over |cos| at the geometric
            // normal: light vertices land on the geometric surface, their density is per unit
            // of its area (photon/density.glsl photon_bsdf); in a medium the phase function
            float cos_i = volume ? 1.0 : abs(dot(m.wi, pt.ng));
            vec3 f = vertex_f_bsdf(pt, pt_bsdf, pt_minus.p, pt.p + m.wi, false, pdf_light, pdf_back);
            if (max_component(f) <= 0.0 || !(cos_i > 0.0)) continue;
            f /= cos_i;
            if (!vcm_merge_visible(pt, m)) continue;
            float w = vcm_merge_weight(t, m, pdf_light,
                                       solid_angle_to_area(pdf_back, pt, pt_minus) * vertex_tr_mis(pt));
            vec3 L = pt.beta * f * m.beta * kernel;
            strategy_merge(m.segments, t, L, w);
            sum += L * w;
        }
    }
    if (total > visit) atomicAdd(vcm_counters[2], total - visit);
    if (visit > 0u) atomicAdd(vcm_counters[3], visit);
    return sum;
}

// One camera sample: its subpath, the light subpath of the pixel's index, every
// connection strategy but the lens's (the light pass splatted those) and the merges.
vec3 bidir_sample(uvec2 pixel, inout SamplerState s, inout Aov aov) {
    strategy_begin(pixel);
    int n_camera = camera_subpath(pixel, s, aov);
    int n_light = kVcmMode == 1 && kVcmCacheConnections == 0 ? vcm_load_light_path(vcm_light_path_of(pixel)) : 0;
    if (kVcmMode != 1 || kVcmCacheConnections > 0) g_light_delta = false;
    bdpt_mis_prepare_camera(n_camera);

    vec3 L = strategies_emission(n_camera, aov);
    if (kVcmMode == 1) strategies_light_sample(n_camera, s, L);
    for (int t = 2; t <= n_camera; ++t) {
        Vertex pt = g_camera[t - 1];
        if (!vertex_connectible(pt)) continue;
        Vertex pt_minus = camera_point(t - 2);
        VertexBsdf pt_bsdf = vertex_bsdf(pt);
        int k_end = min(n_light, kBdptMaxSegments + 1 - t);
        for (int k = 2; k <= k_end; ++k) {
            LOOP_TICK();
            L += strategy_connect(k, t, pt, pt_bsdf, pt_minus);
        }
#if GLRENDER_VCM_CACHE   // (a call under a false constant still counts its storage block)
        L += vcm_connect_cache(t, pt, pt_bsdf, pt_minus, s);
#endif
        if (info_mergeable(pt.info) && t - 1 < kBdptMaxSegments) L += vcm_merge(t, pt, pt_bsdf, pt_minus);
    }
    return L;
}
