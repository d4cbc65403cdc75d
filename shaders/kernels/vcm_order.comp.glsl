#version 450
// vcm's merge points in the grid's order (glrender/vcm/vcm.py): entry e of the copy is
// merge point order[e]'s position with its index, so that a lookup reads a cell's merge
// points one after another (integrators/vcm.glsl vcm_merge).
layout(local_size_x = 64) in;

#include "common/bindings.glsl"

layout(std430, binding = SSBO_VCM_MERGE_KEYS) readonly buffer Keys { vec4 keys[]; };
layout(std430, binding = SSBO_VCM_GRID) readonly buffer Order { uint order[]; };
layout(std430, binding = SSBO_VCM_MERGE_SORT) writeonly buffer Ordered { vec4 ordered[]; };

void main() {
    // work groups in rows of at most 65,535 (glrender/vcm/vcm.py groups_2d)
    uint e = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationID.x;
    if (e >= uint(order.length())) return;
    uint i = order[e];
    ordered[e] = vec4(keys[i].xyz, uintBitsToFloat(i));
}
