// Debug instrumentation: counts loop iterations per invocation.
//
// llvmpipe silently stops an invocation after ~65,535 loop iterations in total.
// With the host define GLRENDER_COUNT_LOOPS=1, every loop that can run long calls
// LOOP_TICK() once per iteration and kernels write g_loop_count to a debug buffer,
// so tests can check the worst invocation stays far below the cap. Without the
// define the macro expands to nothing.
#if defined(GLRENDER_COUNT_LOOPS) && GLRENDER_COUNT_LOOPS
uint g_loop_count = 0u;
#define LOOP_TICK() (g_loop_count++)
#else
#define LOOP_TICK()
#endif
