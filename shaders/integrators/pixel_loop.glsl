// integrator_pixel for integrators whose samples cost about the same: one camera ray at
// a time through integrator_li (the direct and AO integrators).
#include "integrators/pixel.glsl"

// Defined by the integrator file that includes this one.
vec3 integrator_li(vec3 o, vec3 d, float t_max, float time, inout SamplerState s, inout Aov aov);

void integrator_pixel(uvec2 pixel, uint pixel_hash, uint first, uint count, inout Accumulator acc) {
    for (uint k = 0u; k < count; ++k) {
        LOOP_TICK();
        SamplerState s = pixel_sampler(pixel_hash, first + k);
        CameraSample c = camera_sample(pixel, s);
        Aov aov = kNoAov;
        vec3 L = c.weight * integrator_li(c.o, c.d, c.t_max, c.time, s, aov);
        accumulate(acc, L, aov_scaled(aov, c.weight), first + k);
    }
}
