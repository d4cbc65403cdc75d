"""BDPT's MIS weights sum to 1 over the strategies that can make a path.

A test kernel builds real subpaths with bdpt.glsl's random walks (from the scene on the
device, as the renderer binds it), joins the whole light subpath to the whole camera
subpath into one path x_0 ... x_{k-1}, computes every vertex's densities in both
directions, and re-splits the path at every s (s light vertices, t = k - s camera
vertices) as that strategy would have stored it. bdpt_mis_weight(s, t) (after
bdpt_mis_prepare, the suffix sums of the split's subpaths) summed over the
strategies that can make the path (no connection at a specular vertex or a delta
light, s = 0 only on an area light, t >= 1, (1, 1) left out) must be 1 to float32
precision, under the balance and the power heuristic, on scenes with glass, a
roughplastic, a point light, an image environment and a directional light (paths with
delta vertices and vertices at infinity included). Vertex connection and merging adds a
merge at each inner vertex (vcm_merge_weight from the merge point its light pass would
store): the connections and merges sum to 1 the same way (test02).
"""
from unittest import mock

import numpy as np
import pytest

from glrender.gl import shaders
from glrender.gpu import codegen
from glrender.render.params import STRATEGIES
from glrender.gpu.bindings import UBO_VCM_PARAMS
from glrender.render.renderer import Renderer, settings_from_scene
from glrender.vcm.layout import VCM_PARAMS

from bidir_scenes import (MEDIA, caustic, directional, environment, fog_glossy, fog_in_glass, glossy,
                          point_light, smoke_grid)

