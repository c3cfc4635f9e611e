#include "lights/background.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/parallel.h"
#include "lights/environment_map.h"

namespace gp {

BakedTerms bake_direction_terms(int W, int H, int S, int threads, int K,
                                const std::function<void(const Vec3&, RGB*)>& radiance) {
  BakedTerms t;
  t.W = W;
  t.H = H;
  t.luminance.assign(size_t(K), std::vector<float>(size_t(W) * H));
  std::vector<RGB> rows(size_t(H) * K, RGB(0.0f));  // per row and term: the sum of its cells
  parallel_for(static_cast<size_t>(H), threads, [&](size_t j0, size_t j1) {
    std::vector<RGB> value(static_cast<size_t>(K)), c(static_cast<size_t>(K));
    for (size_t j = j0; j != j1; ++j) {
      for (int i = 0; i < W; ++i) {
        std::fill(c.begin(), c.end(), RGB(0.0f));
        for (int sj = 0; sj < S; ++sj)
          for (int si = 0; si < S; ++si) {
            radiance(EnvironmentMap::equirectangular_direction(Vec2((i + (si + 0.5f) / S) / W, (j + (sj + 0.5f) / S) / H)),
                     value.data());
            for (int k = 0; k < K; ++k) c[k] += value[k];
          }
        for (int k = 0; k < K; ++k) {
          c[k] = c[k] * (1.0f / float(S * S));
          rows[j * K + k] += c[k];
          t.luminance[k][j * W + i] = c[k].luminance();
        }
      }
    }
  });
  t.integral.assign(size_t(K), {0.0, 0.0, 0.0});
  for (int j = 0; j < H; ++j) {
    const double band = std::abs(std::cos(M_PI * j / H) - std::cos(M_PI * (j + 1) / H));  // solid angle / 2pi
    for (int k = 0; k < K; ++k)
      for (int ch = 0; ch < 3; ++ch) t.integral[k][ch] += rows[j * K + k][ch] * 2.0 * M_PI * band / W;
    t.uniform_integral += static_cast<float>(W) * 2.0 * M_PI * band / W;
  }
  return t;
}

BakedDirections combine_direction_terms(const BakedTerms& t, const std::vector<float>& weights, RGB constant) {
  const int W = t.W, H = t.H;
  const size_t K = t.luminance.size();
  if (weights.size() != K) throw std::invalid_argument("combine_direction_terms: one weight per term");
  const float lc = constant.luminance();
  std::vector<float> f(size_t(W) * H);
  double mean = 0;
  for (int j = 0; j < H; ++j) {
    const float st = std::sin(kPi * (j + 0.5f) / H);
    for (int i = 0; i < W; ++i) {
      const size_t c = size_t(j) * W + i;
      float v = 0.0f;
      for (size_t k = 0; k < K; ++k) v += weights[k] * t.luminance[k][c];
      if (lc != 0.0f) v += lc;
      f[c] = std::isfinite(v) ? std::max(v, 0.0f) * st : 0.0f;  // (an overflowing weight lights nothing, as eval)
      mean += f[c];
    }
  }
  mean /= double(W) * H;
  for (float& v : f) v = std::max(v, static_cast<float>(1e-3 * mean));
  if (!(mean > 0)) std::fill(f.begin(), f.end(), 1.0f);  // black to light samples: uniform
  double sum[3] = {0, 0, 0};
  for (int ch = 0; ch < 3; ++ch) {
    for (size_t k = 0; k < K; ++k) sum[ch] += weights[k] * t.integral[k][ch];
    if (constant[ch] != 0.0f) sum[ch] += constant[ch] * t.uniform_integral;
    sum[ch] = std::isfinite(float(sum[ch])) ? std::max(sum[ch], 0.0) : 0.0;
  }
  return {PiecewiseConstant2D(f.data(), W, H), RGB(float(sum[0]), float(sum[1]), float(sum[2]))};
}

size_t BakedTerms::bytes() const {
  size_t n = 0;
  for (const auto& l : luminance) n += l.size() * sizeof(float);
  return n;
}

BakedDirections bake_directions(int W, int H, int S, int threads, const std::function<RGB(const Vec3&)>& radiance) {
  // One term of weight 1: the same floats as summing it alone.
  const BakedTerms t = bake_direction_terms(W, H, S, threads, 1, [&](const Vec3& d, RGB* out) { out[0] = radiance(d); });
  return combine_direction_terms(t, {1.0f}, RGB(0.0f));
}

bool BakedDirections::sample(Vec2 u, Vec3* dir) const {
  float pdf_uv = 0;
  const Vec2 uv = grid.sample(u, &pdf_uv);
  if (!(pdf_uv > 0)) return false;
  *dir = EnvironmentMap::equirectangular_direction(uv);
  return true;
}

float BakedDirections::density(const Vec3& dir) const {
  const float st = std::sqrt(std::max(0.0f, 1.0f - dir.z * dir.z));
  return st > 0 ? grid.pdf(EnvironmentMap::equirectangular_uv(dir)) / (2.0f * kPi * kPi * st) : 0.0f;
}

bool ConstantBackground::sample(Vec2 u, Vec3* dir, float* pdf) const {
  *dir = sample_uniform_sphere(u);
  *pdf = uniform_sphere_pdf();
  return true;
}

std::string ConstantBackground::identity() const {
  return fmt::format("constant {} {} {}", radiance_.r, radiance_.g, radiance_.b);
}

std::string ScaledBackground::identity() const {
  return fmt::format("{} x ({} {} {})", term_->identity(), scale_.r, scale_.g, scale_.b);
}

TransformedBackground::TransformedBackground(std::shared_ptr<const BackgroundTerm> term, const float a[3][3])
    : term_(std::move(term)) {
  if (!term_) throw std::invalid_argument("a transformed background without a background");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(a[r][c])) throw std::invalid_argument("the sky's vector transform is not finite");
      m_[r][c] = a[r][c];
    }
  const double det = double(a[0][0]) * (double(a[1][1]) * a[2][2] - double(a[1][2]) * a[2][1]) -
                     double(a[0][1]) * (double(a[1][0]) * a[2][2] - double(a[1][2]) * a[2][0]) +
                     double(a[0][2]) * (double(a[1][0]) * a[2][1] - double(a[1][1]) * a[2][0]);
  if (!(std::abs(det) > 1e-12)) throw std::invalid_argument("the sky's vector transform is singular (zero scale?)");
  det_ = static_cast<float>(std::abs(det));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {  // inverse = adjugate / det
      const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
      inv_[r][c] = static_cast<float>((double(a[r1][c1]) * a[r2][c2] - double(a[r1][c2]) * a[r2][c1]) / det);
    }
}

