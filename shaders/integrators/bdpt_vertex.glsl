// Vertices of bidirectional subpaths, their area-measure densities, and the MIS weight
// of a connection strategy by Veach's ratio recurrence.
//
// A path of k segments x_0 ... x_k (x_0 on a light, x_k the lens) can be made by k + 1
// strategies (s, t): s vertices from the light subpath, t from the camera subpath,
// s + t = k + 1 (plus s = k + 1, t = 0, which a lens nothing hits cannot use). Each
// vertex keeps the density with which its subpath reached it (pdf_fwd) and the one the
// other direction would have (pdf_rev), both per unit area. The weight of (s, t) under
// the balance (exponent 1) or power (exponent 2) heuristic is 1 / sum_i (p_i / p_s)^e,
// and p_{i+1} / p_i is a ratio of one vertex's pdf_rev and pdf_fwd: walking outward from
// the connection along each subpath multiplies one ratio per step (Veach 1997, sec.
// 10.2-10.3; pbrt-v3's MISWeight). Strategies that would connect at a delta vertex
// (a specular bounce, a point light) cannot make the path and are left out; a zero
// density (a delta direction) counts as 1 in the ratios, as it cancels.
#include "integrators/integrator_common.glsl"
#include "integrators/shading.glsl"
#include "camera/importance.glsl"
#if GLRENDER_VCM_MODE != 0
#include "integrators/vcm_layout.glsl"
#endif

// Subpath vertices stored per invocation: max_depth segments (at most kBdptDepthCap;
// unbounded depth is capped there) need max_depth + 1 camera vertices.
const int kBdptDepthCap = 16;
const int kBdptMaxSegments = (kMaxDepth < 0 || kMaxDepth > kBdptDepthCap) ? kBdptDepthCap : kMaxDepth;
const bool kBdptDepthCapped = kMaxDepth < 0 || kMaxDepth > kBdptDepthCap;   // the cap may cut paths
const int kBdptVertices = kBdptMaxSegments + 1;

const uint kVertexCamera = 0u;
const uint kVertexLight = 1u;
const uint kVertexSurface = 2u;
// A light at infinity (environment, directional): p lies a long way along the direction
// toward it (kInfiniteVertexDistance scene radii from the vertex before it); its
// densities are per unit solid angle, and the light-subpath vertex after it has the
// density of the emission disk's point (pdf_pos |cos|, pbrt-v3's BDPT).
const uint kVertexInfinite = 3u;
const float kInfiniteVertexDistance = 2.0;
// A scattering event in a participating medium (kMedia): no normal (ng = 0), the phase
// function of its medium (vertex_medium) in place of a BSDF; its densities are per unit
// volume, and a segment's free-flight density enters them through the MIS transmittance
// of the media it crosses (tr_mis below; the extinction at the vertex is a factor of both
// of its densities and cancels in every ratio).
const uint kVertexMedium = 4u;

struct Vertex {
    vec3 p;
    vec3 ng;        // geometric normal (0 for points off surfaces: pinhole, lens, point lights)
    vec3 ns;        // shading normal
#if GLRENDER_NORMAL_SHADOWING
    vec3 ns0;       // the shading normal before a normal map (bsdf_normal_frame)
#endif
    vec3 tangent;   // x axis of the shading frame (geometry/surface.glsl's shading_frame)
    vec3 beta;      // subpath throughput up to and including this vertex's arrival
    vec2 uv;
    uint material;
    // one word (a record of a dynamically indexed array costs llvmpipe a scatter or
    // gather per word and lane): bits 0-2 the kind (kVertexCamera, kVertexLight,
    // kVertexSurface, kVertexInfinite, kVertexMedium), bit 3 delta (a Dirac lobe was
    // sampled here: no strategy may end a subpath here), bit 4 connectible (not a
    // delta-only surface: a connection can end here), bits 5-11 the medium + 1 the
    // subpath arrived in (kMedia; a medium vertex's own medium, the camera's at the lens, a
    // light path's first medium at the light; 0: none), bits 12-31 the index + 1 of the
    // light at p (light vertices, emitting surfaces; 0: none); read and set through the
    // functions below
    uint info;
    float pdf_fwd;  // area density of this vertex from its own subpath
    float pdf_rev;  // area density of this vertex from the other direction
#if GLRENDER_MEDIA
    float tr_mis;   // the MIS transmittance of the segment to the vertex before it on its subpath
#endif
};

