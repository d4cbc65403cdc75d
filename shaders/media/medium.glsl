// Participating media: free-flight sampling, transmittance and the phase function, on the
// records of scene/layout.glsl's media block (glrender/gpu/pack.py).
//
// Heterogeneous media (Mitsuba's gridvolume: a grid over the unit cube placed by its
// to_world, cell-centred lookups, trilinear or nearest) are tracked against the medium's
// majorant mu >= sigma_t,c(x) for every channel (Novák et al. 2014): tentative collisions
// at exponential steps of rate mu inside the grid's box, mu the local majorant of the
// supervoxel (kSupervoxel^3 voxels and a one-voxel apron) the step is in, walked by a 3D
// DDA, so sparse smoke takes few steps where it is thin; at each, the hero channel h
// scatters with probability sigma_s,h / mu, goes on (a null collision, sigma_n = mu -
// sigma_t) with sigma_n,h / mu, else is absorbed; each event's f and p per channel are its
// sigma_s or sigma_n (delta tracking under the null-scattering path integral: unbiased
// for chromatic media). Shadow rays take ratio tracking's transmittance, the product of
// 1 - sigma_t,c / mu over the tentative collisions. Their random numbers come from
// g_medium_rng, a hash chain that each path segment seeds from its sampler.
//
// Chromatic media (sigma_t differs per channel) are sampled by spectral MIS over the three
// channels at the level of whole paths (Miller, Georgiev and Jarosz 2019; the balance
// heuristic over hero channels): each path draws one hero channel and samples its free
// flights with that channel's coefficients; every medium event multiplies the path's
// contribution f per channel and its per-channel densities p (PathState.chan), and the
// path's throughput is f over the channels' mean density, which stays bounded (by 3) where
// a per-event average would compound. Events report (f, p) up to a common factor.
//
// Media are entered and left through the surfaces that bound them: a shape's material
// record carries its interior and exterior medium (kMaterialInteriorShift), and a ray
// leaving a surface on the side its geometric normal faces is in the exterior medium,
// otherwise in the interior one, as Mitsuba's SurfaceInteraction::target_medium. Surfaces
// of the null material only bound media: paths and shadow rays pass through them.
#include "common/hash.glsl"
#include "integrators/integrator_common.glsl"
#include "bsdf/material.glsl"
#include "sampling/phase.glsl"
#include "@scene"

const uint kMediumHomogeneous = 0u;   // glrender/gpu/layout.py MEDIUM_KINDS
const uint kMediumHeterogeneous = 1u;
const uint kPhaseIsotropic = 0u;      // PHASE_KINDS
const uint kPhaseHg = 1u;
const int kNoMedium = -1;
// Null surfaces a shadow ray passes through at most; one more blocks it.
const int kMaxNullCrossings = 32;
// Tentative collisions of one tracking at most (the medium then ends the path or blocks the
// shadow ray): far above mu times the grid's extent in any scene that renders in time.
const int kMaxTrackingSteps = 4096;

// Random numbers of the trackings (see above).
uint g_medium_rng = 0u;

float medium_random() {
    g_medium_rng = pcg_hash(g_medium_rng);
    return uint_to_unit_float(g_medium_rng);
}

// The medium the camera's rays start in (kNoMedium: none).
int camera_medium() {
    return int(u_media.media_counts.y) - 1;
}

// The medium on the far side of surface `material` for a ray leaving it along w (ng its
// geometric normal), when the surface bounds media; `current` when it bounds none.
int medium_after(uint material, vec3 ng, vec3 w, int current) {
    uint bits = scene_material(material).info.y;
    uint inside = (bits >> kMaterialInteriorShift) & 0xffu;
    uint outside = (bits >> kMaterialExteriorShift) & 0xffu;
    if (inside == 0u && outside == 0u) return current;
    return int(dot(w, ng) > 0.0 ? outside : inside) - 1;
}

