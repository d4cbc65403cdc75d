// The power density p(x) = (n + 1) x^n on [0, 1], by inversion and by the maximum of n + 1 uniforms.
//
// Lecture 13, "Example: power function": P(x) = x^(n + 1), so X = U^(1 / (n + 1)); and
// Y = max(U_1, ..., U_{n+1}) has Pr(Y < x) = prod Pr(U_i < x) = x^(n + 1): the same law.

// u = 0 is read as 2^-25, half the spacing of float32 uniforms, so that x is never 0,
// where the density vanishes for n > 0: an estimator f / pdf would divide 0 by 0.
const float kPowerSmallestUniform = 2.98023224e-8;

// Samples x with density (n + 1) x^n by inversion: u in [0, 1), n > -1 (any real).
float sample_power(float u, float n) {
    return pow(max(u, kPowerSmallestUniform), 1.0 / (n + 1.0));
}

// Density (n + 1) x^n per unit length for x in [0, 1]; 0 outside. (GLSL leaves pow(0, y)
// undefined for y <= 0, so x = 0 is spelled out: 0^0 = 1.)
float power_pdf(float x, float n) {
    if (!(x >= 0.0 && x <= 1.0)) return 0.0;
    float x_n = x > 0.0 ? pow(x, n) : (n == 0.0 ? 1.0 : 0.0);
    return (n + 1.0) * x_n;
}

// The u that sample_power maps to x: P(x) = x^(n + 1).
float invert_power_sample(float x, float n) {
    return pow(x, n + 1.0);
}

// Samples x with density (n + 1) x^n as the largest of n + 1 uniforms (lecture 13's
// trick): u holds independent uniforms in [0, 1), of which u[0] .. u[n] are used;
// integer n in [0, 3]. Not invertible (many u give the same x).
float sample_power_max(vec4 u, int n) {
    float x = u.x;
    x = n >= 1 ? max(x, u.y) : x;
    x = n >= 2 ? max(x, u.z) : x;
    x = n >= 3 ? max(x, u.w) : x;
    return max(x, kPowerSmallestUniform);
}