const uint kVertexKindMask = 7u;
const uint kVertexDeltaBit = 8u;
const uint kVertexConnectibleBit = 16u;
const uint kVertexMediumShift = 5u;
const uint kVertexLightShift = 12u;

uint vertex_info(uint kind, uint light, bool delta, bool connectible) {
    return kind | (delta ? kVertexDeltaBit : 0u) | (connectible ? kVertexConnectibleBit : 0u) |
           (light << kVertexLightShift);
}

// The fields of an info word (of a stored vertex: read its info alone, e.g.
// info_delta(g_camera[i].info), not the whole record).
uint info_kind(uint info) { return info & kVertexKindMask; }
uint info_light(uint info) { return info >> kVertexLightShift; }
bool info_delta(uint info) { return (info & kVertexDeltaBit) != 0u; }
bool info_connectible(uint info) { return (info & kVertexConnectibleBit) != 0u; }
int info_medium(uint info) { return int((info >> kVertexMediumShift) & 127u) - 1; }

uint vertex_kind(Vertex v) { return info_kind(v.info); }
uint vertex_light(Vertex v) { return info_light(v.info); }
bool vertex_delta(Vertex v) { return info_delta(v.info); }
bool vertex_connectible(Vertex v) { return info_connectible(v.info); }

void vertex_set_kind(inout Vertex v, uint kind) { v.info = (v.info & ~kVertexKindMask) | kind; }
void vertex_set_light(inout Vertex v, uint light) {
    v.info = (v.info & ((1u << kVertexLightShift) - 1u)) | (light << kVertexLightShift);
}
int vertex_medium(Vertex v) { return info_medium(v.info); }
void vertex_set_medium(inout Vertex v, int m) {
    v.info = (v.info & ~(127u << kVertexMediumShift)) | (uint(m + 1) << kVertexMediumShift);
}
void vertex_set_delta(inout Vertex v, bool delta) {
    v.info = (v.info & ~kVertexDeltaBit) | (delta ? kVertexDeltaBit : 0u);
}

// Vertex's last constructor argument, the MIS transmittance (kMedia only).
#if GLRENDER_MEDIA
#define VERTEX_TR(x) , x
#else
#define VERTEX_TR(x)
#endif

// The MIS transmittance of the segment from v to the vertex before it (1 without media).
float vertex_tr_mis(Vertex v) {
#if GLRENDER_MEDIA
    return v.tr_mis;
#else
    return 1.0;
#endif
}

// Vertex's constructor argument ns0 (n), in scenes with a normal map's shadowing term only:
// the others keep no copy of it in their subpaths.
#if GLRENDER_NORMAL_SHADOWING
#define VERTEX_NS0(n) n,
#else
#define VERTEX_NS0(n)
#endif

// The shading normal before a normal map at v (its shading normal where none keeps it).
vec3 vertex_ns0(Vertex v) {
#if GLRENDER_NORMAL_SHADOWING
    return v.ns0;
#else
    return v.ns;
#endif
}

// arr[index] = value with constant indices: a loop over every index that the compiler
// unrolls, each a masked vector store. llvmpipe stores to a dynamically indexed local
// array lane by lane, and its vector loads after such scalar stores stall: bdpt samples
// measured 17-25% cheaper this way (benchmarks/patches/bdpt-indexed-stores.patch
// restores the plain indexed store for comparison).
#define STORE_AT(arr, index, value) { int at_ = (index); for (int i_ = 0; i_ < arr.length(); ++i_) if (i_ == at_) arr[i_] = value; }

