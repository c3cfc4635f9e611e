#include "integrators/photon/error_estimate.h"

#include <algorithm>
#include <cmath>

namespace gp {

double normal_quantile(double p) {
  // Acklam's rational approximation, refined by one Halley step (|error| < 1e-12).
  p = std::clamp(p, 1e-300, 1.0 - 1e-16);
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                             1.383577518672690e+02, -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00, 2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  double x;
  if (p < 0.02425) {
    const double q = std::sqrt(-2 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  } else if (p <= 1 - 0.02425) {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  } else {
    const double q = std::sqrt(-2 * std::log(1 - p));
    x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
  }
  const double e = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
  const double u = e * std::sqrt(2 * M_PI) * std::exp(x * x / 2);
  return x - u / (1 + x * u / 2);
}

double student_t_quantile(double dof, double p) {
  if (dof <= 1) return std::tan(M_PI * (p - 0.5));
  if (dof <= 2) return (2 * p - 1) / std::sqrt(2 * p * (1 - p));
  // Cornish-Fisher expansion (Abramowitz & Stegun 26.7.5).
  const double z = normal_quantile(p), z2 = z * z, v = dof;
  const double g1 = (z2 + 1) * z / 4;
  const double g2 = ((5 * z2 + 16) * z2 + 3) * z / 96;
  const double g3 = (((3 * z2 + 19) * z2 + 17) * z2 - 15) * z / 384;
  const double g4 = ((((79 * z2 + 776) * z2 + 1482) * z2 - 1920) * z2 - 945) * z / 92160;
  return z + g1 / v + g2 / (v * v) + g3 / (v * v * v) + g4 / (v * v * v * v);
}

FoldedNormalQuantile::FoldedNormalQuantile(double confidence) : one_tail_(normal_quantile(confidence)) {
  auto Phi = [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); };
  const int n = static_cast<int>(kMax / kStep) + 1;
  table_.resize(n);
  for (int k = 0; k < n; ++k) {
    const double m = k * kStep;
    double lo = 0, hi = m + 10;
    for (int it = 0; it < 60; ++it) {
      const double q = 0.5 * (lo + hi);
      (Phi(q - m) - Phi(-q - m) < confidence ? lo : hi) = q;
    }
    table_[k] = 0.5 * (lo + hi);
  }
}

double FoldedNormalQuantile::operator()(double m) const {
  m = std::abs(m);
  if (!(m < kMax)) return m + one_tail_;
  const double x = m / kStep;
  const size_t k = static_cast<size_t>(x);
  const double f = x - static_cast<double>(k);
  return table_[k] * (1 - f) + table_[std::min(k + 1, table_.size() - 1)] * f;
}

double folded_normal_mean(double m, double s, double dof) {
  if (dof < 1 || !std::isfinite(s)) return INFINITY;
  m = std::abs(m);
  // s / c4: E[s] = c4 sigma for the sample sd of dof + 1 normal samples,
  // c4 = sqrt(2 / v) Gamma((v + 1) / 2) / Gamma(v / 2).
  s /= std::sqrt(2 / dof) * std::exp(std::lgamma((dof + 1) / 2) - std::lgamma(dof / 2));
  if (s <= 0) return m;
  // Mean of the folded normal |N(m, s^2)|.
  return s * std::sqrt(2 / M_PI) * std::exp(-m * m / (2 * s * s)) + m * std::erf(m / (s * std::sqrt(2.0)));
}

}  // namespace gp