Vec3 TransformedBackground::to_term(const Vec3& d) const {
  return {m_[0][0] * d.x + m_[0][1] * d.y + m_[0][2] * d.z, m_[1][0] * d.x + m_[1][1] * d.y + m_[1][2] * d.z,
          m_[2][0] * d.x + m_[2][1] * d.y + m_[2][2] * d.z};
}

RGB TransformedBackground::eval(const Vec3& dir) const {
  const Vec3 v = to_term(dir);
  const float len = length(v);
  return len > 0 && std::isfinite(len) ? term_->eval(v / len) : RGB(0.0f);
}

RGB TransformedBackground::eval(const Vec3& dir, const RayState& ray) const {
  const Vec3 v = to_term(dir);
  const float len = length(v);
  return len > 0 && std::isfinite(len) ? term_->eval(v / len, ray) : RGB(0.0f);
}

bool TransformedBackground::sample(Vec2 u, Vec3* dir, float* pdf) const {
  Vec3 v;
  float p = 0;
  if (!term_->sample(u, &v, &p)) return false;
  const Vec3 w(inv_[0][0] * v.x + inv_[0][1] * v.y + inv_[0][2] * v.z, inv_[1][0] * v.x + inv_[1][1] * v.y + inv_[1][2] * v.z,
               inv_[2][0] * v.x + inv_[2][1] * v.y + inv_[2][2] * v.z);
  const float len = length(w);
  if (!(len > 0) || !std::isfinite(len)) return false;
  *dir = w / len;
  // |M d| = 1 / |M^-1 v| for d = M^-1 v / |M^-1 v|.
  *pdf = p * det_ * len * len * len;
  return std::isfinite(*pdf) && *pdf > 0;
}

float TransformedBackground::pdf(const Vec3& dir) const {
  const Vec3 v = to_term(dir);
  const float len = length(v);
  if (!(len > 0) || !std::isfinite(len)) return 0.0f;
  const float p = term_->pdf(v / len) * det_ / (len * len * len);
  return std::isfinite(p) ? p : 0.0f;
}

std::string TransformedBackground::identity() const {
  return fmt::format("{} along [{} {} {}; {} {} {}; {} {} {}]", term_->identity(), m_[0][0], m_[0][1], m_[0][2], m_[1][0],
                     m_[1][1], m_[1][2], m_[2][0], m_[2][1], m_[2][2]);
}

BackgroundSum::BackgroundSum(std::vector<std::shared_ptr<const BackgroundTerm>> terms) {
  std::vector<float> weights;
  for (auto& t : terms) {
    if (!t) continue;
    const float w = t->integral().average();
    if (!(w > 0) || !std::isfinite(w)) continue;
    weights.push_back(w);
    terms_.push_back(std::move(t));
  }
  if (terms_.empty()) throw std::invalid_argument("a sum of backgrounds with no light in it");
  pick_ = DiscreteDistribution(weights);
}

RGB BackgroundSum::eval(const Vec3& dir) const {
  RGB L(0.0f);
  for (const auto& t : terms_) L += t->eval(dir);
  return L;
}

RGB BackgroundSum::eval(const Vec3& dir, const RayState& ray) const {
  RGB L(0.0f);
  for (const auto& t : terms_) L += t->eval(dir, ray);
  return L;
}

bool BackgroundSum::sample(Vec2 u, Vec3* dir, float* pdf) const {
  float u_rest = 0;
  const size_t i = pick_.sample(u.x, &u_rest);
  float pdf_i = 0;
  if (!terms_[i]->sample(Vec2(u_rest, u.y), dir, &pdf_i)) return false;
  // The mixture's density (one-sample MIS, balance heuristic): every term's, not only i's.
  *pdf = this->pdf(*dir);
  return std::isfinite(*pdf) && *pdf > 0;
}

float BackgroundSum::pdf(const Vec3& dir) const {
  float p = 0;
  for (size_t i = 0; i < terms_.size(); ++i) p += pick_.pmf(i) * terms_[i]->pdf(dir);
  return p;
}

RGB BackgroundSum::integral() const {
  RGB s(0.0f);
  for (const auto& t : terms_) s += t->integral();
  return s;
}

std::string BackgroundSum::identity() const {
  std::string s = "sum";
  for (const auto& t : terms_) s += " [" + t->identity() + "]";
  return s;
}

}  // namespace gp