Vertex g_camera[kBdptVertices];
Vertex g_light[kBdptVertices];
float g_time;   // the sample's shutter time

Vertex vertex_point(uint kind, vec3 p, vec3 ng, vec3 beta) {
    return Vertex(p, ng, ng, VERTEX_NS0(ng) vec3(0.0), beta, vec2(0.0), 0u, vertex_info(kind, 0u, false, true),
                  0.0, 0.0 VERTEX_TR(1.0));
}

// The shading frame of a surface vertex, as its hit's shading_frame gave it.
Frame vertex_frame(Vertex v) {
    return Frame(v.tangent, cross(v.ns, v.tangent), v.ns);
}

bool vertex_on_surface(Vertex v) {
    return dot(v.ng, v.ng) > 0.0;
}

// The area density at `next` of a solid-angle density pdf_sa at v toward it (a vertex at
// infinity keeps the solid-angle density).
float solid_angle_to_area(float pdf_sa, Vertex v, Vertex next) {
    if (vertex_kind(next) == kVertexInfinite) return pdf_sa;
    vec3 w = next.p - v.p;
    float d2 = dot(w, w);
    if (!(d2 > 0.0)) return 0.0;
    float pdf = pdf_sa / d2;
    if (vertex_on_surface(next)) pdf *= abs(dot(next.ng, w)) * inversesqrt(d2);
    return pdf;
}

// Solid-angle density of the direction w (toward the light) for a vertex at infinity:
// the environment's, times its selection probability (directional lights: 0, a delta).
float infinite_light_density(vec3 w) {
    uint env = u_params.counts.z;
    if (env == 0u) return 0.0;
    float pdf;
    environment_radiance(scene_light(env - 1u), w, pdf);
    return light_selection_pmf(env - 1u) * pdf;
}

// Area density at `next` of light paths leaving v, a point on a light (a light at
// infinity: the emission disk's density, projected onto next's surface).
float vertex_pdf_light(Vertex v, Vertex next) {
    vec3 w = normalize(next.p - v.p);
    if (vertex_kind(v) == kVertexInfinite) {
        float r = u_params.scene_sphere.w;
        return vertex_on_surface(next) ? abs(dot(next.ng, w)) / (kPi * r * r) : 1.0 / (kPi * r * r);
    }
    LightData l = scene_light(vertex_light(v) - 1u);
    vec3 n = v.ng;
    if ((l.info.y & kLightFlagTwoSided) != 0u && dot(n, w) < 0.0) n = -n;
    float pdf_pos, pdf_dir;
    light_emission_pdf(l, v.p, n, w, u_params.scene_sphere, pdf_pos, pdf_dir);
    return solid_angle_to_area(pdf_dir, v, next);
}

// Area density of v, a point on a light, as the start of a light path toward `next`
// (a light at infinity: the solid-angle density of its direction).
float vertex_pdf_light_origin(Vertex v, Vertex next) {
    if (vertex_kind(v) == kVertexInfinite) return infinite_light_density(normalize(v.p - next.p));
    LightData l = scene_light(vertex_light(v) - 1u);
    float pdf_pos, pdf_dir;
    light_emission_pdf(l, v.p, v.ng, v.ng, u_params.scene_sphere, pdf_pos, pdf_dir);
    return light_selection_pmf(vertex_light(v) - 1u) * pdf_pos;
}

// The phase function of medium vertex v between the directions toward `from` and `to` (both
// unit, from v): its value, and the density of sampling either one from the other.
float vertex_phase(Vertex v, vec3 w_from, vec3 w_to) {
#if GLRENDER_MEDIA
    return medium_phase(vertex_medium(v), -w_from, w_to);
#else
    return 0.0;
#endif
}

