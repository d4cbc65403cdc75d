// The bidirectional subpaths and their strategies, shared by bdpt (integrators/bdpt.glsl:
// both subpaths of a sample in one invocation) and vertex connection and merging
// (integrators/vcm.glsl and kernels/vcm_light.comp.glsl: light subpaths stored by a
// light pass, camera subpaths that connect and merge with them).
//
// Strategies (Veach 1997, ch. 10; pbrt-v3's BDPTIntegrator): s = 0, the camera subpath
// reaches an area light; s = 1, next-event estimation (a light point sampled afresh
// from the camera vertex, as the path tracer does); t = 1, a light subpath vertex
// connected to the lens and splatted onto the film (integrators/splat.glsl); s, t >= 2,
// a visibility ray between the two subpaths' ends. (s, t) = (1, 1), the lens connected
// to a sampled light point, is left out: s = 0, t = 2 sees the lights. An orthographic
// camera has no t = 1 strategies (its vertex is a delta, camera_connect finds no lens). Each is
// weighted by bdpt_mis_weight (balance or power heuristic, kStrategy); kernels built
// for strategy images also keep each one's own image (integrators/strategy_images.glsl).
// max_depth counts the segments of a path (s + t - 1), at most kBdptDepthCap (the
// vertex storage bounds the subpaths, with --rr off too; Russian roulette may end them
// sooner). Lights at infinity (directional, constant and image environments) start light
// subpaths on a disk of the scene's bounding radius facing their direction, and a camera
// subpath that leaves the scene ends on a vertex at infinity (bdpt_vertex.glsl,
// kVertexInfinite).
// The emission AOV is the s = 0, t = 2 term: the emitter the camera ray finds.
#include "integrators/integrator_common.glsl"
#include "integrators/roulette.glsl"
#include "integrators/shading.glsl"
#include "integrators/pixel.glsl"
#include "integrators/light_path.glsl"
#include "integrators/splat.glsl"
#include "integrators/bdpt_vertex.glsl"
#include "integrators/strategy_images.glsl"
// vcm's splats: its light pass traces N light paths for W H camera samples, and the film
// divides the splats by W H per iteration (the light paths bdpt traces): each counts W H / N.
#if GLRENDER_VCM_MODE == 1
#define LENS_SCALE * u_vcm.lens.y
#else
#define LENS_SCALE
#endif
// The strategies weigh with the densities of their own BSDF evaluations; tests set
// kBdptGenericWeights to evaluate every density afresh instead (the same bits).
// Next-event estimation and lens connections pass their own light or lens vertex (the
// generic weights read it from index 0 of its subpath, where they put it for the call).
#if GLRENDER_BDPT_GENERIC_WEIGHTS
#define STRATEGY_WEIGHT(s, t, cp) bdpt_mis_weight(s, t)
#define LIGHT_SAMPLE_WEIGHT(t, cp, light, delta) light_sample_weight_generic(t, light)
#define LENS_WEIGHT(s, cp, lens) lens_weight_generic(s, lens)
#else
#define STRATEGY_WEIGHT(s, t, cp) bdpt_mis_weight_pdfs(s, t, cp)
#define LIGHT_SAMPLE_WEIGHT(t, cp, light, delta) bdpt_mis_weight_ends(1, t, cp, light.pdf_fwd, delta)
#define LENS_WEIGHT(s, cp, lens) bdpt_mis_weight_pdfs(s, 1, cp)
#endif

#if GLRENDER_BDPT_GENERIC_WEIGHTS
float light_sample_weight_generic(int t, Vertex light) {
    Vertex saved = g_light[0];
    g_light[0] = light;
    float w = bdpt_mis_weight(1, t);
    g_light[0] = saved;
    return w;
}

float lens_weight_generic(int s, Vertex lens) {
    Vertex saved = g_camera[0];
    g_camera[0] = lens;
    float w = bdpt_mis_weight(s, 1);
    g_camera[0] = saved;
    return w;
}
#endif

