// Warps from the unit square to the domains the integrators sample, with their densities,
// a discrete distribution for light selection, and the MIS heuristics.
#pragma once

#include <span>
#include <vector>

#include "core/color.h"
#include "core/math.h"

namespace gp {

Vec2 sample_uniform_disk_concentric(Vec2 u);
Vec3 sample_cosine_hemisphere(Vec2 u);            // local frame, z up
inline float cosine_hemisphere_pdf(float cos_theta) { return cos_theta * kInvPi; }
Vec3 sample_uniform_sphere(Vec2 u);
inline float uniform_sphere_pdf() { return kInv4Pi; }
Vec3 sample_uniform_hemisphere(Vec2 u);
inline float uniform_hemisphere_pdf() { return kInv2Pi; }
// Uniform direction inside a cone around +z with cos of the half-angle `cos_max`.
Vec3 sample_uniform_cone(Vec2 u, float cos_max);
inline float uniform_cone_pdf(float cos_max) { return 1.0f / (2.0f * kPi * (1.0f - cos_max)); }
// Barycentrics (b0, b1) uniform over a triangle (the third is 1 - b0 - b1).
Vec2 sample_uniform_triangle(Vec2 u);

// Power heuristic with beta = 2 (Veach 1997, eq. 9.13), for one sample of each strategy.
inline float power_heuristic(float pdf_a, float pdf_b) {
  const float a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  if (std::isinf(a)) return 1.0f;
  return a + b > 0 ? a / (a + b) : 0.0f;
}
inline float balance_heuristic(float pdf_a, float pdf_b) {
  return pdf_a + pdf_b > 0 ? pdf_a / (pdf_a + pdf_b) : 0.0f;
}

// Russian roulette on a path throughput: the path survives with probability
// 1 - q, q = max(0.05, 1 - max(beta)), and beta is divided by it. Returns false when it ends.
// `survival` (optional) receives 1 - q, for paths that share the decision (GPM's offsets).
inline bool russian_roulette(RGB& beta, float u, float* survival = nullptr) {
  const float q = std::max(0.05f, 1.0f - beta.max_component());
  if (u < q) return false;
  beta = beta / (1.0f - q);
  if (survival) *survival = 1.0f - q;
  return true;
}

// Russian roulette's survival probability on a camera path (paths/camera_path.h: pt, spt,
// spt-hero) of largest throughput channel m, taken with the 1/eta^2 radiance scaling of its
// refractions divided out (pbrt-v4's etaScale: inside a clear glass ball m stays 1, not 1/1.5^2)
// and no 0.95 cap (max_depth ends paths): survivors keep a weight near 1 (docs/benchmarks.md,
// issue 31: a glass ball under an HDRI).
inline float camera_path_survival(float m) { return std::min(1.0f, m); }

// Piecewise-constant discrete distribution: sample an index with probability w_i / sum(w).
class DiscreteDistribution {
 public:
  DiscreteDistribution() = default;
  explicit DiscreteDistribution(std::span<const float> weights);
  bool empty() const { return pmf_.empty(); }
  size_t size() const { return pmf_.size(); }
  float total() const { return total_; }
  float pmf(size_t i) const { return pmf_[i]; }
  // Returns the index; `u_remapped` (optional) receives u rescaled to [0,1) within the bucket.
  size_t sample(float u, float* u_remapped = nullptr) const;

 private:
  std::vector<float> pmf_, cdf_;
  float total_ = 0;
};

// Piecewise-constant density over [0,1]^2 from an nu x nv grid of non-negative values (row v,
// column u; pbrt-v3's Distribution2D, PBR 3rd ed. §13.6.7): a marginal over rows, a conditional
// over each row's cells, continuous samples inside the chosen cell. Sums run in double, so an
// 8192 x 4096 map with a sun of 1e5 beside a sky of 1e-2 keeps every cell's probability.
class PiecewiseConstant2D {
 public:
  PiecewiseConstant2D() = default;
  // f: nv rows of nu values (NaN or negative read as 0). All zero: uniform.
  PiecewiseConstant2D(const float* f, int nu, int nv);
  bool empty() const { return nu_ == 0; }
  int nu() const { return nu_; }
  int nv() const { return nv_; }
  // The grid's mean value (its integral over the unit square).
  double integral() const { return integral_; }
  // A point of [0,1)^2 and its density per unit area of the square.
  Vec2 sample(Vec2 u, float* pdf) const;
  float pdf(Vec2 p) const;
  size_t bytes() const { return (cond_cdf_.size() + marg_cdf_.size() + cond_pdf_.size()) * sizeof(float); }

 private:
  int nu_ = 0, nv_ = 0;
  double integral_ = 0;
  std::vector<float> cond_pdf_;  // nv x nu: density of u within row v (mean 1 over the row)
  std::vector<float> cond_cdf_;  // nv x (nu + 1)
  std::vector<float> marg_pdf_;  // nv: density of v
  std::vector<float> marg_cdf_;  // nv + 1
};

}  // namespace gp
