// The unit disk by rejection from the square [-1,1]^2, with a bounded number of trials.
//
// Lecture 13, "Sampling a circle: rejection": X = 1 - 2 U_1, Y = 1 - 2 U_2 until
// X^2 + Y^2 <= 1. A trial is accepted with probability pi / 4, so the number of trials
// is geometric with mean 4 / pi ~ 1.273.
//
// Rejection needs an unbounded supply of uniforms, so the caller supplies them: the
// shader that includes this file defines disk_rejection_uniform over its own random
// numbers (only kernels own RNG state; this warp stays a function of its inputs).
//
// llvmpipe silently stops an invocation after ~65,535 loop iterations, so the loop is
// bounded: after kDiskRejectionMaxTrials rejections (probability (1 - pi/4)^64 ~ 2e-43,
// never seen in practice) the last candidate is mapped into the disk by the concentric
// map, which keeps the result inside the disk.
#include "common/constants.glsl"
#include "common/loop_counter.glsl"
#include "sampling/disk.glsl"

const uint kDiskRejectionMaxTrials = 64u;

// The caller's uniform pair in [0,1)^2 for the given trial (0, 1, 2, ...); independent
// across trials and invocations.
vec2 disk_rejection_uniform(uint trial);

// One rejection trial: the point 2u - 1 of the square [-1,1]^2 (lecture's X = 1 - 2U
// mirrored, the same law) and whether it lies in the unit disk.
bool disk_rejection_trial(vec2 u, out vec2 p) {
    p = 2.0 * u - 1.0;
    return dot(p, p) <= 1.0;
}

// Uniform point of the unit disk by rejection (local, centred at the origin), density
// uniform_disk_pdf() per unit area. trials: the number of candidates drawn (>= 1).
vec2 sample_uniform_disk_rejection(out uint trials) {
    vec2 u = vec2(0.0);
    vec2 p = vec2(0.0);
    for (trials = 1u; trials <= kDiskRejectionMaxTrials; ++trials) {
        LOOP_TICK();
        u = disk_rejection_uniform(trials - 1u);
        if (disk_rejection_trial(u, p)) return p;
    }
    trials = kDiskRejectionMaxTrials;
    return sample_uniform_disk_concentric(u);
}