Vertex vertex_from_hit(SurfaceHit hit, Frame frame, Bsdf b, vec3 beta) {
    return Vertex(hit.p, hit.ng, frame.z, VERTEX_NS0(hit.ns0) frame.x, beta, hit.uv, hit.material,
                  vertex_info(kVertexSurface, hit.light, false, !bsdf_is_delta(b)), 0.0, 0.0 VERTEX_TR(1.0));
}

void vertex_set_tr_mis(inout Vertex v, float tr_mis) {
#if GLRENDER_MEDIA
    v.tr_mis = tr_mis;
#endif
}

// Extends a subpath from path[n - 1] along (o, d), which starts in `medium` (kMedia), until
// it leaves the scene, reaches max_vertices vertices, or a sample or Russian roulette ends
// it; radiance (camera) or importance (light, adjoint) transport. Russian roulette from
// kRrDepth vertices on by the rule kRrRule (integrators/roulette.glsl; the throughput rule on
// the product of BSDF weights, times eta^2 for radiance, as the path tracer): it scales beta
// by 1 / q and leaves the MIS densities alone (any weights that sum to 1 over the strategies
// keep the estimator unbiased). Returns the vertex count.
// In media the walk samples a free flight before each surface, as the path tracer does
// (media/medium.glsl: one hero channel per subpath, its spectral MIS in beta): a scattering
// event is a medium vertex, which continues by sampling the phase function; null surfaces
// are passed, neither vertices nor bounces. Every density of a segment carries the MIS
// transmittance of the media it crosses (tr_mis).
int random_walk(bool light_path, int n, vec3 o, vec3 d, float t_max, vec3 beta, float pdf_sa,
                int max_vertices, int medium, inout SamplerState s, inout Aov aov) {
    vec3 throughput = vec3(1.0);
    float eta_product = 1.0;
    vec3 chan = vec3(1.0);   // kMedia: the medium events' densities per channel (spectral MIS)
    int hero = 0;            // kMedia: the channel that samples the free flights
    float tr_mis = 1.0;      // kMedia: the MIS transmittance since the last vertex
    int crossings = 0;       // kMedia: null surfaces passed
    bool first = true;
    // The newest vertex (index n - 1) stays in registers until its reverse density and
    // delta flag are known and is then stored once, whole: llvmpipe stores a record of a
    // dynamically indexed array word by word, lane by lane (the vertex before the walk's
    // first is stored again with its reverse density).
    Vertex prev = light_path ? g_light[n - 1] : g_camera[n - 1];
    while (n < max_vertices) {
        LOOP_TICK();
        SurfaceHit hit;
        g_light_path_rays = light_path;   // a normal map's flip is for camera paths
        bool found = scene_intersect(o, d, t_max, g_time, hit);
        bool in_medium = false;           // a scattering event in the medium before the surface
        float t_event = 0.0;
        if (kMedia) {
            vec2 u_medium = sampler_2d(s);
            g_medium_rng = pcg_hash(floatBitsToUint(u_medium.y) ^ uint(n + 32 * crossings));
            if (first) hero = min(int(medium_random() * 3.0), 2);
            first = false;
            if (medium != kNoMedium) {
                MediumEvent ev = medium_sample(medium, o, d, found ? hit.t : t_max, u_medium.x, hero);
                vec3 w = vec3(1.0);
                medium_event_weight(w, chan, ev.f, ev.p);
                beta *= w;
                throughput *= w;
                tr_mis *= medium_mis_transmittance(medium, o, d, ev.t);
                in_medium = ev.scatter;
                t_event = ev.t;
                if (max_component(beta) <= 0.0) break;
            }
            if (!in_medium && found && material_is_null(hit.material)) {
                // a boundary of media only: the walk goes on through it
                if (!medium_cross_null(hit, d, medium, o, crossings)) break;
                t_max = kInfinity;
                continue;
            }
        }
        if (!in_medium && !found) {
            // a camera subpath that leaves the scene ends on the environment (s = 0)
            if (!light_path && u_params.counts.z != 0u) {
                Vertex v = vertex_point(kVertexInfinite,
                                        prev.p + kInfiniteVertexDistance * u_params.scene_sphere.w * d,
                                        vec3(0.0), beta);
                v.info = vertex_info(kVertexInfinite, u_params.counts.z, false, false);
                v.pdf_fwd = pdf_sa * tr_mis;
                vertex_set_tr_mis(v, tr_mis);
                STORE_AT(g_camera, n - 1, prev);
                prev = v;
                n += 1;
            }
            break;
        }
        vec2 u_choice = sampler_2d(s);
        vec2 u_bsdf = sampler_2d(s);
        float u_rr = sampler_1d(s);
        Bsdf b;
        Frame frame;
        Vertex v;
        if (in_medium) {
            v = vertex_point(kVertexMedium, o + t_event * d, vec3(0.0), beta);
        } else {
            b = bsdf_from_material(hit.material, hit.uv);
            frame = shading_frame(hit);
            bsdf_normal_frame(b, hit.ns0, frame);
            // the light side (light_side_valid): a light path's arrival, a camera path's
            // sampled direction (below)
            if (light_path && !light_side_valid(-d, hit.ng, frame.z)) break;
            v = vertex_from_hit(hit, frame, b, beta);
            if (!light_path && n == 1) record_aov(aov, hit);
        }
        if (kMedia) {
            vertex_set_medium(v, medium);
            vertex_set_tr_mis(v, tr_mis);
        }
        v.pdf_fwd = solid_angle_to_area(pdf_sa, prev, v) * tr_mis;
        n += 1;
        // from here the pending vertices are prev (index n - 2) and v (n - 1)
        bool stop = n >= max_vertices;
        if (stop && kBdptDepthCapped) g_truncated_paths += 1u;   // cut by kBdptDepthCap
        vec3 wi = vec3(0.0);
        if (!stop && in_medium) {
            // the phase function: its sample's weight is 1, its density its value, the same
            // both ways
            wi = medium_sample_phase(medium, d, u_bsdf);
            pdf_sa = medium_phase(medium, d, wi);
            prev.pdf_rev = solid_angle_to_area(pdf_sa, v, prev) * tr_mis;
        } else if (!stop) {
            BsdfSample bs;
            vec3 wo = frame_to_local(frame, -d);
            bs = bsdf_sample(b, wo, u_choice.x, u_bsdf, light_path);
            wi = frame_from_local(frame, bs.wi);
            stop = !bs.valid || (!light_path && dot(wi, hit.ng) * bs.wi.z <= 0.0);
            if (!stop) {
                vec3 weight = bs.weight;
                if (light_path) weight *= shading_normal_correction(-d, wi, hit.ns, hit.ng);
                beta *= weight;
                throughput *= weight;
                eta_product *= bs.eta;
                // densities: forward of the next vertex, reverse of the previous one
                pdf_sa = bs.delta ? 0.0 : bs.pdf;
                float pdf_rev_sa = bs.delta ? 0.0 : bsdf_pdf(b, bs.wi, wo);
                prev.pdf_rev = solid_angle_to_area(pdf_rev_sa, v, prev) * tr_mis;
                vertex_set_delta(v, bs.delta);
            }
        }
        if (light_path) { STORE_AT(g_light, n - 2, prev); } else { STORE_AT(g_camera, n - 2, prev); }
        prev = v;
        if (stop) break;
        if (roulette_applies(n)) {
            float q = roulette_survival(max_component(throughput) * (light_path ? 1.0 : eta_product * eta_product));
            if (!(u_rr < q)) break;
            beta /= q;
            throughput /= q;
        }
        if (max_component(beta) <= 0.0) break;
        if (in_medium) {
            o = v.p;
        } else {
            o = offset_ray_origin(hit.p, hit.ng, wi);
            if (kMedia) medium = medium_after(hit.material, hit.ng, wi, medium);
        }
        d = wi;
        t_max = kInfinity;
        tr_mis = 1.0;
        crossings = 0;
    }
    if (light_path) { STORE_AT(g_light, n - 1, prev); } else { STORE_AT(g_camera, n - 1, prev); }
    return n;
}

