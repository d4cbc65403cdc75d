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

// Switches the host passes only for the scenes or tests that need them
// (glrender/render/params.py OPTIONAL_DEFINES): each is a number here, 0 when absent
// (the geometry's parts: 1).
// Code reads the typed constant; it tests the macro (#if) only where a declaration
// depends on it (a struct field, a storage block, a function the scene code defines).
#ifndef GLRENDER_NORMAL_SHADOWING
#define GLRENDER_NORMAL_SHADOWING 0
#endif
#ifndef GLRENDER_ALPHA_CUTOUTS
#define GLRENDER_ALPHA_CUTOUTS 0
#endif
#ifndef GLRENDER_STRATEGY_DEPTH
#define GLRENDER_STRATEGY_DEPTH 0
#endif
#ifndef GLRENDER_BVH_MAX_DEPTH
#define GLRENDER_BVH_MAX_DEPTH 31
#endif
#ifndef GLRENDER_BDPT_GENERIC_WEIGHTS
#define GLRENDER_BDPT_GENERIC_WEIGHTS 0
#endif
#ifndef GLRENDER_METALLIC_ROUGHNESS
#define GLRENDER_METALLIC_ROUGHNESS 0
#endif
#ifndef GLRENDER_EMISSION_TEXTURES
#define GLRENDER_EMISSION_TEXTURES 0
#endif
#ifndef GLRENDER_WAVEFRONT
#define GLRENDER_WAVEFRONT 0
#endif
#ifndef GLRENDER_WAVE_STAGE
#define GLRENDER_WAVE_STAGE 0
#endif
#ifndef GLRENDER_WAVE_BVH_HITS
#define GLRENDER_WAVE_BVH_HITS 0
#endif
#ifndef GLRENDER_COOP_LANES
#define GLRENDER_COOP_LANES 0
#endif
#ifndef GLRENDER_VCM_MODE
#define GLRENDER_VCM_MODE 0
#endif
#ifndef GLRENDER_VCM_CACHE
#define GLRENDER_VCM_CACHE 0
#endif
#ifndef GLRENDER_SHARED_TIME
#define GLRENDER_SHARED_TIME 0
#endif
#ifndef GLRENDER_MEDIA
#define GLRENDER_MEDIA 0
#endif
#ifndef GLRENDER_GEOMETRY_PART_TEXELS
#define GLRENDER_GEOMETRY_PART_TEXELS 0
#endif
#ifndef GLRENDER_BVH_NODE_PARTS
#define GLRENDER_BVH_NODE_PARTS 1
#endif
#ifndef GLRENDER_BVH_TRIANGLE_PARTS
#define GLRENDER_BVH_TRIANGLE_PARTS 1
#endif
#ifndef GLRENDER_TRI_NORMAL_PARTS
#define GLRENDER_TRI_NORMAL_PARTS 1
#endif
#ifndef GLRENDER_TRI_UV_PARTS
#define GLRENDER_TRI_UV_PARTS 1
#endif
#ifndef GLRENDER_TRI_INFO_PARTS
#define GLRENDER_TRI_INFO_PARTS 1
#endif
// A material's normal map has Mitsuba's shadowing term (bsdf/bsdf.glsl
// bsdf_normal_shadowing; bdpt's vertices keep the unperturbed normal for it).
const bool kNormalShadowing = GLRENDER_NORMAL_SHADOWING != 0;
// Opacity textures cut holes into mesh triangles: BVH traversal asks the scene code's
// bvh_alpha_pass about each hit (geometry/bvh.glsl, glrender/gpu/codegen.py).
const bool kAlphaCutouts = GLRENDER_ALPHA_CUTOUTS != 0;
// bdpt keeps the image of every strategy of path lengths up to this (0: none;
// integrators/strategy_images.glsl and its storage block).
const int kStrategyDepth = GLRENDER_STRATEGY_DEPTH;
// The deepest BVH the traversal stack holds (glrender/accel/bvh.py MAX_DEPTH; tests lower
// it to see the overflow answer).
const int kBvhMaxDepth = GLRENDER_BVH_MAX_DEPTH;
// Test only (tests/render/test_bdpt.py): bdpt evaluates every MIS density afresh
// instead of reusing its connections' own, the oracle of the O(1) weights.
const bool kBdptGenericWeights = GLRENDER_BDPT_GENERIC_WEIGHTS != 0;
// A metallic-roughness material picks its BSDF per surface point (bsdf/metallic_roughness.glsl),
// and rough plastic may read the coating table over alpha (bsdf/roughplastic.glsl).
const bool kMetallicRoughness = GLRENDER_METALLIC_ROUGHNESS != 0;
// An area light's radiance may vary over it with a texture (lights/light.glsl).
const bool kEmissionTextures = GLRENDER_EMISSION_TEXTURES != 0;
// The path tracer runs as stages over queues of paths (kernels/wavefront.comp.glsl): a
// segment hands its light sample's shadow ray to the shadow stage instead of tracing it.
const bool kWavefront = GLRENDER_WAVEFRONT != 0;
// Which of its stages a wavefront program runs (kernels/wavefront.comp.glsl kStage*); the
// step's scene code then takes the extend stage's BVH hit (GLRENDER_WAVE_BVH_HITS, tested
// by #if in the generated scene code: it declares nothing otherwise).
const uint kWaveStage = uint(GLRENDER_WAVE_STAGE);
// The 8-wide traversal (geometry/bvh8.glsl) traces a vector's rays cooperatively when at
// most this many of its lanes have one (0: never; benchmarks/traversal.py measures it).
const uint kCoopLanes = uint(GLRENDER_COOP_LANES);
// Vertex connection and merging (integrators/vcm.glsl): 0 the bidirectional strategies
// alone in one kernel (bdpt, vcm's bpt mode), 1 connections and merges (vcm), 2 merges
// alone (vm, progressive photon mapping); modes 1 and 2 read light subpaths that a light
// pass stored (kernels/vcm_light.comp.glsl) and take their declarations by #if.
const int kVcmMode = GLRENDER_VCM_MODE;
// vcm with a light vertex cache: each camera vertex connects to this many light vertices
// drawn from all the iteration's stored ones (0: to its pixel's own light subpath).
const int kVcmCacheConnections = GLRENDER_VCM_CACHE;
// Every camera sample of a pass takes one shutter time (u_params.shutter.w), a new one each
// pass: vcm's merges join light vertices of one time in scenes with motion.
const bool kSharedTime = GLRENDER_SHARED_TIME != 0;
// The scene's shapes or camera name participating media (media/medium.glsl): paths track
// the medium they are in, scatter in it and see its transmittance.
const bool kMedia = GLRENDER_MEDIA != 0;

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
const int kLightSelectionBvh = 2;
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
