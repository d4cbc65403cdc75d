// Bidirectional path tracing: a camera subpath and a light subpath per sample, joined
// by every connection strategy (s, t) and weighted by multiple importance sampling
// (the subpaths and strategies: integrators/bidir.glsl). This is vertex connection and
// merging's connections-only mode (vcm --vcm-mode bpt): both subpaths of a sample in
// one invocation, no light pass.
#include "integrators/bidir.glsl"

// One sample: both subpaths, then every strategy; returns the camera-side radiance.
vec3 bidir_sample(uvec2 pixel, inout SamplerState s, inout Aov aov) {
    strategy_begin(pixel);
    int n_camera = camera_subpath(pixel, s, aov);

    int n_light = light_subpath(s);

    bdpt_mis_prepare(n_camera, n_light);

    // Every strategy, one kind per loop (a loop body runs the same code on every SIMD
    // lane); path length s + t - 1 <= kBdptMaxSegments holds by the subpath lengths
    // except for s, t >= 2.
    vec3 L = strategies_emission(n_camera, aov);
    strategies_light_sample(n_camera, s, L);
    for (int k = 2; k <= n_light; ++k) {
        LOOP_TICK();
        strategy_lens(k, s);
    }
    for (int t = 2; t <= n_camera; ++t) {
        int k_end = min(n_light, kBdptMaxSegments + 1 - t);
        Vertex pt = g_camera[t - 1];
        if (k_end < 2 || !vertex_connectible(pt)) continue;
        Vertex pt_minus = camera_point(t - 2);
        VertexBsdf pt_bsdf = vertex_bsdf(pt);
        for (int k = 2; k <= k_end; ++k) {
            LOOP_TICK();
            L += strategy_connect(k, t, pt, pt_bsdf, pt_minus);
        }
    }
    return L;
}