// f |cos| of a surface vertex v toward the world point `to`, reached from `from`
// (importance transport with the shading-normal correction when adjoint), and the
// solid-angle densities with which v samples `to` coming from `from` (pdf_to) and
// `from` coming from `to` (pdf_from): the MIS densities of the connection, from the
// same BSDF (vertex_pdf would look the material up again for each).
// The BSDF of a surface vertex in its shading frame (normal-mapped as at its hit).
struct VertexBsdf {
    Bsdf b;
    Frame frame;
};

VertexBsdf vertex_bsdf(Vertex v) {
    VertexBsdf vb;
    vb.frame = vertex_frame(v);
    vb.b = bsdf_from_material(v.material, v.uv);
    bsdf_normal_frame(vb.b, vertex_ns0(v), vb.frame);
    return vb;
}

// vertex_f with v's BSDF already looked up (vertex_bsdf).
// A medium vertex (kMedia) has its phase function in place of f |cos| (the scattering
// coefficient is in its subpath's beta), which is also both densities.
vec3 vertex_f_bsdf(Vertex v, VertexBsdf vb, vec3 from, vec3 to, bool adjoint, out float pdf_to, out float pdf_from) {
    vec3 wo_w = normalize(from - v.p), wi_w = normalize(to - v.p);
    if (kMedia && vertex_kind(v) == kVertexMedium) {
        float ph = vertex_phase(v, wo_w, wi_w);
        pdf_to = ph;
        pdf_from = ph;
        return vec3(ph);
    }
    vec3 wo = frame_to_local(vb.frame, wo_w), wi = frame_to_local(vb.frame, wi_w);
    vec3 f = bsdf_eval_pdf(vb.b, wo, wi, adjoint, pdf_to);
    pdf_from = bsdf_pdf(vb.b, wi, wo);
    if (adjoint) f *= shading_normal_correction(wo_w, wi_w, v.ns, v.ng);
    return f;
}