bool material_is_null(uint material) {
    return scene_material(material).info.x == kMaterialNull;
}

// exp(-sigma_t t) per channel, 1 where sigma_t is 0 (t may be infinite).
vec3 medium_transmittance(int m, float t) {
    vec3 st = u_media.media[m].sigma_t.xyz;
    return vec3(st.x > 0.0 ? exp(-st.x * t) : 1.0, st.y > 0.0 ? exp(-st.y * t) : 1.0,
                st.z > 0.0 ? exp(-st.z * t) : 1.0);
}

// A free-flight sample along a ray in a medium whose surface lies at t_max (kInfinity:
// none): a scattering event at distance t < t_max, or none (the surface reached, t =
// t_max); f and p: the contribution and the densities per channel of what was sampled,
// up to a common factor (medium_event_weight applies them).
struct MediumEvent {
    bool scatter;
    float t;
    vec3 f;
    vec3 p;
};

bool medium_is_grid(int m) {
    return u_media.media[m].info.x == kMediumHeterogeneous;
}

// Voxel v of the grid whose first texel is `first` and whose voxels along x, y, z are res.
vec3 medium_voxel(uint first, uvec3 res, uvec3 v) {
    return texelFetch(u_media_grids, int(first + (v.z * res.y + v.y) * res.x + v.x)).rgb;
}