// Area density at `next` with which vertex v samples it, v having been reached from prev
// (without the MIS transmittance of the segment between them).
float vertex_pdf(Vertex v, Vertex prev, Vertex next) {
    if (vertex_kind(v) == kVertexLight || vertex_kind(v) == kVertexInfinite) return vertex_pdf_light(v, next);
    vec3 wn = normalize(next.p - v.p);
    if (vertex_kind(v) == kVertexCamera) return solid_angle_to_area(camera_pdf_dir(wn, g_time), v, next);
    if (vertex_kind(v) == kVertexMedium)
        return solid_angle_to_area(vertex_phase(v, normalize(prev.p - v.p), wn), v, next);
    Frame f = vertex_frame(v);
    float pdf = bsdf_pdf(bsdf_from_material(v.material, v.uv), frame_to_local(f, normalize(prev.p - v.p)),
                         frame_to_local(f, wn));
    return solid_angle_to_area(pdf, v, next);
}

// Whether v, a light vertex, lies on a point or spot light (a delta position) or a
// directional light (a delta direction): no camera subpath can reach it.
bool light_data_is_delta(LightData l) {
    uint kind = l.info.x;
    return kind == kLightPoint || kind == kLightSpot || kind == kLightDirectional;
}

bool light_is_delta(Vertex v) {
    return light_data_is_delta(scene_light(vertex_light(v) - 1u));
}

// One factor of the recurrence: (pdf_rev / pdf_fwd)^e, zeros counting as 1.
float mis_ratio(float pdf_rev, float pdf_fwd) {
    float r = (pdf_rev != 0.0 ? pdf_rev : 1.0) / (pdf_fwd != 0.0 ? pdf_fwd : 1.0);
    return kStrategy == kStrategyMisBalance ? r : r * r;
}

// Vertex connection and merging (kVcmMode 1 and 2, integrators/vcm.glsl) adds a merge
// strategy at every vertex x_j that both subpaths can reach (a non-delta surface point or a
// scattering event in a medium, not on the light): its density is the connection
// strategy's that ends the camera subpath at x_j times p_light(x_j) eta, eta = pi r^2 (light
// paths) on surfaces (Georgiev et al. 2012, eq. 10-12), so the recurrence adds
// (p_fwd(x_j) eta)^e beside each connection's term (VM_TERM, given x_j's info word), and the
// merges-only mode (2) keeps of the connections only s = 0, the camera subpath reaching a
// light (VC_ON, VC_AT). In bdpt (mode 0) the terms are not there at all.
// In a medium the merge is over a ball, eta = (4/3) pi r^3 (light paths), and the light
// subpath's volume density of x_j has a factor sigma_t(x_j) that its stored densities leave
// out (it cancels in their ratios, not here): the weights take the medium's mean extinction
// (MediumData.majorant.y), as its MIS transmittance does (media/medium.glsl
// medium_mis_transmittance), a deterministic function of the path, so that they still sum
// to 1.
#if GLRENDER_VCM_MODE != 0
#define VM_TERM(mergeable, info, pdf_fwd) + ((mergeable) ? vcm_merge_ratio(info, pdf_fwd) : 0.0)
#else
#define VM_TERM(mergeable, info, pdf_fwd)
#endif
#if GLRENDER_VCM_MODE == 2
#define VC_ON 0.0
#define VC_AT(i) ((i) == 0 ? 1.0 : 0.0)
#else
#define VC_ON 1.0
#define VC_AT(i) 1.0
#endif
// The connection that ends the camera subpath after t vertices (VC_CAM(t)), relative to the
// others: vcm's light pass traces N light paths for the W H camera samples of an iteration,
// so its lens connections (t = 1) have N / (W H) times the density of one per sample
// (vcm_lens_ratio); a t = 1 strategy's own weight divides the others' ratios by it
// (VC_SELF_DIV). bdpt has one light path per sample: the factor is not there.
#if GLRENDER_VCM_MODE == 1
#define VC_CAM(t) ((t) == 1 ? vcm_lens_ratio() : 1.0)
#define VC_SELF_DIV(t, x) ((t) == 1 ? (x) / vcm_lens_ratio() : (x))
#elif GLRENDER_VCM_MODE == 2
#define VC_CAM(t) 0.0
#define VC_SELF_DIV(t, x) x
#else
#define VC_CAM(t) 1.0
#define VC_SELF_DIV(t, x) x
#endif