vec3 vertex_f(Vertex v, vec3 from, vec3 to, bool adjoint, out float pdf_to, out float pdf_from) {
    return vertex_f_bsdf(v, vertex_bsdf(v), from, to, adjoint, pdf_to, pdf_from);
}

// The point of camera (light) subpath vertex i alone: position, geometric normal and kind,
// all that the densities and directions toward it need (a whole record read from a
// dynamically indexed array costs llvmpipe a load per field and lane).
Vertex camera_point(int i) {
    return vertex_point(info_kind(g_camera[i].info), g_camera[i].p, g_camera[i].ng, vec3(0.0));
}

Vertex light_point(int i) {
    return vertex_point(info_kind(g_light[i].info), g_light[i].p, g_light[i].ng, vec3(0.0));
}

// light_side_valid at camera-subpath vertex v for w, its direction toward the light side.
bool vertex_light_side_valid(Vertex v, vec3 w) {
    return !vertex_on_surface(v) || light_side_valid(w, v.ng, v.ns);
}

// The transmittance of the segment from a to b: 1 or 0 by a visibility ray, and with media
// (kMedia) the media's along it through null surfaces, from the medium a leaves into (its
// MIS transmittance into g_connection_tr_mis, for the connection's weight).
// Both ends are offset off their surfaces (pbrt's SpawnRayTo): with only the start offset,
// the shadow ray's end, short of b by kShadowEpsilon of the distance, lies beyond b's own
// surface wherever the start offset (up to 256 ulps of a's coordinates along a.ng) exceeds
// that margin, and b's surface occludes its own connection: short connections between
// facing surfaces (a door ajar and the wall beside it) were lost, BDPT 1-3% dark there.
vec3 segment_transmittance(Vertex a, Vertex b, uint ignore) {
    vec3 d = b.p - a.p;
    if (!(dot(d, d) > 0.0)) return vec3(0.0);
    vec3 o = vertex_on_surface(a) ? offset_ray_origin(a.p, a.ng, d) : a.p;
    vec3 e = vertex_on_surface(b) ? offset_ray_origin(b.p, b.ng, -d) : b.p;
    vec3 w = e - o;
    float dist = length(w);
    if (!(dist > 0.0)) return vec3(0.0);
    w /= dist;
    return ray_transmittance(o, w, dist * (1.0 - kShadowEpsilon), g_time, ignore, vertex_exit_medium(a, w),
                             g_connection_tr_mis);
}

