// Uniform directions on the unit sphere by inversion in (z, phi) (Archimedes' hat-box theorem).
//
// The area between two heights z is proportional to their difference, so z = 1 - 2 u.x
// and phi = 2 pi u.y is uniform (pbrt-v4 SampleUniformSphere).
#include "common/constants.glsl"

// Density of a uniform direction per unit solid angle: 1 / (4 pi).
float uniform_sphere_pdf() {
    return kInvFourPi;
}

// The fraction phi / 2 pi in [0, 1) of the azimuth of w around +z.
float azimuth_fraction(vec3 w) {
    float t = atan(w.y, w.x) * kInvTwoPi;
    return t < 0.0 ? min(t + 1.0, kOneMinusEpsilon) : t;
}

// The unit direction with polar angle theta from +z and azimuth phi = 2 pi t (pbrt-v4
// SphericalDirection), given sin theta and cos theta.
vec3 spherical_direction(float sin_theta, float cos_theta, float t) {
    float phi = kTwoPi * t;
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

// sin theta from 1 - cos theta: sqrt((1 - cos)(1 + cos)) without cancellation near
// cos theta = 1, where 1 - cos theta is known more accurately than cos theta.
float sin_theta_from_one_minus_cos(float one_minus_cos) {
    return sqrt(max(0.0, one_minus_cos * (2.0 - one_minus_cos)));
}

// Uniform direction on the sphere: u in [0,1)^2; returns a unit vector (local, +z up);
// density uniform_sphere_pdf() per unit solid angle.
vec3 sample_uniform_sphere(vec2 u) {
    float one_minus_cos = 2.0 * u.x;
    return spherical_direction(sin_theta_from_one_minus_cos(one_minus_cos), 1.0 - one_minus_cos,
                               u.y);
}

// The u that sample_uniform_sphere maps to the unit vector w.
vec2 invert_uniform_sphere_sample(vec3 w) {
    return vec2(clamp(0.5 * (1.0 - w.z), 0.0, kOneMinusEpsilon), azimuth_fraction(w));
}
