// The geometry buffer textures and their encoding: the one place texture units
// 0-3 are declared. glrender/gpu/bvh_upload.py binds them and a test checks the
// units and constants below against it and against glrender/accel/bvh.py; the unit
// numbers are named in common/bindings.glsl.
//
// u_bvh_nodes      rgba32ui, 4 texels (64 bytes) per 4-wide node
//                  (glrender/accel/quantize.py): origin + exponents, the four
//                  child references, and the child boxes as 8-bit planes.
// u_bvh_triangles  rgba32f, 3 texels per triangle: corners v0, v1, v2 (BVH order).
// u_bvh_instances  rgba32f, the motion instances (geometry/motion.glsl).
// Unit 3 is reserved for geometry.
//
// A child reference is an inner node index (high bit clear), or a leaf
// kBvhLeafFlag | count << kBvhLeafCountShift | first: triangles [first, first + count).
#include "common/bindings.glsl"
layout(binding = TEX_BVH_NODES) uniform usamplerBuffer u_bvh_nodes;
layout(binding = TEX_BVH_TRIANGLES) uniform samplerBuffer u_bvh_triangles;
layout(binding = TEX_BVH_INSTANCES) uniform samplerBuffer u_bvh_instances;

const uint kBvhLeafFlag = 0x80000000u;
const uint kBvhLeafCountShift = 28u;
const uint kBvhLeafFirstMask = 0x0FFFFFFFu;
const int kBvhTexelsPerNode = 4;
const int kBvhTexelsPerTriangle = 3;
const uint kBvhExponentBias = 127u;