// s = 0: the camera subpath's vertex t - 1 lies on an area light or at infinity.
vec3 strategy_emission(int t) {
    Vertex pt = g_camera[t - 1];
    if (vertex_light(pt) == 0u || (t == 2 && kHideEmitters)) return vec3(0.0);
    LightData l = scene_light(vertex_light(pt) - 1u);
    vec3 wo = normalize(g_camera[t - 2].p - pt.p);
    float unused;
    vec3 L = pt.beta * (vertex_kind(pt) == kVertexInfinite ? environment_radiance(l, -wo, unused)
                                                   : area_light_radiance(l, pt.ng, wo, pt.uv));
    if (max_component(L) <= 0.0) return vec3(0.0);
    float w = bdpt_mis_weight(0, t);
    strategy_record(0, t, L, w);
    return L * w;
}

// s = 1: next-event estimation from camera vertex t - 1, a light point sampled afresh.
vec3 strategy_light_sample(int t, inout SamplerState smp) {
    vec2 u_light = sampler_2d(smp);
    float u_select = sampler_1d(smp);
    Vertex pt = g_camera[t - 1];
    if (!vertex_connectible(pt)) return vec3(0.0);
    LightChoice choice = select_light(u_select);
    LightData l = scene_light(choice.index);
    LightSample ls = sample_light(l, pt.p, u_light);
    if (!(ls.pdf > 0.0) || max_component(ls.Le) <= 0.0) return vec3(0.0);
    bool infinite = light_is_infinite(l);
    vec3 q = pt.p + (infinite ? kInfiniteVertexDistance * u_params.scene_sphere.w : ls.dist) * ls.wi;
    if (!vertex_light_side_valid(pt, ls.wi)) return vec3(0.0);
    Vertex pt_minus = camera_point(t - 2);
    float pdf_light, pdf_back;
    vec3 L = pt.beta * vertex_f(pt, pt_minus.p, q, false, pdf_light, pdf_back) * ls.Le / (choice.pmf * ls.pdf);
    if (max_component(L) <= 0.0) return vec3(0.0);
    vec3 o = vertex_on_surface(pt) ? offset_ray_origin(pt.p, pt.ng, ls.wi) : pt.p;
    float t_max = isinf(ls.dist) ? kInfinity : ls.dist * (1.0 - kShadowEpsilon);
    L *= ray_transmittance(o, ls.wi, t_max, g_time, l.info.z, vertex_exit_medium(pt, ls.wi), g_connection_tr_mis);
    if (max_component(L) <= 0.0) return vec3(0.0);
    vec3 n = vec3(0.0);
    if (light_is_area(l)) n = l.info.x == kLightSphere ? normalize(q - l.p.xyz) : l.n.xyz;
    Vertex light = vertex_point(infinite ? kVertexInfinite : kVertexLight, q, n, vec3(1.0));
    vertex_set_light(light, choice.index + 1u);
    light.pdf_fwd = vertex_pdf_light_origin(light, pt);
    float tr = g_connection_tr_mis;
    ConnectionPdfs cp = ConnectionPdfs(vertex_pdf_light(light, pt) * tr,
                                       solid_angle_to_area(pdf_back, pt, pt_minus) * vertex_tr_mis(pt),
                                       solid_angle_to_area(pdf_light, pt, light) * tr, 0.0);
    float w = LIGHT_SAMPLE_WEIGHT(t, cp, light, light_data_is_delta(l));
    strategy_record(1, t, L, w);
    return L * w;
}

