// Chi-square goodness of fit for the statistical tests (bsdf_test's direction samplers,
// msppm_test's path-vertex densities): the p-value function and Pearson's statistic over
// histogram cells with low-expectation cells pooled (after pbrt-v4's Chi2Test).
#pragma once

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace gp {

// Regularized upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a), the p-value of
// a chi-square statistic chi2 with k degrees of freedom being Q(k / 2, chi2 / 2). Series for
// P = 1 - Q when x < a + 1, Lentz's continued fraction for Q otherwise (Numerical Recipes,
// 3rd ed., §6.2, gser/gcf).
inline double gamma_q(double a, double x) {
  if (a <= 0 || x < 0) return std::nan("");
  if (x == 0) return 1.0;
  const double log_prefactor = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1) {
    double ap = a, term = 1.0 / a, sum = term;
    for (int n = 0; n < 10000; ++n) {
      ap += 1;
      term *= x / ap;
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return std::max(0.0, 1.0 - sum * std::exp(log_prefactor));
  }
  constexpr double kTiny = 1e-300;
  double b = x + 1 - a, c = 1 / kTiny, d = 1 / b, h = d;
  for (int i = 1; i < 10000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-16) break;
  }
  return std::exp(log_prefactor) * h;
}

struct Chi2Result {
  double statistic = 0;
  int dof = 0;
  double p_value = 0;
  double pdf_integral = 0;        // integral of pdf over the domain (<= 1: rejected samples)
  double accepted_fraction = 0;   // samples that came back
  size_t zero_expected_hits = 0;  // samples in cells of zero expected count
  std::string error;              // set when the test could not be run
};

// Pearson's statistic of observed against expected counts (same cells, the counts summing to
// the same total), cells with expected < min_expected pooled together, and its p-value (dof =
// cells - 1, no fitted parameters). Samples in cells of zero expectation are counted apart.
inline void pearson_pooled(const std::vector<double>& observed, const std::vector<double>& expected,
                           double min_expected, Chi2Result& r) {
  std::vector<size_t> order(expected.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double pooled_obs = 0, pooled_exp = 0;
  for (size_t b : order) {
    if (expected[b] == 0) {
      // Samples where the pdf is zero: the sampler and pdf disagree about the support.
      r.zero_expected_hits += static_cast<size_t>(observed[b]);
    } else if (expected[b] < min_expected || (pooled_exp > 0 && pooled_exp < min_expected)) {
      pooled_obs += observed[b];
      pooled_exp += expected[b];
    } else {
      r.statistic += (observed[b] - expected[b]) * (observed[b] - expected[b]) / expected[b];
      ++r.dof;
    }
  }
  if (pooled_exp > 0) {
    r.statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
    ++r.dof;
  }
  r.dof -= 1;
  if (r.dof <= 0) {
    r.error = "too few degrees of freedom (" + std::to_string(r.dof) + ")";
    return;
  }
  r.p_value = gamma_q(0.5 * r.dof, 0.5 * r.statistic);
}

}  // namespace gp