KERNEL = """#version 450
layout(local_size_x = 64) in;
#include "common/params.glsl"
#include "scene/layout.glsl"
#include "@bidir"
layout(std430, binding = 8) buffer Results { vec4 results[]; };

Vertex g_path[2 * kBdptVertices];
float g_p_light[2 * kBdptVertices];   // density of x_i generated from x_{i-1} (light side)
float g_p_camera[2 * kBdptVertices];  // density of x_i generated from x_{i+1} (camera side)
float g_seg[2 * kBdptVertices];       // the MIS transmittance of the segment x_i x_{i+1} (media)

// The path's first sl vertices as the light subpath, its last t as the camera subpath,
// with the densities each would have stored.
void split_path(int k, int sl, int t) {
    for (int j = 0; j < sl; ++j) {
        g_light[j] = g_path[j];
        g_light[j].pdf_fwd = g_p_light[j];
        g_light[j].pdf_rev = g_p_camera[j];
        vertex_set_tr_mis(g_light[j], j > 0 ? g_seg[j - 1] : 1.0);
    }
    for (int j = 0; j < t; ++j) {
        g_camera[j] = g_path[k - 1 - j];
        g_camera[j].pdf_fwd = g_p_camera[k - 1 - j];
        g_camera[j].pdf_rev = g_p_light[k - 1 - j];
        vertex_set_tr_mis(g_camera[j], j > 0 ? g_seg[k - 1 - j] : 1.0);
    }
    g_connection_tr_mis = sl >= 1 && t >= 1 ? g_seg[sl - 1] : 1.0;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    uvec2 pixel = uvec2(i % u_params.image.x, (i / u_params.image.x) % u_params.image.y);
    SamplerState s = pixel_sampler(sampler_pixel_hash(pixel, 77u), i / (u_params.image.x * u_params.image.y));
    CameraSample c = camera_sample(pixel, s);
    g_time = c.time;
    vec3 axis = normalize(world_from_camera_at(c.time)[2].xyz);
    vec3 lens = c.o - (u_params.camera_clip.x / max(dot(c.d, axis), 1e-6)) * c.d;
    g_camera[0] = vertex_point(kVertexCamera, lens, vec3(0.0), vec3(1.0));
    int m = kMedia ? camera_medium() : kNoMedium;
    if (kMedia) vertex_set_medium(g_camera[0], m);
    Aov aov = kNoAov;
    int n_camera = random_walk(false, 1, c.o, c.d, c.t_max, vec3(1.0), camera_pdf_dir(c.d, c.time),
                               kBdptMaxSegments + 1, m, s, aov);
    if (vertex_kind(g_camera[n_camera - 1]) == kVertexInfinite) n_camera -= 1;   // join its last surface vertex
    LightPathStart st = light_path_start(s);
    results[i] = vec4(0.0);
    if (!st.valid) return;
    LightData l = scene_light(st.light);
    g_light[0] = vertex_point(kVertexLight, st.e.p, light_is_area(l) ? st.e.n : vec3(0.0), vec3(1.0));
    g_light[0].info = vertex_info(light_is_infinite(l) ? kVertexInfinite : kVertexLight, st.light + 1u, false, true);
    m = kMedia ? light_start_medium(st.o, st.e.d, g_time) : kNoMedium;
    if (kMedia) vertex_set_medium(g_light[0], m);
    int n_light = random_walk(true, 1, st.o, st.e.d, kInfinity, st.beta, st.e.pdf_dir,
                              kBdptMaxSegments, m, s, aov);
    // the whole path, if its two ends can be joined and it is not too long
    int k = n_light + n_camera;
    if (k - 1 > kBdptMaxSegments || k < 3) return;
    if (!vertex_connectible(g_light[n_light - 1]) || !vertex_connectible(g_camera[n_camera - 1])) return;
    for (int j = 0; j < k; ++j) g_path[j] = j < n_light ? g_light[j] : g_camera[k - 1 - j];
    vertex_set_delta(g_path[n_light - 1], false);   // the joined ends were not scattered toward each other
    vertex_set_delta(g_path[n_light], false);
    // the segments' MIS transmittances: each subpath's from its walk, the join's walked now
    for (int j = 0; j + 1 < k; ++j) {
        if (j + 1 < n_light) g_seg[j] = vertex_tr_mis(g_light[j + 1]);
        else if (j >= n_light) g_seg[j] = vertex_tr_mis(g_camera[k - 1 - j]);
    }
    segment_transmittance(g_path[n_light - 1], g_path[n_light], kNoPrimitive);
    g_seg[n_light - 1] = g_connection_tr_mis;
    bool any_delta = false;
    bool any_medium = false;
    for (int j = 0; j < k; ++j) {
        any_delta = any_delta || vertex_delta(g_path[j]) || !vertex_connectible(g_path[j]);
        any_medium = any_medium || vertex_kind(g_path[j]) == kVertexMedium;
        if (j == 0) g_p_light[j] = vertex_pdf_light_origin(g_path[0], g_path[1]);
        else if (j == 1) g_p_light[j] = vertex_pdf_light(g_path[0], g_path[1]);
        else g_p_light[j] = vertex_delta(g_path[j - 1]) ? 0.0 : vertex_pdf(g_path[j - 1], g_path[j - 2], g_path[j]);
        if (j >= 1) g_p_light[j] *= g_seg[j - 1];
        if (j == k - 1) g_p_camera[j] = 0.0;
        else if (j == k - 2) g_p_camera[j] = vertex_pdf(g_path[k - 1], g_path[k - 1], g_path[j]);
        else g_p_camera[j] = vertex_delta(g_path[j + 1]) ? 0.0 : vertex_pdf(g_path[j + 1], g_path[j + 2], g_path[j]);
        if (j <= k - 2) g_p_camera[j] *= g_seg[j];
    }
#if GLRENDER_VCM_MODE != 0
    // a merge evaluates the BSDF at its vertex: a path whose integrand is 0 there (a
    // direction below a shading hemisphere) contributes nothing under any weights
    for (int j = 1; j <= k - 2; ++j) {
        float unused_to, unused_from;
        if (info_merge_inside(g_path[j].info) &&
            max_component(vertex_f(g_path[j], g_path[j + 1].p, g_path[j - 1].p, false, unused_to, unused_from)) <= 0.0)
            return;
    }
#endif
    bool delta_light = light_is_delta(g_path[0]);
    bool volume_merge = false;   // a merge in a medium with a weight of 1% or more
    float sum = 0.0;
    int strategies = 0;
    for (int sl = 0; sl < k; ++sl) {
        int t = k - sl;
        bool valid;
        if (sl == 0) valid = !delta_light && vertex_light(g_path[0]) != 0u &&
                             (light_is_area(l) || light_is_infinite(l));
        else valid = !(sl == 1 && t == 1) && !vertex_delta(g_path[sl - 1]) && !vertex_delta(g_path[sl]) &&
                     vertex_connectible(g_path[sl - 1]) && vertex_connectible(g_path[sl]) &&
                     !(t == 1 && sl < 2);
        if (!valid || (kVcmMode == 2 && sl != 0)) continue;   // merges alone: s = 0 and the merges
        split_path(k, sl, t);
        // the light's point, reached by the camera (a light at infinity stays one)
        if (sl == 0 && !light_is_infinite(l)) vertex_set_kind(g_camera[t - 1], kVertexSurface);
        bdpt_mis_prepare(t, sl);
        sum += bdpt_mis_weight(sl, t);
        strategies += 1;
    }
#if GLRENDER_VCM_MODE != 0
    // merges at x_j, 1 <= j <= k - 2, where the path scatters by a non-delta lobe: the light
    // subpath x_0 .. x_j (its merge point x_j) and the camera subpath x_{k-1} .. x_j
    for (int j = 1; j <= k - 2; ++j) {
        if (!info_merge_inside(g_path[j].info)) continue;
        int sl = j + 1, t = k - j;
        split_path(k, sl, t);
        bdpt_mis_prepare(t, sl);
        MergePoint mp = vcm_merge_point(j);
        Vertex pt = g_camera[t - 1], pt_minus = g_camera[t - 2];
        float pdf_light, pdf_back;
        vertex_f(pt, pt_minus.p, pt.p + mp.wi, false, pdf_light, pdf_back);
        float w = vcm_merge_weight(t, mp, pdf_light, solid_angle_to_area(pdf_back, pt, pt_minus) * vertex_tr_mis(pt));
        sum += w;
        strategies += 1;
        if (vertex_kind(pt) == kVertexMedium && w > 0.01) volume_merge = true;
    }
#endif
    results[i] = vec4(sum, float(strategies), float(k),
                      (any_delta ? 1.0 : 0.0) + (any_medium ? 2.0 : 0.0) + (volume_merge ? 4.0 : 0.0));
}
"""


