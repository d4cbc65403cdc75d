// The one door for host configuration: host defines become typed constants here.
//
// The host (glrender/render/params.py) passes every define below; a missing one
// is a compile error naming it. Code tests constants (`if (kSampler == ...)`),
// never the macros, so the compiler folds the branches away.
#ifndef GLRENDER_SAMPLER
#error "common/params.glsl: the host define GLRENDER_SAMPLER is missing"
#endif

const int kSamplerIndependent = 0;
const int kSamplerStratified = 1;
const int kSamplerSobol = 2;
const int kSampler = GLRENDER_SAMPLER;
