// Display transforms: linear radiance -> display values in [0, 1], the GLSL twin of
// glrender/film/tonemap.py (tests/preview/test_display.py checks them against each other).
//
// The pipeline is an exposure scale, a tone curve, then the sRGB transfer function
// (IEC 61966-2-1) or none. Curves:
// - clamp: values above 1 are clipped;
// - filmic: John Hable's Uncharted 2 curve (GDC 2010) with exposure bias 2 and white
//   point W = 11.2 (radiance 5.6 maps to white);
// - aces: Stephen Hill's fit of the ACES RRT + sRGB ODT (BakingLab, ACES.hlsl).

const int kToneCurveClamp = 0;
const int kToneCurveFilmic = 1;
const int kToneCurveAces = 2;

const float kHableWhite = 11.2;
const float kHableBias = 2.0;

// Hill's matrices, written row by row: `v * m` with m = mat3(rows) is the matrix
// product M v of the row-major listing.
const mat3 kAcesInput = mat3(0.59719, 0.35458, 0.04823,
                             0.07600, 0.90834, 0.01566,
                             0.02840, 0.13383, 0.83777);
const mat3 kAcesOutput = mat3(1.60475, -0.53108, -0.07367,
                              -0.10208, 1.10813, -0.00605,
                              -0.00327, -0.07276, 1.07602);

// Hable's rational curve before normalisation; x in [0, 1e30] (linear radiance, scaled).
// Numerator and denominator are divided by max(x, 1) so that x^2 cannot overflow.
vec3 hable_partial(vec3 x) {
    const float a = 0.15, b = 0.50, c = 0.10, d = 0.20, e = 0.02, f = 0.30;
    vec3 s = max(x, vec3(1.0));
    vec3 r = x / s;
    return (r * (a * x + c * b) + d * e / s) / (r * (a * x + b) + d * f / s) - e / f;
}

// Hable's filmic curve: 0 -> 0, W / bias -> 1; x: linear RGB (negative values clamp to 0).
// Returns display-linear RGB in [0, 1].
vec3 tone_curve_filmic(vec3 x) {
    vec3 white = hable_partial(vec3(kHableWhite));
    return clamp(hable_partial(kHableBias * max(x, vec3(0.0))) / white, 0.0, 1.0);
}

// Hill's ACES fit; rgb: linear sRGB (negative values clamp to 0).
// Returns display-linear sRGB in [0, 1].
vec3 tone_curve_aces(vec3 rgb) {
    vec3 v = max(rgb, vec3(0.0)) * kAcesInput;
    vec3 s = max(v, vec3(1.0));  // divides the rational fit's terms: v^2 cannot overflow
    vec3 r = v / s;
    v = (r * (v + 0.0245786) - 0.000090537 / s) / (r * (0.983729 * v + 0.4329510) + 0.238081 / s);
    return clamp(v * kAcesOutput, 0.0, 1.0);
}

// One of the curves kToneCurve*; rgb: linear RGB. Returns display-linear RGB in [0, 1].
vec3 tone_curve(vec3 rgb, int curve) {
    if (curve == kToneCurveFilmic) return tone_curve_filmic(rgb);
    if (curve == kToneCurveAces) return tone_curve_aces(rgb);
    return clamp(rgb, 0.0, 1.0);
}

// The sRGB transfer function; x: display-linear values (clipped to [0, 1]).
vec3 linear_to_srgb(vec3 x) {
    x = clamp(x, 0.0, 1.0);
    vec3 curved = 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055;
    return mix(curved, 12.92 * x, lessThanEqual(x, vec3(0.0031308)));
}

// Linear RGB -> display values in [0, 1]: scale (2^exposure), tone curve, then sRGB
// encoding when `srgb`. NaN becomes 0 and +inf the curve's white, as in tonemap.py.
vec3 display_encode(vec3 rgb, float scale, int curve, bool srgb) {
    rgb = mix(rgb, vec3(0.0), isnan(rgb));
    vec3 display = tone_curve(min(max(rgb, vec3(0.0)) * scale, vec3(1e30)), curve);
    return srgb ? linear_to_srgb(display) : display;
}
