// Debug instrumentation: counts loop iterations per invocation.
//
// llvmpipe silently stops an invocation after ~65,535 loop iterations in total.
// With the host define GLRENDER_COUNT_LOOPS=1 (kCountLoops), every loop that can
// run long calls LOOP_TICK() once per iteration and kernels write g_loop_count to a
// debug buffer, so tests can check the worst invocation stays far below the cap.
// Without it the macro expands to nothing and the counter stays 0.
uint g_loop_count = 0u;
#if defined(GLRENDER_COUNT_LOOPS) && GLRENDER_COUNT_LOOPS
#define LOOP_TICK() (g_loop_count++)
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
