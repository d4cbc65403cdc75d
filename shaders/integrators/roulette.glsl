// Russian roulette: the one rule by which path, bdpt and lighttrace end their paths.
//
// Past a depth kRrDepth a path survives a vertex with probability q and its throughput is
// divided by q (Arvo & Kirk 1990; pbrt-v3, sec. 13.7): unbiased for any q in (0, 1].
// The rule is the host's `--rr` (kRrRule, common/params.glsl):
//   throughput  q = min(max(beta) eta^2, 0.95), Mitsuba 3's rule (its path integrator,
//               src/integrators/path.cpp): the path's largest throughput component, times
//               eta^2 for radiance so that paths stay alive inside refractive media (1 for
//               importance); 0.95 keeps every path ending;
//   fixed       q = kRrSurvival, in (0, 1];
//   off         never (the depth limit ends paths: kMaxDepth, kUnboundedDepthCap, and for
//               bdpt kBdptDepthCap).
// Each integrator counts depth its own way and computes the throughput estimate in its
// own operation order (their float bits are part of the golden images), so both come in
// as arguments; the caller then draws u_rr in [0,1), ends the path unless u_rr < q, and
// divides its throughputs by q.
#include "common/params.glsl"

// Whether Russian roulette is played at a vertex reached at `depth` by the caller's count
// (the path tracer's and light tracer's path segments, bdpt's subpath vertices): from
// kRrDepth on, unless the rule is off.
bool roulette_applies(int depth) {
    return kRrRule != kRrOff && depth >= kRrDepth;
}

// The survival probability q in (0, 1] under kRrRule, given the throughput rule's estimate
// max(beta) eta^2 (>= 0; eta^2 = 1 for importance transport): min(estimate, 0.95) for the
// throughput rule, kRrSurvival for a fixed one. Only where roulette_applies (1 when off).
float roulette_survival(float throughput_estimate) {
    if (kRrRule == kRrOff) return 1.0;
    return kRrRule == kRrFixed ? kRrSurvival : min(throughput_estimate, 0.95);
}