def weight_sums(gl_ctx, scene, heuristic, n=1 << 14, vcm_mode=0, eta=0.0, lens=1.0, radius=0.0):
    """Per path: the sum of the weights, the strategies counted, the vertices, and flags:
    1 delta vertices, 2 medium vertices, 4 a merge in a medium of weight 1% or more. vcm_mode 1 or 2: vcm's weights (merge density factor eta, lens
    connections' density factor ``lens``: light paths per camera sample, merge radius
    ``radius``, which sets the factor of merges in media), with its merges among the
    strategies."""
    # the scene on the device as the renderer binds it (its own kernel: the cheap path tracer,
    # never run here: its warm-up dispatch, llvmpipe's code generation, is left out)
    with mock.patch.object(Renderer, "_warm_up", lambda self: None):
        r = Renderer(scene, settings_from_scene(scene, integrator="path", spp=1, seed=1), ctx=gl_ctx)
    library = shaders.ShaderLibrary().with_generated(
        {codegen.GENERATED_PATH: codegen.generate(r.packed, has_bvh=r.packed.has_bvh, lights=r.lights_final)})
    defines = {**r.defines, "GLRENDER_STRATEGY": STRATEGIES[heuristic]}
    if vcm_mode:
        defines["GLRENDER_VCM_MODE"] = vcm_mode
    bidir = "integrators/vcm.glsl" if vcm_mode else "integrators/bdpt.glsl"
    kernel = shaders.compile_compute(gl_ctx, source=KERNEL, name="<bdpt mis test>", defines=defines,
                                     slots={"scene": codegen.GENERATED_PATH, "bidir": bidir},
                                     library=library)
    out = gl_ctx.gl.buffer(reserve=16 * n)
    block = np.zeros(1, VCM_PARAMS)[0]
    block["merge"] = (radius, radius * radius, eta, 0.0)
    block["lens"] = (lens, 1.0 / lens, 0.0, 0.0)
    params = gl_ctx.gl.buffer(block.tobytes())
    r.bind()
    r.write_params(r.param_block(0, 1))
    out.bind_to_storage_buffer(8)
    params.bind_to_uniform_block(UBO_VCM_PARAMS)
    kernel.run(group_x=n // 64)
    res = np.frombuffer(out.read(), np.float32).reshape(n, 4).astype(np.float64)
    out.release()
    params.release()
    r.release()
    return res


# medium vertices under the power heuristic (the balance one differs only in the exponent)
CASES01 = [(make, h) for make in (glossy, caustic, point_light, environment, directional)
           for h in ("mis-power", "mis-balance")] + [(make, "mis-power") for make in MEDIA]


@pytest.mark.slow
@pytest.mark.parametrize("make, heuristic", CASES01, ids=lambda x: getattr(x, "__name__", x))
def test01_weights_sum_to_one(gl_ctx, make, heuristic):
    res = weight_sums(gl_ctx, make(16), heuristic)
    made = res[:, 1] > 0
    assert made.sum() > 1000, made.sum()
    np.testing.assert_allclose(res[made, 0], 1.0, atol=2e-4)
    if make is caustic:   # paths through the glass: specular vertices among them
        assert (res[made, 3] % 2 > 0).sum() > 50
    if make in MEDIA:     # paths with medium vertices among them
        assert (res[made, 3] >= 2).sum() > 200


# media: vcm (merges in media beside merges at surfaces and connections) on three scenes,
# and the merges alone on one
CASES02 = [(make, mode) for make in (glossy, caustic, point_light, environment, directional)
           for mode in (1, 2)] + [(make, 1) for make in (fog_glossy, fog_in_glass, smoke_grid)] + [(fog_glossy, 2)]


@pytest.mark.slow
@pytest.mark.parametrize("make, mode", CASES02, ids=lambda x: getattr(x, "__name__", str(x)))
def test02_vcm_weights_sum_to_one(gl_ctx, make, mode):
    """The same paths under vertex connection and merging's weights: every connection
    strategy and a merge at every inner vertex where the path scatters by a non-delta lobe
    (vcm, mode 1), or s = 0 and the merges alone (vm, mode 2); the merges' density factor
    eta = pi r^2 N at a value where merges and connections weigh alike (area densities of
    order 1 in these scenes), radius 4 (merges in media: eta (4/3) r times the medium's
    mean extinction), and 0.6 light paths per camera sample (the lens connections' density
    factor), under the power heuristic."""
    res = weight_sums(gl_ctx, make(16), "mis-power", vcm_mode=mode, eta=0.7, lens=0.6, radius=4.0)
    made = res[:, 1] > 0
    assert made.sum() > 1000, made.sum()
    np.testing.assert_allclose(res[made, 0], 1.0, atol=2e-4)
    if make in MEDIA:     # merges in media that weigh among the strategies
        assert (res[made, 3].astype(int) & 4 > 0).sum() > 100
