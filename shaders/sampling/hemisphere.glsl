// Directions on the hemisphere z >= 0: uniform by inversion in (z, phi), cosine-weighted by Malley's method.
//
// Malley's method (pbrt-v4 SampleCosineHemisphere): a uniform point of the unit disk
// lifted to the hemisphere has density cos theta / pi per unit solid angle (the
// projected solid angle of a patch is its area on the disk). The disk point comes from
// the concentric map, so strata of u stay compact on the hemisphere.
#include "common/constants.glsl"
#include "sampling/disk.glsl"
#include "sampling/sphere.glsl"

// Density of a uniform direction on the hemisphere per unit solid angle: 1 / (2 pi).
float uniform_hemisphere_pdf() {
    return kInvTwoPi;
}

// Uniform direction on the hemisphere z >= 0: cos theta = u.x, phi = 2 pi u.y. u in
// [0,1)^2; returns a unit vector (local, +z up = the normal).
vec3 sample_uniform_hemisphere(vec2 u) {
    return spherical_direction(sqrt(max(0.0, 1.0 - u.x * u.x)), u.x, u.y);
}

// The u that sample_uniform_hemisphere maps to the unit vector w (w.z >= 0).
vec2 invert_uniform_hemisphere_sample(vec3 w) {
    return vec2(clamp(w.z, 0.0, kOneMinusEpsilon), azimuth_fraction(w));
}

// Cosine-weighted direction on the hemisphere z >= 0 (Malley's method through the
// concentric disk). u in [0,1)^2; returns a unit vector (local, +z up = the normal);
// density cosine_hemisphere_pdf(w.z) per unit solid angle.
vec3 sample_cosine_hemisphere(vec2 u) {
    vec2 d = sample_uniform_disk_concentric(u);
    // |d| is the half-width r of u's concentric square ring, known exactly: z from
    // (1 - r)(1 + r) stays accurate near the horizon, where 1 - dot(d, d) cancels.
    // u = 0 gives r = 1, z = 0, where the density vanishes; r < 1 keeps z > 0.
    vec2 o = abs(2.0 * u - 1.0);
    float r = min(max(o.x, o.y), kOneMinusEpsilon);
    float z = sqrt(max(0.0, (1.0 - r) * (1.0 + r)));
    return vec3(d, z);
}

// Density cos theta / pi per unit solid angle; 0 below the horizon.
float cosine_hemisphere_pdf(float cos_theta) {
    return max(cos_theta, 0.0) * kInvPi;
}

// The u that sample_cosine_hemisphere maps to the unit vector w (w.z >= 0).
vec2 invert_cosine_hemisphere_sample(vec3 w) {
    return invert_uniform_disk_concentric_sample(w.xy);
}