// t = 1: light subpath vertex s - 1 connected to the lens, splatted onto the film.
void strategy_lens(int s, inout SamplerState smp) {
    vec2 u_lens = sampler_2d(smp);
    Vertex qs = g_light[s - 1];
    if (!vertex_connectible(qs)) return;
    CameraConnection c = camera_connect(qs.p, u_lens, g_time);
    if (!c.valid) return;
    Vertex qs_minus = light_point(s - 2);
    float pdf_lens, pdf_back;
    vec3 L = qs.beta * vertex_f(qs, qs_minus.p, c.p, true, pdf_lens, pdf_back) * c.importance LENS_SCALE;
    Vertex lens = vertex_point(kVertexCamera, c.p, vec3(0.0), vec3(1.0));
    if (max_component(L) <= 0.0) return;
    L *= segment_transmittance(qs, lens, kNoPrimitive);
    if (max_component(L) <= 0.0) return;
    float tr = g_connection_tr_mis;
    ConnectionPdfs cp = ConnectionPdfs(solid_angle_to_area(pdf_lens, qs, lens) * tr, 0.0, vertex_pdf(lens, lens, qs) * tr,
                                       solid_angle_to_area(pdf_back, qs, qs_minus) * vertex_tr_mis(qs));
    float w = LENS_WEIGHT(s, cp, lens);
    strategy_splat(s, c.film, L, w);
    splat_film(c.film, L * w);
}

// s, t >= 2: the two subpaths' ends joined by a visibility ray; pt = g_camera[t - 1],
// its BSDF and the point before it come from the caller (the same for every s). The
// light vertices are read at g_light[0, s); the strategy is (s_path, t) (vcm's light
// vertex cache puts a vertex's last three there: integrators/vcm.glsl vcm_load_cached).
vec3 strategy_connect_as(int s, int s_path, int t, Vertex pt, VertexBsdf pt_bsdf, Vertex pt_minus) {
    Vertex qs = g_light[s - 1];
    if (!vertex_connectible(qs)) return vec3(0.0);
    Vertex qs_minus = light_point(s - 2);
    vec3 d = pt.p - qs.p;
    if (!vertex_light_side_valid(pt, -d)) return vec3(0.0);
    float qs_to_pt, qs_to_minus, pt_to_qs, pt_to_minus;
    vec3 L = qs.beta * vertex_f(qs, qs_minus.p, pt.p, true, qs_to_pt, qs_to_minus) *
             vertex_f_bsdf(pt, pt_bsdf, pt_minus.p, qs.p, false, pt_to_qs, pt_to_minus) * pt.beta / dot(d, d);
    if (max_component(L) <= 0.0) return vec3(0.0);
    L *= segment_transmittance(qs, pt, kNoPrimitive);
    if (max_component(L) <= 0.0) return vec3(0.0);
    float tr = g_connection_tr_mis;
    ConnectionPdfs cp = ConnectionPdfs(solid_angle_to_area(qs_to_pt, qs, pt) * tr,
                                       solid_angle_to_area(pt_to_minus, pt, pt_minus) * vertex_tr_mis(pt),
                                       solid_angle_to_area(pt_to_qs, pt, qs) * tr,
                                       solid_angle_to_area(qs_to_minus, qs, qs_minus) * vertex_tr_mis(qs));
    float w = STRATEGY_WEIGHT(s, t, cp);
    strategy_record(s_path, t, L, w);
    return L * w;
}

vec3 strategy_connect(int s, int t, Vertex pt, VertexBsdf pt_bsdf, Vertex pt_minus) {
    return strategy_connect_as(s, s, t, pt, pt_bsdf, pt_minus);
}

// The camera subpath of one sample of `pixel` into g_camera (its time into g_time):
// returns its vertex count.
int camera_subpath(uvec2 pixel, inout SamplerState s, inout Aov aov) {
    CameraSample c = camera_sample(pixel, s);
    g_time = c.time;
    // the lens point: the ray starts at the near clip plane
    vec3 axis = normalize(world_from_camera_at(c.time)[2].xyz);
    vec3 lens = c.o - (u_params.camera_clip.x / max(dot(c.d, axis), 1e-6)) * c.d;
    g_camera[0] = vertex_point(kVertexCamera, lens, vec3(0.0), vec3(c.weight));
    // an orthographic camera's direction is a delta: no strategy ends on its vertex (t = 1)
    if (u_params.camera_projection == kCameraOrthographic) vertex_set_delta(g_camera[0], true);
    int m = kMedia ? camera_medium() : kNoMedium;
    if (kMedia) vertex_set_medium(g_camera[0], m);
    return random_walk(false, 1, c.o, c.d, c.t_max, vec3(c.weight), camera_pdf_dir(c.d, c.time),
                       kBdptMaxSegments + 1, m, s, aov);
}