// A grid's value at point u of its unit cube: cell-centred (u res - 0.5), clamped to the
// outer voxels' centres, trilinear or the voxel holding u.
vec3 medium_grid_value(uint first, uvec3 res, vec3 u, bool nearest) {
    vec3 r = vec3(res);
    if (nearest) return medium_voxel(first, res, min(uvec3(max(floor(u * r), 0.0)), res - 1u));
    vec3 c = clamp(u * r - 0.5, vec3(0.0), r - 1.0);
    uvec3 a = uvec3(c);
    uvec3 b = min(a + 1u, res - 1u);
    vec3 f = c - vec3(a);
    vec3 x00 = mix(medium_voxel(first, res, a), medium_voxel(first, res, uvec3(b.x, a.y, a.z)), f.x);
    vec3 x10 = mix(medium_voxel(first, res, uvec3(a.x, b.y, a.z)), medium_voxel(first, res, uvec3(b.x, b.y, a.z)), f.x);
    vec3 x01 = mix(medium_voxel(first, res, uvec3(a.x, a.y, b.z)), medium_voxel(first, res, uvec3(b.x, a.y, b.z)), f.x);
    vec3 x11 = mix(medium_voxel(first, res, uvec3(a.x, b.y, b.z)), medium_voxel(first, res, b), f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

// sigma_t and sigma_s of heterogeneous medium m at world point p (0 outside its grid's box).
void medium_coefficients(int m, vec3 p, out vec3 sigma_t, out vec3 sigma_s) {
    MediumData md = u_media.media[m];
    vec3 u = (md.grid_from_world * vec4(p, 1.0)).xyz;
    sigma_t = vec3(0.0);
    sigma_s = vec3(0.0);
    if (any(lessThan(u, vec3(0.0))) || any(greaterThan(u, vec3(1.0)))) return;
    bool nearest = (md.info.z & kMediumFlagNearest) != 0u;
    sigma_t = md.sigma_t.xyz * medium_grid_value(md.sigma_grid.x, md.sigma_grid.yzw, u, nearest);
    vec3 albedo = md.albedo_grid.x != 0u
                ? medium_grid_value(md.albedo_grid.x - 1u, md.albedo_grid.yzw, u, nearest) : md.sigma_s.xyz;
    sigma_s = albedo * sigma_t;
}

// v / sigma_s(p) per channel for a point p in medium m (0 where sigma_s is): what a volume
// photon of power v at its scattering event at p stores (photon/photon_trace.comp.glsl), and
// a vcm merge point's throughput (integrators/vcm.glsl). The events' density, weighted by the
// power after each event's weight (the free flight's sigma_s T over its density), is
// sigma_s(x) L_i(x, w) per unit volume and solid angle, so these powers' density is the
// incident radiance L_i itself: a camera point estimates its in-scattered radiance
// int p(wo, wi) L_i(x, wi) dwi from them without dividing by any coefficient.
vec3 medium_over_sigma_s(int m, vec3 p, vec3 v) {
    vec3 ss = u_media.media[m].sigma_s.xyz;
    if (medium_is_grid(m)) {
        vec3 st;
        medium_coefficients(m, p, st, ss);
    }
    return vec3(ss.x > 0.0 ? v.x / ss.x : 0.0, ss.y > 0.0 ? v.y / ss.y : 0.0,
                ss.z > 0.0 ? v.z / ss.z : 0.0);
}

// The part [t0, t1] of the ray o + t d, t in [0, t_max], inside heterogeneous medium m's
// grid box; false when it misses the box.
bool medium_box(int m, vec3 o, vec3 d, float t_max, out float t0, out float t1) {
    mat4 g = u_media.media[m].grid_from_world;
    vec3 og = (g * vec4(o, 1.0)).xyz;
    vec3 inv = 1.0 / (g * vec4(d, 0.0)).xyz;
    vec3 ta = -og * inv, tb = (1.0 - og) * inv;
    vec3 lo = min(ta, tb), hi = max(ta, tb);
    t0 = max(max(lo.x, lo.y), max(lo.z, 0.0));
    t1 = min(min(hi.x, hi.y), min(hi.z, t_max));
    return t0 < t1;
}

// Tentative collisions along o + t d in heterogeneous medium m, supervoxel by supervoxel
// (a 3D DDA over its grid of local majorants): within each, exponential steps at that
// supervoxel's majorant; a step that leaves it starts afresh in the next (the exponential
// has no memory), one without extinction is crossed at once.
struct Tracker {
    float t;        // the current tentative collision (or where the walk stands)
    float mu;       // the majorant there
    float t_end;    // where the ray leaves the grid's box (or reaches its end)
    ivec3 cell;     // the supervoxel
    ivec3 step;
    vec3 t_next;    // where the ray crosses the next supervoxel boundary along each axis
    vec3 t_delta;   // the ray's length across one supervoxel along each axis
    uvec4 grid;     // MediumData.majorant_grid
    bool capped;    // the walk ran past kMaxTrackingSteps
};

// A tracker over the part of o + t d, t in [0, t_max], inside medium m's grid; false when
// the ray misses it or the medium has no extinction.
bool tracker_begin(int m, vec3 o, vec3 d, float t_max, out Tracker tk) {
    MediumData md = u_media.media[m];
    float t0, t1;
    tk.capped = false;
    if (!(md.majorant.x > 0.0) || !medium_box(m, o, d, t_max, t0, t1)) return false;
    tk.grid = md.majorant_grid;
    // supervoxel coordinates: kSupervoxel voxels to a unit (the last one may be partial)
    vec3 per_unit = vec3(md.sigma_grid.yzw) / float(kSupervoxel);
    vec3 q0 = (md.grid_from_world * vec4(o, 1.0)).xyz * per_unit;
    vec3 dq = (md.grid_from_world * vec4(d, 0.0)).xyz * per_unit;
    vec3 q = q0 + t0 * dq;
    tk.cell = clamp(ivec3(floor(q)), ivec3(0), ivec3(tk.grid.yzw) - 1);
    for (int a = 0; a < 3; ++a) {
        if (dq[a] > 0.0) {
            tk.step[a] = 1;
            tk.t_delta[a] = 1.0 / dq[a];
            tk.t_next[a] = t0 + (float(tk.cell[a] + 1) - q[a]) / dq[a];
        } else if (dq[a] < 0.0) {
            tk.step[a] = -1;
            tk.t_delta[a] = -1.0 / dq[a];
            tk.t_next[a] = t0 + (float(tk.cell[a]) - q[a]) / dq[a];
        } else {
            tk.step[a] = 0;
            tk.t_delta[a] = kInfinity;
            tk.t_next[a] = kInfinity;
        }
    }
    tk.t = t0;
    tk.t_end = t1;
    tk.mu = 0.0;
    return true;
}

// The next tentative collision (tk.t, tk.mu); false when the ray leaves the grid first.
bool tracker_next(inout Tracker tk) {
    for (int k = 0; k < kMaxTrackingSteps; ++k) {
        LOOP_TICK();
        float t_exit = min(min(min(tk.t_next.x, tk.t_next.y), tk.t_next.z), tk.t_end);
        uint at = tk.grid.x + (uint(tk.cell.z) * tk.grid.z + uint(tk.cell.y)) * tk.grid.y + uint(tk.cell.x);
        float mu = texelFetch(u_media_grids, int(at)).r;
        if (mu > 0.0) {
            float t = tk.t - log(1.0 - medium_random()) / mu;
            if (t < t_exit) {
                tk.t = t;
                tk.mu = mu;
                return true;
            }
        }
        tk.t = t_exit;
        if (t_exit >= tk.t_end) return false;
        int a = tk.t_next.x <= tk.t_next.y ? (tk.t_next.x <= tk.t_next.z ? 0 : 2)
                                            : (tk.t_next.y <= tk.t_next.z ? 1 : 2);
        tk.cell[a] += tk.step[a];
        tk.t_next[a] += tk.t_delta[a];
        if (tk.cell[a] < 0 || tk.cell[a] >= int(tk.grid[a + 1])) return false;
    }
    tk.capped = true;
    return false;
}

// Delta tracking of hero channel h in heterogeneous medium m along o + t d up to t_max.
MediumEvent medium_sample_grid(int m, vec3 o, vec3 d, float t_max, int h) {
    Tracker tk;
    if (!tracker_begin(m, o, d, t_max, tk)) return MediumEvent(false, t_max, vec3(1.0), vec3(1.0));
    vec3 w = vec3(1.0);   // the null collisions' f = p so far, scaled to a largest channel of 1
    while (tracker_next(tk)) {
        vec3 st, ss;
        medium_coefficients(m, o + tk.t * d, st, ss);
        vec3 sn = max(vec3(tk.mu) - st, vec3(0.0));
        float u = medium_random() * tk.mu;
        if (u < ss[h]) return MediumEvent(true, tk.t, w * ss, w * ss);
        if (u >= ss[h] + sn[h]) return MediumEvent(false, tk.t, vec3(0.0), vec3(1.0));   // absorbed
        w *= sn;
        w /= max_component(w);
    }
    return tk.capped ? MediumEvent(false, t_max, vec3(0.0), vec3(1.0)) : MediumEvent(false, t_max, w, w);
}

// Ratio tracking's transmittance of heterogeneous medium m along o + t d over [0, t_max].
vec3 medium_transmittance_grid(int m, vec3 o, vec3 d, float t_max) {
    Tracker tk;
    if (!tracker_begin(m, o, d, t_max, tk)) return vec3(1.0);
    vec3 tr = vec3(1.0);
    while (tracker_next(tk)) {
        vec3 st, ss;
        medium_coefficients(m, o + tk.t * d, st, ss);
        tr *= max(1.0 - st / tk.mu, vec3(0.0));
        if (max_component(tr) <= 0.0) return vec3(0.0);
    }
    return tk.capped ? vec3(0.0) : tr;
}

// The transmittance of medium m along o + t d over [0, t].
vec3 medium_segment_transmittance(int m, vec3 o, vec3 d, float t) {
    return medium_is_grid(m) ? medium_transmittance_grid(m, o, d, t) : medium_transmittance(m, t);
}

// A free-flight sample of hero channel h in medium m along the ray o + t d whose surface
// lies at t_max; u: the homogeneous media's number (heterogeneous ones draw from
// g_medium_rng). Homogeneous: t from the hero's exponential; a scattering event has
// f = sigma_s T(t), p = sigma_t T(t), passing the surface f = p = T(t_max).
MediumEvent medium_sample(int m, vec3 o, vec3 d, float t_max, float u, int h) {
    if (medium_is_grid(m)) return medium_sample_grid(m, o, d, t_max, h);
    vec3 st = u_media.media[m].sigma_t.xyz;
    float t = st[h] > 0.0 ? -log(1.0 - u) / st[h] : kInfinity;
    if (t < t_max) {
        vec3 T = medium_transmittance(m, t);
        return MediumEvent(true, t, u_media.media[m].sigma_s.xyz * T, st * T);
    }
    vec3 T = medium_transmittance(m, t_max);
    return MediumEvent(false, t_max, T, T);
}

// The phase function of medium m for light arriving along d and leaving along wi (both
// unit, d the direction of travel): its value, which is also the density of sampling wi.
float medium_phase(int m, vec3 d, vec3 wi) {
    MediumData md = u_media.media[m];
    return md.info.y == kPhaseHg ? hg_phase(dot(d, wi), md.sigma_t.w) : isotropic_phase();
}

vec3 medium_sample_phase(int m, vec3 d, vec2 u) {
    MediumData md = u_media.media[m];
    return sample_hg_world(u, md.info.y == kPhaseHg ? md.sigma_t.w : 0.0, d);
}

bool medium_samples_emitters(int m) {
    return (u_media.media[m].info.z & kMediumFlagSampleEmitters) != 0u;
}

// A medium event's contribution f and densities p per channel into a path's throughput
// beta and its per-channel density products chan: beta becomes the product of the f's over
// the channels' mean density of the whole path (spectral MIS over hero channels), chan the
// densities' products, rescaled (only their ratios count).
void medium_event_weight(inout vec3 beta, inout vec3 chan, vec3 f, vec3 p) {
    float before = dot(chan, vec3(1.0));
    chan *= p;
    float after = dot(chan, vec3(1.0));
    beta *= after > 0.0 ? f * (before / after) : vec3(0.0);
    float top = max_component(chan);
    if (top > 0.0) chan /= top;
}

// A ray that goes on past surface h along d from `from`, offset off it: the length along d
// from the surface's plane to `from`, which the next medium segment counts too (at grazing
// angles at most 64 offsets: the lead is ill-conditioned there).
float crossing_lead(vec3 from, SurfaceHit h, vec3 d) {
    return abs(dot(from - h.p, h.ng)) / max(abs(dot(d, h.ng)), 1.0 / 64.0);
}

// The transmittance that the MIS weights of bidirectional strategies give medium m along
// o + t d over [0, t]: exp(-mu t) with mu the medium's mean extinction (MediumData.majorant.y;
// a grid's counts inside its box only). The densities in those weights must be deterministic
// functions of the path (a tracked transmittance is only an estimate), and any such function
// that is positive where the true density is keeps them summing to 1 (Miller, Georgiev and
// Jarosz 2019 use the majorant's; the mean ranks the strategies closer to their true
// densities in smoke whose majorant is far above most of its voxels).
float medium_mis_transmittance(int m, vec3 o, vec3 d, float t) {
    float mu = u_media.media[m].majorant.y;
    if (!(mu > 0.0)) return 1.0;
    float t0 = 0.0, t1 = t;
    if (medium_is_grid(m) && !medium_box(m, o, d, t, t0, t1)) return 1.0;
    return exp(-mu * (t1 - t0));
}

// The transmittance of a shadow ray from o along d over t_max that starts in medium m:
// the media's along its segments, through null surfaces (into the medium on their far
// side), 0 at any other surface (`ignore`: the primitive it aims at, not a blocker). The
// ray goes on from a point offset off each surface it passes, parallel to the first: a
// segment's length counts from the surface's plane (the offset's lead along d) to the next
// hit, so that the offsets do not shorten any medium's part. tr_mis: the product of
// medium_mis_transmittance over the same parts, up to where the ray is blocked.
vec3 scene_transmittance_mis(vec3 o, vec3 d, float t_max, float time, uint ignore, int m, out float tr_mis) {
    vec3 tr = vec3(1.0);
    tr_mis = 1.0;
    vec3 from = o;          // the ray continues from here (offset past the last surface)
    float s = 0.0;          // the length along d covered up to the last surface passed
    float lead = 0.0;       // from that surface's plane to `from`, along d
    for (int k = 0; k <= kMaxNullCrossings; ++k) {
        LOOP_TICK();
        SurfaceHit h;
        RAY_TICK();
        bool found = scene_intersect(from, d, max(t_max - s - lead, 0.0), time, h) && h.prim != ignore;
        float length = found ? lead + h.t : max(t_max - s, 0.0);
        if (m != kNoMedium) {
            tr *= medium_segment_transmittance(m, from - lead * d, d, length);
            tr_mis *= medium_mis_transmittance(m, from - lead * d, d, length);
        }
        if (!found) return tr;
        if (!material_is_null(h.material) || k == kMaxNullCrossings || max_component(tr) <= 0.0)
            return vec3(0.0);
        m = medium_after(h.material, h.ng, d, m);
        s += length;
        from = offset_ray_origin(h.p, h.ng, d);
        lead = crossing_lead(from, h, d);
    }
    return vec3(0.0);
}

// The transmittance along o + t d over [0, t_max]: with media (kMedia) scene_transmittance_mis
// from medium m, without them 1 or 0 by a visibility ray (tr_mis 1).
vec3 ray_transmittance(vec3 o, vec3 d, float t_max, float time, uint ignore, int m, out float tr_mis) {
    if (kMedia) return scene_transmittance_mis(o, d, t_max, time, ignore, m, tr_mis);
    tr_mis = 1.0;
    return scene_occluded(o, d, t_max, time, ignore) ? vec3(0.0) : vec3(1.0);
}

vec3 scene_transmittance(vec3 o, vec3 d, float t_max, float time, uint ignore, int m) {
    float unused;
    return scene_transmittance_mis(o, d, t_max, time, ignore, m, unused);
}

// Passes null surface `hit` (a boundary of media only) along d: the medium beyond it and the
// ray's origin past it; false when the walk has passed kMaxNullCrossings of them since its
// last vertex (it ends there).
bool medium_cross_null(SurfaceHit hit, vec3 d, inout int medium, inout vec3 o, inout int crossings) {
    if (++crossings > kMaxNullCrossings) return false;
    medium = medium_after(hit.material, hit.ng, d, medium);
    o = offset_ray_origin(hit.p, hit.ng, d);
    return true;
}

// The medium that a ray from o along d starts in, where nothing says it (a light path's
// first segment): the one on the near side of the first surface along the ray that bounds
// media (surfaces that bound none are passed, as they leave a path's medium as it is), the
// camera's where no such surface lies ahead.
int light_start_medium(vec3 o, vec3 d, float time) {
    vec3 from = o;
    for (int k = 0; k < kMaxNullCrossings; ++k) {
        LOOP_TICK();
        SurfaceHit h;
        RAY_TICK();
        if (!scene_intersect(from, d, kInfinity, time, h)) break;
        uint bits = scene_material(h.material).info.y;
        if ((bits & ((0xffu << kMaterialInteriorShift) | (0xffu << kMaterialExteriorShift))) != 0u)
            return medium_after(h.material, h.ng, -d, kNoMedium);
        from = offset_ray_origin(h.p, h.ng, d);
    }
    return camera_medium();
}
