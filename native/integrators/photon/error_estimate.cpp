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

double local_linear_radiance(const DiscShape& d, double own, double mu, double mv) {
  if (!(d.a > 1e-3)) return own;
  // own = a L + c . g, (mu, mv) = c L + S g: eliminate g = S^-1 (m - c L).
  const double det = d.suu * d.svv - d.suv * d.suv;
  const double whole = d.suu + d.svv;  // R^2 / 2 for a whole disc
  if (!(det > 1e-2 * whole * whole / 4)) return own / d.a;
  const double iuu = d.svv / det, iuv = -d.suv / det, ivv = d.suu / det;  // S^-1
  const double cSc = d.cu * (iuu * d.cu + iuv * d.cv) + d.cv * (iuv * d.cu + ivv * d.cv);
  const double cSm = d.cu * (iuu * mu + iuv * mv) + d.cv * (iuv * mu + ivv * mv);
  const double denom = d.a - cSc;
  if (!(denom > 1e-2 * d.a)) return own / d.a;
  return (own - cSm) / denom;
}

void BoundarySums::add(const DiscShape& d, double own, double foreign, double mu, double mv) {
  shape.a += d.a;
  shape.cu += d.cu;
  shape.cv += d.cv;
  shape.suu += d.suu;
  shape.suv += d.suv;
  shape.svv += d.svv;
  const double v[4] = {own, foreign, mu, mv};
  for (int i = 0, k = 0; i < 4; ++i) {
    x[i] += v[i];
    for (int j = i; j < 4; ++j) xx[k++] += v[i] * v[j];
  }
  ++n;
}

BoundarySums::Bias BoundarySums::bias() const {
  if (n == 0 || (shape.a >= n && x[1] == 0)) return {};
  // The fit on the sums: L = (OWN - c' S^-1 M) / (A - c' S^-1 c) (local_linear_radiance, whose
  // sums scale with n on both sides).
  const double N = n;
  const double L = local_linear_radiance(shape, x[0], x[2], x[3]);
  // The same L as a linear form of the sums, L = (OWN - k . M) / D with k and D from the shape:
  // each pass contributes z_j = own_j + foreign_j - (own_j - k . m_j) / (D / n); the bias is their
  // mean and its standard error their spread's.
  double ku = 0, kv = 0, D = shape.a;
  const double det = shape.suu * shape.svv - shape.suv * shape.suv;
  const double whole = shape.suu + shape.svv;
  if (det > 1e-2 * whole * whole / 4) {
    ku = (shape.svv * shape.cu - shape.suv * shape.cv) / det;
    kv = (shape.suu * shape.cv - shape.suv * shape.cu) / det;
    const double d2 = D - (ku * shape.cu + kv * shape.cv);
    if (d2 > 1e-2 * D) D = d2;
    else ku = kv = 0;
  }
  if (!(D > 1e-3 * N)) return {};
  const double Dn = D / N;
  // Sample variance over the passes of w . (own, foreign, mu, mv), from the sums.
  auto variance = [&](const double (&w)[4]) {
    if (n < 2) return 0.0;
    double mean = 0, mean2 = 0;
    for (int i = 0, k = 0; i < 4; ++i) {
      mean += w[i] * x[i] / N;
      for (int j = i; j < 4; ++j, ++k) mean2 += (i == j ? 1 : 2) * w[i] * w[j] * xx[k] / N;
    }
    return std::max(0.0, (mean2 - mean * mean) * N / (N - 1));
  };
  const double z[4] = {1 - 1 / Dn, 1, ku / Dn, kv / Dn};  // z_j: the pass's bias
  const double q[4] = {1 / Dn, 0, -ku / Dn, -kv / Dn};    // own_j + foreign_j - z_j: the fit's form
  const double p[4] = {1, 1, 0, 0};                       // own_j + foreign_j: the estimate
  return {(x[0] + x[1]) / N - L, std::sqrt(variance(z) / N), (variance(q) - variance(p)) / N};
}

}  // namespace gp
