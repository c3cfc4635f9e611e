#include "lights/background.h"

#include <fmt/format.h>

#include <stdexcept>

namespace gp {

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
