// Pixel filters by filter importance sampling: offsets drawn from the filter itself.
//
// The measurement equation's pixel integral I = ∫ f(x - c) L(x) dx / ∫ f is estimated
// with x = c + X, X ~ f (Ernst et al. 2006; pbrt-v4's FilterSampler): no sample is
// shared between pixels, so pixels stay independent and the estimator unbiased.
// Filters are separable, f(x, y) = f1(x) f1(y). Box and tent are sampled exactly
// (weight 1). The Gaussian (Mitsuba's: exp(-x^2 / 2 s^2) minus its value at the
// radius) is sampled as a Gaussian truncated to the radius, with weight
// f1 / (the sampled density * ∫ f1). Mitchell-Netravali is sampled uniformly over its
// support with weight f1 / (pdf * ∫ f1) (signed: its lobes are negative).
#include "common/params.glsl"
#include "sampling/erf.glsl"

// Offset within [-r, r] with a tent density (1 - |x| / r) / r; u in [0, 1).
float sample_tent(float u, float r) {
    return u < 0.5 ? r * (sqrt(2.0 * u) - 1.0) : r * (1.0 - sqrt(2.0 - 2.0 * u));
}

// 1D Mitchell-Netravali filter with parameters b, c on [-2, 2] (scaled to radius r).
float mitchell_1d(float x, float r, float b, float c) {
    x = abs(2.0 * x / r);
    float x2 = x * x, x3 = x2 * x;
    float v;
    if (x > 2.0) v = 0.0;
    else if (x > 1.0)
        v = (-b - 6.0 * c) * x3 + (6.0 * b + 30.0 * c) * x2 + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c);
    else
        v = (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b);
    return v / 6.0;
}

// Filter offset in pixels for u in [0,1)^2, and the sample's weight.
// params: x radius, y Gaussian stddev, z Mitchell B, w Mitchell C.
vec2 sample_pixel_filter(vec2 u, vec4 params, out float weight) {
    float r = params.x;
    weight = 1.0;
    if (kFilter == kFilterBox) return (2.0 * u - 1.0) * r;
    if (kFilter == kFilterTent) return vec2(sample_tent(u.x, r), sample_tent(u.y, r));
    if (kFilter == kFilterGaussian) {
        float s = params.y;
        float k = s * 1.41421356237;
        float e = erf_approx(r / k);
        vec2 x = k * vec2(erf_inv_approx((2.0 * u.x - 1.0) * e), erf_inv_approx((2.0 * u.y - 1.0) * e));
        x = clamp(x, -r, r);
        // f1 = g - g(r), sampled with density g / ∫g: weight (1 - g(r)/g(x)) * ∫g / ∫(g - g(r))
        float g_r = exp(-r * r / (2.0 * s * s));
        float integral_g = k * 1.77245385091 * e;        // ∫_{-r}^{r} g
        float norm = integral_g / (integral_g - 2.0 * r * g_r);
        vec2 g = exp(-x * x / (2.0 * s * s));
        vec2 w = (1.0 - g_r / g) * norm;
        weight = w.x * w.y;
        return x;
    }
    // Mitchell: uniform over the support; ∫ f1 over [-r, r] = r / 2 (the B, C family integrates to 1 on [-2, 2]).
    vec2 x = (2.0 * u - 1.0) * r;
    float integral = 0.5 * r;
    weight = (2.0 * r * mitchell_1d(x.x, r, params.z, params.w) / integral) *
             (2.0 * r * mitchell_1d(x.y, r, params.z, params.w) / integral);
    return x;
}
