// The normalised Phong lobe (n + 1) / (2 pi) cos^n theta about +z, by inversion through the power density.
//
// Per unit solid angle, d omega = d(cos theta) d phi, so cos theta has the power density
// (n + 1) cos^n theta on [0, 1] (lecture 13, "Example: power function") and phi is
// uniform: cos theta = u.x^(1 / (n + 1)), phi = 2 pi u.y. With n = 1 this is the cosine
// lobe; for a glossy Phong BRDF the lobe axis is the mirror direction (rotate with a
// Frame from common/frame.glsl).
#include "common/constants.glsl"
#include "sampling/power.glsl"
#include "sampling/sphere.glsl"

// Density (n + 1) / (2 pi) cos^n theta per unit solid angle; 0 below the horizon.
float phong_lobe_pdf(float cos_theta, float n) {
    return cos_theta > 0.0 ? power_pdf(cos_theta, n) * kInvTwoPi : 0.0;
}

// Direction of the Phong lobe cos^n theta (n > -1): u in [0,1)^2; returns a unit vector
// (local, +z = lobe axis); density phong_lobe_pdf(w.z, n) per unit solid angle.
vec3 sample_phong_lobe(vec2 u, float n) {
    float cos_theta = sample_power(u.x, n);
    float sin_theta = sqrt(max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
    return spherical_direction(sin_theta, cos_theta, u.y);
}

// The u that sample_phong_lobe maps to the unit vector w (w.z > 0).
vec2 invert_phong_lobe_sample(vec3 w, float n) {
    return vec2(min(invert_power_sample(max(w.z, 0.0), n), kOneMinusEpsilon), azimuth_fraction(w));
}
