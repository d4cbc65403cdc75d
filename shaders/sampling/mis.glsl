// Multiple importance sampling weights: the balance and power (beta = 2) heuristics, for two or n techniques.
//
// Veach & Guibas, "Optimally Combining Sampling Techniques for Monte Carlo Rendering",
// SIGGRAPH 1995; Veach's thesis 1997, eq. 9.13 (balance) and 9.15 (power). Technique i
// takes n_i samples with density pdf_i; the weight of a sample x of technique f is
//     balance: n_f p_f(x) / sum_i n_i p_i(x),    power: (n_f p_f)^2 / sum_i (n_i p_i)^2,
// so that the weights of all techniques sum to 1 wherever some p_i(x) > 0. Densities
// must share one measure (convert area densities to solid angle first).
// Guards: a weight is 0, never NaN, when every n_i p_i is 0 or when several are
// infinite; a single infinite n_i p_i (a delta technique) takes weight 1. The weights
// are computed as ratios to the largest term, so no product overflows in float32.

const int kMisMaxTechniques = 8;

// Weight of technique f against g with exponent beta (1 balance, 2 power): 1 / (1 +
// (g / f)^beta), with the guards above.
float mis_weight_ratio(float f, float g, float beta) {
    if (!(f > 0.0) || (isinf(f) && isinf(g))) return 0.0;
    float r = g / f;  // 0 if f is infinite, infinite if g is and f is not
    float w = 1.0 / (1.0 + (beta == 1.0 ? r : r * r));
    return isnan(w) ? 0.0 : w;  // a NaN g
}

// Balance heuristic weight of technique f (n_f samples, density pdf_f at the sample)
// against technique g: n_f pdf_f / (n_f pdf_f + n_g pdf_g).
float mis_balance(float n_f, float pdf_f, float n_g, float pdf_g) {
    return mis_weight_ratio(n_f * pdf_f, n_g * pdf_g, 1.0);
}

// Power heuristic (beta = 2) weight of technique f against g:
// (n_f pdf_f)^2 / ((n_f pdf_f)^2 + (n_g pdf_g)^2).
float mis_power(float n_f, float pdf_f, float n_g, float pdf_g) {
    return mis_weight_ratio(n_f * pdf_f, n_g * pdf_g, 2.0);
}

// Weight of technique k among the first count (<= kMisMaxTechniques) techniques, with
// n[i] samples and density pdf[i] at the sample, for exponent beta (1 or 2).
float mis_weight_n(float n[kMisMaxTechniques], float pdf[kMisMaxTechniques], int count, int k,
                   float beta) {
    float f[kMisMaxTechniques];
    float largest = 0.0;
    int infinite = 0;
    for (int i = 0; i < kMisMaxTechniques; ++i) {
        f[i] = i < count ? n[i] * pdf[i] : 0.0;
        largest = max(largest, f[i]);
        infinite += isinf(f[i]) ? 1 : 0;
    }
    if (!(largest > 0.0) || k < 0 || k >= count) return 0.0;
    if (infinite > 0) return (infinite == 1 && isinf(f[k])) ? 1.0 : 0.0;
    float sum = 0.0;
    for (int i = 0; i < kMisMaxTechniques; ++i) {
        float r = f[i] / largest;
        sum += beta == 1.0 ? r : r * r;
    }
    float r_k = f[k] / largest;
    return (beta == 1.0 ? r_k : r_k * r_k) / sum;
}

// Balance heuristic weight of technique k among count techniques (Veach eq. 9.13).
float mis_balance_n(float n[kMisMaxTechniques], float pdf[kMisMaxTechniques], int count, int k) {
    return mis_weight_n(n, pdf, count, k, 1.0);
}

// Power heuristic (beta = 2) weight of technique k among count techniques (Veach eq. 9.15).
float mis_power_n(float n[kMisMaxTechniques], float pdf[kMisMaxTechniques], int count, int k) {
    return mis_weight_n(n, pdf, count, k, 2.0);
}
