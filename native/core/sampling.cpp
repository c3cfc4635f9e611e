#include "core/sampling.h"

#include <algorithm>
#include <limits>

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
