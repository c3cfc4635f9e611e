#include "lights/light.h"

namespace gp {

LightSet::LightSet(std::vector<Light> lights, const Bounds3& scene_bounds)
    : lights_(std::move(lights)) {
  scene_radius_ = scene_bounds.empty() ? 1.0f : 0.5f * length(scene_bounds.diagonal());
  std::vector<float> weights;
  for (size_t i = 0; i < lights_.size(); ++i) {
    if (lights_[i].type == LightType::Environment) environment_ = static_cast<int>(i);
    weights.push_back(power(static_cast<int>(i)));
  }
  if (!weights.empty()) select_ = DiscreteDistribution(weights);
}

float LightSet::power(int i) const {
  const Light& l = lights_[i];
  const float e = l.emit.average();
  const float r2 = scene_radius_ * scene_radius_;
  switch (l.type) {
    case LightType::Area: return e * l.area * kPi * (l.two_sided ? 2.0f : 1.0f);
    case LightType::Point: return 4.0f * kPi * e;
    case LightType::Spot: return 2.0f * kPi * e * (1.0f - l.spot_cos_half);
    case LightType::Directional: return kPi * r2 * e;
    case LightType::Environment: return 4.0f * kPi * kPi * r2 * e;
  }
  return 0.0f;
}

float LightSet::spot_falloff(const Light& l, const Vec3& w_from_light) const {
  // Blender/Cycles spot: cosine to the axis, cut at the cone, smoothstep blend at the edge.
  const float c = dot(w_from_light, l.direction);
  if (c <= l.spot_cos_half) return 0.0f;
  const float t = c - l.spot_cos_half;
  float atten = c;
  if (l.spot_smooth > 0 && t < l.spot_smooth) {
    const float s = t / l.spot_smooth;
    atten *= s * s * (3.0f - 2.0f * s);
  }
  return atten;
}

std::optional<LightSample> LightSet::sample_li(const Vec3& p, float u_select, Vec2 u) const {
  if (select_.empty()) return std::nullopt;
  float u_rest;
  const int i = static_cast<int>(select_.sample(u_select, &u_rest));
  const float pmf = select_.pmf(i);
  const Light& l = lights_[i];
  LightSample s;
  s.light = i;
  switch (l.type) {
    case LightType::Area: {
      const Vec2 b = sample_uniform_triangle(u);
      const Vec3 q = l.p0 * b.x + l.p1 * b.y + l.p2 * (1.0f - b.x - b.y);
      const Vec3 d = q - p;
      const float d2 = length_squared(d);
      if (d2 <= 0) return std::nullopt;
      s.dist = std::sqrt(d2);
      s.wi = d / s.dist;
      const float cos_l = -dot(l.n, s.wi);
      if (!l.two_sided && cos_l <= 0) return std::nullopt;
      if (cos_l == 0) return std::nullopt;
      s.L = l.emit;
      s.p = q;
      s.n = l.n;
      s.pdf = pmf * d2 / (std::abs(cos_l) * l.area);  // area pdf 1/A to solid angle
      return s;
    }
    case LightType::Point:
    case LightType::Spot: {
      const Vec3 d = l.position - p;
      const float d2 = length_squared(d);
      if (d2 <= 0) return std::nullopt;
      s.dist = std::sqrt(d2);
      s.wi = d / s.dist;
      float scale = 1.0f;
      if (l.type == LightType::Spot) scale = spot_falloff(l, -s.wi);
      if (scale <= 0) return std::nullopt;
      s.L = l.emit * (scale / d2);
      s.pdf = pmf;
      s.delta = true;
      return s;
    }
    case LightType::Directional:
      s.wi = -l.direction;
      s.L = l.emit;
      s.pdf = pmf;
      s.delta = true;
      return s;
    case LightType::Environment:
      s.wi = sample_uniform_sphere(u);
      s.L = l.emit;
      s.pdf = pmf * uniform_sphere_pdf();
      return s;
  }
  return std::nullopt;
}

float LightSet::pdf_area(int i, const Vec3& p, const Vec3& p_light, const Vec3& wi) const {
  const Light& l = lights_[i];
  const float cos_l = -dot(l.n, wi);
  if (cos_l == 0 || (!l.two_sided && cos_l < 0)) return 0.0f;
  return select_.pmf(i) * length_squared(p_light - p) / (std::abs(cos_l) * l.area);
}

float LightSet::pdf_environment(const Vec3& wi) const {
  return environment_ < 0 ? 0.0f : select_.pmf(environment_) * uniform_sphere_pdf();
}

RGB LightSet::environment_radiance(const Vec3& dir) const {
  return environment_ < 0 ? RGB(0.0f) : lights_[environment_].emit;
}

RGB LightSet::area_radiance(int i, const Vec3& w) const {
  const Light& l = lights_[i];
  const float c = dot(l.n, w);
  return (c > 0 || (l.two_sided && c < 0)) ? l.emit : RGB(0.0f);
}

}  // namespace gp