// Whether a vertex of this info word can be merged at: a surface point with a non-delta
// BSDF or a scattering event in a medium (a light subpath's first vertex, on the light, is
// never one: callers check). At a subpath's end that is all (the merge evaluates the BSDF
// or phase function there); a vertex inside a path (info_merge_inside) must also have
// scattered it by a non-delta lobe.
bool info_mergeable(uint info) {
    uint kind = info_kind(info);
    return (kind == kVertexSurface || (kMedia && kind == kVertexMedium)) && info_connectible(info);
}

bool info_merge_inside(uint info) {
    return info_mergeable(info) && !info_delta(info);
}

#if GLRENDER_VCM_MODE != 0
// (p eta)^e for the merge at a vertex of info word `info` and forward density p (a delta
// density counts as 1, as in mis_ratio; at a medium vertex eta is the ball's times the
// medium's mean extinction, see VM_TERM).
float vcm_merge_ratio(uint info, float pdf_fwd) {
    float eta = u_vcm.merge.z;
#if GLRENDER_MEDIA
    if (info_kind(info) == kVertexMedium)
        eta *= (4.0 / 3.0) * u_vcm.merge.x * u_media.media[info_medium(info)].majorant.y;
#endif
    float r = eta * (pdf_fwd != 0.0 ? pdf_fwd : 1.0);
    return kStrategy == kStrategyMisBalance ? r : r * r;
}

// (N / (W H))^e: the lens connections' density factor (VC_CAM).
float vcm_lens_ratio() {
    float r = u_vcm.lens.x;
    return kStrategy == kStrategyMisBalance ? r : r * r;
}
#endif

// The densities a connection changes: of pt = g_camera[t - 1] and qs = g_light[s - 1]
// from the other subpath's side, and of the vertices before them (pt_minus, qs_minus)
// from the connection's side; per unit area (solid angle toward a vertex at infinity).
struct ConnectionPdfs {
    float pt_rev;
    float pt_minus_rev;
    float qs_rev;
    float qs_minus_rev;
};

// Suffix sums of the ratio recurrence over the densities the subpaths stored, so that
// each strategy's weight costs O(1) instead of a walk over both subpaths:
// g_camera_mis[m] = sum over 1 <= i <= m of the products of the ratios of vertices
// i ... m (counting only the i where a strategy could end: x_i and x_{i-1} not delta),
// g_light_mis[m] the same over light vertices 0 <= i <= m (x_0 not a delta light).
// A strategy (s, t) changes the densities of its last two vertices on each side and
// takes the rest from g_camera_mis[t - 3] and g_light_mis[s - 3].
float g_camera_mis[kBdptVertices];
float g_light_mis[kBdptVertices];
bool g_light_delta;   // the light subpath starts on a point, spot or directional light

// ratio times rest, where rest = 0 (no strategy beyond) gives 0 even for an infinite ratio.
float mis_step(float ratio, float rest) {
    return rest > 0.0 ? ratio * rest : 0.0;
}

// Fills g_camera_mis for a camera subpath of n_camera vertices whose densities are final.
void bdpt_mis_prepare_camera(int n_camera) {
    float c = 0.0;
    g_camera_mis[0] = 0.0;
    for (int i = 1; i < n_camera; ++i) {
        LOOP_TICK();
        bool valid = !info_delta(g_camera[i].info) && !info_delta(g_camera[i - 1].info);
        c = mis_step(mis_ratio(g_camera[i].pdf_rev, g_camera[i].pdf_fwd),
                     c + (valid ? VC_CAM(i) : 0.0) VM_TERM(info_merge_inside(g_camera[i].info), g_camera[i].info, g_camera[i].pdf_fwd));
        STORE_AT(g_camera_mis, i, c);
    }
}

