// Debug instrumentation: counts loop iterations, as the SIMD vector executes them.
//
// llvmpipe silently stops an invocation after ~65,535 loop iterations in total. Its
// counter belongs to the whole vector (a subgroup: 8 invocations): it counts every
// iteration any lane of the vector takes, so a lane's own count undercounts wherever
// lanes loop different numbers of times in different loops (and the cooperative
// traversal, geometry/bvh8.glsl, loops over the vector's rays one after another).
// With the host define GLRENDER_COUNT_LOOPS=1 (kCountLoops), every loop that can run
// long calls LOOP_TICK() once per iteration; with subgroup ballots each tick makes the
// active lanes agree on the largest count among them, plus one, so g_loop_count is the
// vector's count of iterations taken so far (exact: every iteration has an active lane,
// and a lane that sat out a loop catches up at its next tick). Kernels write it to a debug
// buffer, so tests can check the worst vector stays far below the cap. Without ballots
// a tick counts the lane's own iterations; without the define it expands to nothing.
#extension GL_ARB_shader_ballot : enable
#extension GL_ARB_gpu_shader_int64 : enable
uint g_loop_count = 0u;
#if defined(GLRENDER_COUNT_LOOPS) && GLRENDER_COUNT_LOOPS
#if defined(GL_ARB_shader_ballot) && defined(GL_ARB_gpu_shader_int64)
// The largest c among the active lanes of the subgroup (constant lane indices for the
// first 8: no loop, which llvmpipe's cap would count).
uint loop_count_subgroup_max(uint c) {
    uvec2 m = unpackUint2x32(ballotARB(true));
    uint best = c;
#define LOOP_COUNT_LANE(k) if ((m.x & (1u << k)) != 0u) best = max(best, readInvocationARB(c, k));
    LOOP_COUNT_LANE(0u) LOOP_COUNT_LANE(1u) LOOP_COUNT_LANE(2u) LOOP_COUNT_LANE(3u)
    LOOP_COUNT_LANE(4u) LOOP_COUNT_LANE(5u) LOOP_COUNT_LANE(6u) LOOP_COUNT_LANE(7u)
#undef LOOP_COUNT_LANE
    m.x &= ~255u;
    for (; m.x != 0u; m.x &= m.x - 1u) best = max(best, readInvocationARB(c, uint(findLSB(m.x))));
    for (; m.y != 0u; m.y &= m.y - 1u) best = max(best, readInvocationARB(c, 32u + uint(findLSB(m.y))));
    return best;
}
#define LOOP_TICK() (g_loop_count = loop_count_subgroup_max(g_loop_count) + 1u)
#else
#define LOOP_TICK() (g_loop_count++)
#endif
#else
#define LOOP_TICK()
#endif

// Rays traced (camera, continuation and shadow rays), with GLRENDER_COUNT_RAYS=1: the
// path integrator calls RAY_TICK() before each and the render kernel adds g_ray_count to
// the pixel's counter, the deterministic cost of an estimator (glrender.lab.roulette).
uint g_ray_count = 0u;
#if defined(GLRENDER_COUNT_RAYS) && GLRENDER_COUNT_RAYS
#define RAY_TICK() (g_ray_count++)
#else
#define RAY_TICK()
#endif
