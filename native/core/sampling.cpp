#include "core/sampling.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel.h"

namespace gp {

Vec2 sample_uniform_disk_concentric(Vec2 u) {
  // Shirley–Chiu concentric mapping: preserves strata, no distortion at the centre.
  const Vec2 o = u * 2.0f - Vec2(1, 1);
  if (o.x == 0 && o.y == 0) return {0, 0};
  float r, theta;
  if (std::abs(o.x) > std::abs(o.y)) {
    r = o.x;
    theta = (kPi / 4) * (o.y / o.x);
  } else {
    r = o.y;
    theta = kPi / 2 - (kPi / 4) * (o.x / o.y);
  }
  return {r * std::cos(theta), r * std::sin(theta)};
}

Vec3 sample_cosine_hemisphere(Vec2 u) {
  const Vec2 d = sample_uniform_disk_concentric(u);
  const float z = safe_sqrt(1.0f - d.x * d.x - d.y * d.y);
  return {d.x, d.y, z};
}

Vec3 sample_uniform_sphere(Vec2 u) {
  const float z = 1.0f - 2.0f * u.x;
  const float r = safe_sqrt(1.0f - z * z);
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Vec3 sample_uniform_hemisphere(Vec2 u) {
  const float z = u.x;
  const float r = safe_sqrt(1.0f - z * z);
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Vec3 sample_uniform_cone(Vec2 u, float cos_max) {
  const float z = (1.0f - u.x) + u.x * cos_max;
  const float r = safe_sqrt(1.0f - z * z);
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

Vec2 sample_uniform_triangle(Vec2 u) {
  // Square-root parameterisation (Osada et al. 2002).
  const float su = std::sqrt(u.x);
  return {1.0f - su, u.y * su};
}

DiscreteDistribution::DiscreteDistribution(std::span<const float> weights) {
  // Sums in double: a handful of extreme weights (a 1e38 W light) must not overflow to Inf.
  pmf_.resize(weights.size());
  cdf_.resize(weights.size());
  std::vector<double> w(weights.size());
  double sum = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    const float v = weights[i];
    w[i] = std::isnan(v) || v < 0 ? 0.0 : std::min<double>(v, std::numeric_limits<float>::max());
    sum += w[i];
  }
  total_ = static_cast<float>(std::min<double>(sum, std::numeric_limits<float>::max()));
  double running = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    // All-zero weights fall back to uniform so sampling stays defined.
    const double p = sum > 0 ? w[i] / sum : 1.0 / w.size();
    running += p;
    pmf_[i] = static_cast<float>(p);
    cdf_[i] = static_cast<float>(running);
  }
  if (!cdf_.empty()) cdf_.back() = 1.0f;
}

size_t DiscreteDistribution::sample(float u, float* u_remapped) const {
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  size_t i = std::min<size_t>(it - cdf_.begin(), cdf_.size() - 1);
  while (i > 0 && pmf_[i] == 0) --i;  // never return a zero-probability bucket
  if (u_remapped) {
    const float lo = i == 0 ? 0.0f : cdf_[i - 1];
    *u_remapped = std::min((u - lo) / pmf_[i], 0x1.fffffep-1f);
  }
  return i;
}

}  // namespace gp

namespace gp {

namespace {

// Density (mean 1) and CDF of one row of piecewise-constant values; returns the row's mean.
// An all-zero row is uniform, so sampling it stays defined (its weight in the marginal is 0).
double piecewise_1d(const float* f, int n, float* pdf, float* cdf) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const float v = f[i];
    sum += std::isnan(v) || v < 0 ? 0.0 : std::min<double>(v, std::numeric_limits<float>::max());
  }
  const double mean = sum / n;
  double running = 0;
  cdf[0] = 0;
  for (int i = 0; i < n; ++i) {
    const float v = f[i];
    const double w = std::isnan(v) || v < 0 ? 0.0 : std::min<double>(v, std::numeric_limits<float>::max());
    const double p = sum > 0 ? w / mean : 1.0;  // density over [0,1]
    pdf[i] = static_cast<float>(p);
    running += sum > 0 ? w / sum : 1.0 / n;
    cdf[i + 1] = static_cast<float>(running);
  }
  cdf[n] = 1.0f;
  return mean;
}

// Continuous sample of a 1D piecewise-constant density: the cell whose CDF interval holds u,
// then u's place inside it. Cells of zero probability are never returned.
float sample_1d(const float* pdf, const float* cdf, int n, float u, int* cell) {
  int i = static_cast<int>(std::upper_bound(cdf, cdf + n + 1, u) - cdf) - 1;
  i = std::clamp(i, 0, n - 1);
  while (i > 0 && pdf[i] == 0) --i;
  while (i < n - 1 && pdf[i] == 0) ++i;
  const float width = cdf[i + 1] - cdf[i];
  const float t = width > 0 ? std::clamp((u - cdf[i]) / width, 0.0f, 0x1.fffffep-1f) : 0.5f;
  *cell = i;
  return std::min((i + t) / n, 0x1.fffffep-1f);
}

}  // namespace

PiecewiseConstant2D::PiecewiseConstant2D(const float* f, int nu, int nv) : nu_(nu), nv_(nv) {
  if (nu <= 0 || nv <= 0) {
    nu_ = nv_ = 0;
    return;
  }
  cond_pdf_.resize(static_cast<size_t>(nu) * nv);
  cond_cdf_.resize(static_cast<size_t>(nu + 1) * nv);
  std::vector<float> row_mean(nv);
  parallel_for(static_cast<size_t>(nv), 0, [&](size_t begin, size_t end) {
    for (size_t v = begin; v != end; ++v)
      row_mean[v] = static_cast<float>(piecewise_1d(f + v * nu, nu, &cond_pdf_[v * nu], &cond_cdf_[v * (nu + 1)]));
  });
  marg_pdf_.resize(nv);
  marg_cdf_.resize(nv + 1);
  integral_ = piecewise_1d(row_mean.data(), nv, marg_pdf_.data(), marg_cdf_.data());
}

Vec2 PiecewiseConstant2D::sample(Vec2 u, float* pdf) const {
  int v = 0, c = 0;
  const float y = sample_1d(marg_pdf_.data(), marg_cdf_.data(), nv_, u.y, &v);
  const size_t row = static_cast<size_t>(v);
  const float x = sample_1d(&cond_pdf_[row * nu_], &cond_cdf_[row * (nu_ + 1)], nu_, u.x, &c);
  *pdf = marg_pdf_[v] * cond_pdf_[row * nu_ + c];
  return {x, y};
}

float PiecewiseConstant2D::pdf(Vec2 p) const {
  if (empty() || !(p.x >= 0 && p.x < 1 && p.y >= 0 && p.y < 1)) return 0.0f;
  const int v = std::min(static_cast<int>(p.y * nv_), nv_ - 1);
  const int c = std::min(static_cast<int>(p.x * nu_), nu_ - 1);
  return marg_pdf_[v] * cond_pdf_[static_cast<size_t>(v) * nu_ + c];
}

}  // namespace gp