// Fills g_light_mis and g_light_delta for a light subpath of n_light vertices whose
// densities are final.
void bdpt_mis_prepare_light(int n_light) {
    g_light_delta = n_light > 0 && light_is_delta(g_light[0]);
    float l = 0.0;
    bool before = g_light_delta;
    for (int i = 0; i < n_light; ++i) {
        LOOP_TICK();
        bool delta_i = info_delta(g_light[i].info);
        l = mis_step(mis_ratio(g_light[i].pdf_rev, g_light[i].pdf_fwd),
                     l + (!delta_i && !before ? VC_AT(i) : 0.0) VM_TERM(i >= 1 && info_merge_inside(g_light[i].info), g_light[i].info, g_light[i].pdf_fwd));
        STORE_AT(g_light_mis, i, l);
        before = delta_i;
    }
}

// Fills g_camera_mis and g_light_mis (and g_light_delta) for subpaths of n_camera and
// n_light vertices whose densities are final.
void bdpt_mis_prepare(int n_camera, int n_light) {
    bdpt_mis_prepare_camera(n_camera);
    bdpt_mis_prepare_light(n_light);
}

// The ratios of the strategies with fewer camera vertices than t (camera subpath
// vertices x_{t-1} and x_{t-2} with the reverse densities pt_rev and pt_minus_rev, the rest
// from g_camera_mis) to the strategy that ends the camera subpath at x_{t-1}, t >= 2;
// merge_pt: whether a merge at x_{t-1} is among them.
float camera_side_sum(int t, float pt_rev, float pt_minus_rev, bool merge_pt) {
    bool delta_minus = info_delta(g_camera[t - 2].info);
    float inner = 0.0;
    if (t >= 3) {
        float tail = g_camera_mis[max(t - 3, 0)];
        bool valid = !delta_minus && !info_delta(g_camera[t - 3].info);
        inner = mis_step(mis_ratio(pt_minus_rev, g_camera[t - 2].pdf_fwd),
                         (valid ? VC_CAM(t - 2) : 0.0) VM_TERM(info_merge_inside(g_camera[t - 2].info), g_camera[t - 2].info, g_camera[t - 2].pdf_fwd) + tail);
    }
    return mis_step(mis_ratio(pt_rev, g_camera[t - 1].pdf_fwd),
                    (!delta_minus ? VC_CAM(t - 1) : 0.0) VM_TERM(merge_pt && info_mergeable(g_camera[t - 1].info), g_camera[t - 1].info, g_camera[t - 1].pdf_fwd) + inner);
}

