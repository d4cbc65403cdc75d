// The geometry buffer textures and their encoding: the one place the BVH's and the mesh
// triangles' texture units are declared. glrender/gpu/bvh_upload.py binds them and a test
// checks the units and constants below against it and against glrender/accel/bvh.py; the
// unit numbers are named in common/bindings.glsl.
//
// u_bvh_nodes      rgba32ui, 4 texels (64 bytes) per 4-wide node
//                  (glrender/accel/quantize.py): origin + exponents, the four
//                  child references, and the child boxes as 8-bit planes.
// u_bvh_triangles  rgba32f, 3 texels per triangle: corners v0, v1, v2 (BVH order).
// u_bvh_instances  rgba32f: texel 0 = (motion instances, static triangles, static
//                  instances, top-level root node) as uint bits, then
//                  kTexelsPerMotionInstance texels per motion instance
//                  (geometry/motion.glsl), then kTexelsPerStaticInstance per static
//                  instance (geometry/instances.glsl).
// Unit 3 is reserved for geometry.
// The shading data of each triangle, in BVH order (geometry/mesh_surface.glsl):
// u_tri_normals    rgba32f, 3 texels per triangle: vertex normals (xyz, -).
// u_tri_uvs        rgba32f, 2 texels per triangle: (uv0, uv1), (uv2, -, -).
// u_tri_info       rgba32ui, 1 texel per triangle: material, light + 1, flags, -.
//
// A child reference is an inner node index (high bit clear), or a leaf
// kBvhLeafFlag | count << kBvhLeafCountShift | first: triangles [first, first + count).
//
// Parts: a buffer texture holds at most GL_MAX_TEXTURE_BUFFER_SIZE texels (2^27 on
// llvmpipe: the corners of 44.7M triangles). Past that, the nodes, the corners and each
// kind of shading data are cut into parts of kGeometryPartTexels texels, a multiple of 12
// so that no node (4 or 6 texels) or triangle record (1 to 3) straddles two: part 0 is the
// texture above, parts 1.. an array from the kind's *_MORE unit on. How many parts each
// kind has is a host define (GLRENDER_*_PARTS, 1 when absent), so a scene whose kinds fit
// one texture each compiles to the fetches it had before parts existed (the same NIR code):
// traversal is the hot loop. Every texel is read through the *_texel functions below.
#include "common/bindings.glsl"
#include "common/params.glsl"

const uint kBvhLeafFlag = 0x80000000u;
const uint kBvhLeafCountShift = 28u;
const uint kBvhLeafFirstMask = 0x0FFFFFFFu;
const int kBvhTexelsPerNode = 4;
const int kBvhTexelsPerTriangle = 3;
const int kTexelsPerMotionInstance = 12;
const int kTexelsPerStaticInstance = 7;
const uint kBvhExponentBias = 127u;
// (1 without parts: a divisor that is never used)
const int kGeometryPartTexels = max(GLRENDER_GEOMETRY_PART_TEXELS, 1);

// T fn(int base, int k): texel base + k of one kind, base the first texel of a node or of a
// triangle's record, first its part 0 and more its further parts. base picks the part.
// Indexing an array of samplers takes a dynamically uniform index, so the further parts are
// visited in turn, each fetch running only where a lane reads that part: a SIMD vector whose
// lanes read k parts makes k fetches. Part 0 is read unconditionally (a lane of a later part
// overwrites it), and the later parts only where a lane reads one: on llvmpipe this measured
// 5-6% faster than a branch per part (benchmarks/large_meshes.py with a forced texel limit).
// With one part every branch folds away and the array of further parts goes unused.
#define GEOMETRY_TEXEL(T, fn, first, more, parts) \
T fn(int base, int k) { \
    int part = parts > 1 ? base / kGeometryPartTexels : 0; \
    int i = base - part * kGeometryPartTexels + k; \
    T v = texelFetch(first, i); \
    if (parts > 1 && part > 0) { \
        for (int j = 1; j < parts; ++j) { \
            if (part == j) v = texelFetch(more[j - 1], i); \
        } \
    } \
    return v; \
}
// The further parts' array: one unused sampler when there are none (GLSL has no empty arrays).
#define GEOMETRY_MORE(parts) (parts > 1 ? parts - 1 : 1)

layout(binding = TEX_BVH_NODES) uniform usamplerBuffer u_bvh_nodes;
layout(binding = TEX_BVH_NODES_MORE) uniform usamplerBuffer u_bvh_nodes_more[GEOMETRY_MORE(GLRENDER_BVH_NODE_PARTS)];
GEOMETRY_TEXEL(uvec4, bvh_node_texel, u_bvh_nodes, u_bvh_nodes_more, GLRENDER_BVH_NODE_PARTS)

layout(binding = TEX_BVH_TRIANGLES) uniform samplerBuffer u_bvh_triangles;
layout(binding = TEX_BVH_TRIANGLES_MORE) uniform samplerBuffer u_bvh_triangles_more[GEOMETRY_MORE(GLRENDER_BVH_TRIANGLE_PARTS)];
GEOMETRY_TEXEL(vec4, bvh_triangle_texel, u_bvh_triangles, u_bvh_triangles_more, GLRENDER_BVH_TRIANGLE_PARTS)

layout(binding = TEX_BVH_INSTANCES) uniform samplerBuffer u_bvh_instances;

layout(binding = TEX_TRI_NORMALS) uniform samplerBuffer u_tri_normals;
layout(binding = TEX_TRI_NORMALS_MORE) uniform samplerBuffer u_tri_normals_more[GEOMETRY_MORE(GLRENDER_TRI_NORMAL_PARTS)];
GEOMETRY_TEXEL(vec4, tri_normal_texel, u_tri_normals, u_tri_normals_more, GLRENDER_TRI_NORMAL_PARTS)

layout(binding = TEX_TRI_UVS) uniform samplerBuffer u_tri_uvs;
layout(binding = TEX_TRI_UVS_MORE) uniform samplerBuffer u_tri_uvs_more[GEOMETRY_MORE(GLRENDER_TRI_UV_PARTS)];
GEOMETRY_TEXEL(vec4, tri_uv_texel, u_tri_uvs, u_tri_uvs_more, GLRENDER_TRI_UV_PARTS)

layout(binding = TEX_TRI_INFO) uniform usamplerBuffer u_tri_info;
layout(binding = TEX_TRI_INFO_MORE) uniform usamplerBuffer u_tri_info_more[GEOMETRY_MORE(GLRENDER_TRI_INFO_PARTS)];
GEOMETRY_TEXEL(uvec4, tri_info_texel, u_tri_info, u_tri_info_more, GLRENDER_TRI_INFO_PARTS)