// A light subpath at time g_time into g_light: returns its vertex count (0: no light).
int light_subpath(inout SamplerState s) {
    int n_light = 0;
    LightPathStart st = light_path_start(s);
    if (st.valid) {
        LightData l = scene_light(st.light);
        vec3 n = light_is_area(l) ? st.e.n : vec3(0.0);
        g_light[0] = vertex_point(kVertexLight, st.e.p, n, st.e.Le / (st.pmf * st.e.pdf_pos));
        bool infinite = light_is_infinite(l);
        g_light[0].info = vertex_info(infinite ? kVertexInfinite : kVertexLight, st.light + 1u, false, true);
        g_light[0].pdf_fwd = st.pmf * st.e.pdf_pos;
        int m = kMedia ? light_start_medium(st.o, st.e.d, g_time) : kNoMedium;
        vec3 beta = st.beta;
        if (kMedia) {
            vertex_set_medium(g_light[0], m);
            // light from infinity crosses an unbounded homogeneous medium only where it is clear
            if (infinite && m != kNoMedium && !medium_is_grid(m))
                beta *= vec3(equal(u_media.media[m].sigma_t.xyz, vec3(0.0)));
        }
        Aov unused = kNoAov;
        n_light = random_walk(true, 1, st.o, st.e.d, kInfinity, beta, st.e.pdf_dir,
                              kBdptMaxSegments, m, s, unused);
        if (infinite) {
            // densities of a light at infinity (pbrt-v3's BDPT): its direction per solid
            // angle, the first hit per unit area through the emission disk
            g_light[0].pdf_fwd = infinite_light_density(-st.e.d);
            if (n_light > 1) {
                vec3 ng1 = g_light[1].ng;   // 0 at a medium vertex: a density per unit volume
                g_light[1].pdf_fwd = st.e.pdf_pos * (dot(ng1, ng1) > 0.0 ? abs(dot(ng1, st.e.d)) : 1.0) *
                                     (kMedia ? vertex_tr_mis(g_light[1]) : 1.0);
            }
        }
    }
    return n_light;
}

// s = 0 at every camera vertex (the emission AOV: the light the camera ray finds).
vec3 strategies_emission(int n_camera, inout Aov aov) {
    vec3 L = vec3(0.0);
    for (int t = 2; t <= n_camera; ++t) {
        LOOP_TICK();
        vec3 Le = strategy_emission(t);
        L += Le;
        if (kAovs && t == 2) aov.emission = Le;     // the light the camera ray finds
    }
    return L;
}

// s = 1, next-event estimation, at every camera vertex, added to L one by one.
void strategies_light_sample(int n_camera, inout SamplerState s, inout vec3 L) {
    int n_light_sample = u_params.counts.x > 0u ? min(n_camera, kBdptMaxSegments) : 0;
    for (int t = 2; t <= n_light_sample; ++t) {
        LOOP_TICK();
        L += strategy_light_sample(t, s);
    }
}

// One sample of `pixel` (its camera-side radiance; light-path splats go to the film):
// bdpt's or vcm's, whichever file includes this one.
vec3 bidir_sample(uvec2 pixel, inout SamplerState s, inout Aov aov);

// Samples [first, first + count) of a pixel (vcm: one per iteration, after its light pass).
void integrator_pixel(uvec2 pixel, uint pixel_hash, uint first, uint count, inout Accumulator acc) {
    for (uint k = 0u; k < count; ++k) {
        LOOP_TICK();
        SamplerState s = pixel_sampler(pixel_hash, first + k);
        Aov aov = kNoAov;
        vec3 L = bidir_sample(pixel, s, aov);
        accumulate(acc, L, aov, first + k);
    }
}
