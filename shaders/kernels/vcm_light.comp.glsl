#version 450
// Vertex connection and merging's light pass (integrators/vcm.glsl vcm_light_path): one
// invocation per light path of the iteration (u_vcm.paths.x of them, u_params.samples.x
// the iteration's sample index).
layout(local_size_x = 64) in;

#include "common/params.glsl"
#include "common/loop_counter.glsl"
#include "scene/layout.glsl"
#include "sampling/sampler.glsl"
#include "sampling/stratified.glsl"
#include "integrators/vcm.glsl"

void main() {
    // work groups in rows of at most 65,535 (glrender/vcm/vcm.py groups_2d)
    uint j = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationID.x;
    if (j >= u_vcm.paths.x) return;
    vcm_light_path(j);
}