// MIS weight of strategy (s, t) given the densities its connection changes, the forward
// density qs_fwd of light vertex s - 1 and whether the path's light is a delta light
// (next-event estimation passes its own light point's; the others g_light[s - 1]'s).
float bdpt_mis_weight_ends(int s, int t, ConnectionPdfs c, float qs_fwd, bool delta_light) {
    if (s + t == 2) return 1.0;
    // strategies with fewer camera vertices: x_{t-1}, x_{t-2} with the connection's
    // reverse densities, the rest from the suffix sums (merges at x_{t-1} only where the
    // light subpath reaches it: s >= 1)
    float cam = 0.0;
    if (t >= 2) cam = camera_side_sum(t, c.pt_rev, c.pt_minus_rev, s >= 1);
    // strategies with fewer light vertices (a delta light's own point cannot be found
    // by the camera subpath)
    float light = 0.0;
    if (s >= 1) {
        bool delta_minus = s >= 2 ? info_delta(g_light[max(s - 2, 0)].info) : delta_light;
        float inner = 0.0;
        if (s >= 2) {
            float tail = s >= 3 ? g_light_mis[max(s - 3, 0)] : 0.0;
            bool before = s >= 3 ? info_delta(g_light[max(s - 3, 0)].info) : delta_light;
            bool valid = !delta_minus && !before;
            inner = mis_step(mis_ratio(c.qs_minus_rev, g_light[s - 2].pdf_fwd),
                             (valid ? VC_AT(s - 2) : 0.0) VM_TERM(s >= 3 && info_merge_inside(g_light[max(s - 2, 0)].info), g_light[max(s - 2, 0)].info, g_light[s - 2].pdf_fwd) + tail);
        }
        light = mis_step(mis_ratio(c.qs_rev, qs_fwd),
                         (!delta_minus ? VC_AT(s - 1) : 0.0) VM_TERM(s >= 2 && info_mergeable(g_light[max(s - 1, 0)].info), g_light[max(s - 1, 0)].info, qs_fwd) + inner);
    }
    return 1.0 / (1.0 + VC_SELF_DIV(t, cam + light));
}

// MIS weight of strategy (s, t) given the densities its connection changes (the
// strategies get them from their own BSDF evaluations), after bdpt_mis_prepare.
float bdpt_mis_weight_pdfs(int s, int t, ConnectionPdfs c) {
    return bdpt_mis_weight_ends(s, t, c, s > 0 ? g_light[max(s - 1, 0)].pdf_fwd : 0.0, g_light_delta);
}

// The medium that a ray leaving vertex v along w runs in (kMedia; kNoMedium without media):
// the one across v's surface where that bounds media, else the one v was reached in.
int vertex_exit_medium(Vertex v, vec3 w) {
#if GLRENDER_MEDIA
    int m = vertex_medium(v);
    if (vertex_kind(v) == kVertexSurface) m = medium_after(v.material, v.ng, w, m);
    return m;
#else
    return -1;
#endif
}

// The MIS transmittance of the connection whose weight bdpt_mis_weight evaluates: set by
// the strategy that traced it (kMedia; the densities from the BSDFs and lights are evaluated
// afresh, the media's from the walk along the segment).
float g_connection_tr_mis = 1.0;

// MIS weight of strategy (s, t) for the path g_light[0, s) + g_camera[0, t) (for s = 1
// or t = 1 the caller has put the sampled light or lens vertex at index 0), every
// density of the connection evaluated afresh (the rest from bdpt_mis_prepare).
float bdpt_mis_weight(int s, int t) {
    if (s + t == 2) return 1.0;
    Vertex pt = g_camera[t - 1];
    bool has_pt_minus = t > 1, has_qs = s > 0, has_qs_minus = s > 1;
    Vertex pt_minus = g_camera[max(t - 2, 0)];
    Vertex qs = g_light[max(s - 1, 0)];
    Vertex qs_minus = g_light[max(s - 2, 0)];
    ConnectionPdfs c;
    float tr = has_qs ? g_connection_tr_mis : 1.0;
    c.pt_rev = has_qs ? vertex_pdf(qs, qs_minus, pt) * tr : vertex_pdf_light_origin(pt, pt_minus);
    c.pt_minus_rev = !has_pt_minus ? 0.0
                   : (has_qs ? vertex_pdf(pt, qs, pt_minus) : vertex_pdf_light(pt, pt_minus)) * vertex_tr_mis(pt);
    c.qs_rev = has_qs ? vertex_pdf(pt, pt_minus, qs) * tr : 0.0;
    c.qs_minus_rev = has_qs_minus ? vertex_pdf(qs, pt, qs_minus) * vertex_tr_mis(qs) : 0.0;
    return bdpt_mis_weight_ends(s, t, c, qs.pdf_fwd, has_qs && light_is_delta(g_light[0]));
}
