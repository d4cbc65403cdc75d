// The one door for host configuration: host defines become typed constants here.
//
// The host (glrender/render/params.py) passes every define below; a missing one
// is a compile error naming it. Code tests the constants (`if (kUseNee)`), never
// the macros, so the compiler folds the branches away.
#if !defined(GLRENDER_SAMPLER) || !defined(GLRENDER_MATERIAL_KINDS) || \
    !defined(GLRENDER_LIGHT_KINDS) || !defined(GLRENDER_MAX_DEPTH) || \
    !defined(GLRENDER_RR_DEPTH) || !defined(GLRENDER_STRATEGY) || \
    !defined(GLRENDER_EMITTER_SAMPLES) || !defined(GLRENDER_BSDF_SAMPLES) || \
    !defined(GLRENDER_HIDE_EMITTERS) || !defined(GLRENDER_LIGHT_SELECTION) || \
    !defined(GLRENDER_AREA_SAMPLING) || !defined(GLRENDER_FILTER) || \
    !defined(GLRENDER_AOVS) || !defined(GLRENDER_COUNT_LOOPS) || \
    !defined(GLRENDER_DEBUG_NONFINITE) || !defined(GLRENDER_EMISSION_ONLY) || \
    !defined(GLRENDER_RR_RULE) || !defined(GLRENDER_RR_SURVIVAL) || \
    !defined(GLRENDER_LIGHT_SAMPLES) || !defined(GLRENDER_SPLIT) || !defined(GLRENDER_COUNT_RAYS)
#error "common/params.glsl: a host define is missing (see glrender/render/params.py)"
#endif

// Sample generator (sampling/sampler.glsl).
const int kSamplerIndependent = 0;
const int kSamplerStratified = 1;
const int kSamplerSobol = 2;
const int kSampler = GLRENDER_SAMPLER;

// Material and light kinds present in the scene, as bit masks over their kind ids.
const uint kMaterialKinds = uint(GLRENDER_MATERIAL_KINDS);
const uint kLightKinds = uint(GLRENDER_LIGHT_KINDS);

// Integrator settings. Depth counts path segments as in Mitsuba 3: 1 = emitters
// seen directly, 2 = direct lighting; a negative value means unbounded.
const int kMaxDepth = GLRENDER_MAX_DEPTH;
const int kRrDepth = GLRENDER_RR_DEPTH;
// Russian roulette from depth kRrDepth (integrators/roulette.glsl: path, bdpt, lighttrace):
// survive with q = min(max(beta) eta^2, 0.95) (throughput), with the fixed q = kRrSurvival,
// or never stop (off).
const int kRrThroughput = 0;
const int kRrFixed = 1;
const int kRrOff = 2;
const int kRrRule = GLRENDER_RR_RULE;
const float kRrSurvival = GLRENDER_RR_SURVIVAL;
// Splitting in the path tracer: light samples per vertex, BSDF branches at the first vertex.
const int kLightSamples = GLRENDER_LIGHT_SAMPLES;
const int kSplit = GLRENDER_SPLIT;
const int kStrategyLight = 0;
const int kStrategyBsdf = 1;
const int kStrategyMisBalance = 2;
const int kStrategyMisPower = 3;
const int kStrategy = GLRENDER_STRATEGY;
const int kEmitterSamples = GLRENDER_EMITTER_SAMPLES;
const int kBsdfSamples = GLRENDER_BSDF_SAMPLES;
const bool kHideEmitters = GLRENDER_HIDE_EMITTERS != 0;
const int kLightSelectionUniform = 0;
const int kLightSelectionPower = 1;
const int kLightSelection = GLRENDER_LIGHT_SELECTION;
const int kAreaSamplingArea = 0;
const int kAreaSamplingSolidAngle = 1;
const int kAreaSampling = GLRENDER_AREA_SAMPLING;

// Pixel filter (camera/filter.glsl).
const int kFilterBox = 0;
const int kFilterTent = 1;
const int kFilterGaussian = 2;
const int kFilterMitchell = 3;
const int kFilter = GLRENDER_FILTER;

// First-hit AOVs (albedo, normal, depth, seen emission) accumulated beside the image.
const bool kAovs = GLRENDER_AOVS != 0;
// The path tracer renders the seen emission alone (the emission AOV's quantity: paths
// end at the first non-delta surface, no next-event estimation).
const bool kEmissionOnly = GLRENDER_EMISSION_ONLY != 0;
// Debug: count loop iterations per invocation (common/loop_counter.glsl).
const bool kCountLoops = GLRENDER_COUNT_LOOPS != 0;
// Count the rays traced per pixel, summed over its samples (common/loop_counter.glsl).
const bool kCountRays = GLRENDER_COUNT_RAYS != 0;
// Debug: every sample whose index is kDebugNonFinite - 1 modulo 7 returns NaN, to test that
// the accumulation drops and counts non-finite samples (0: off).
const uint kDebugNonFinite = uint(GLRENDER_DEBUG_NONFINITE);
