#include "integrators/shift/spectral_shift.h"

#include <cmath>

namespace gp {

Etas dielectric_etas(float eta, float wo_z, bool transmission) {
  const float side_wo = wo_z > 0 ? 1.0f : eta;
  if (!transmission) return {side_wo, side_wo};
  return {side_wo, wo_z > 0 ? eta : 1.0f};
}

std::optional<Vec3> half_vector(const Vec3& wo, const Vec3& wi, const Etas& e, bool transmission) {
  Vec3 h = transmission ? -(wo * e.wo + wi * e.wi) : wo + wi;  // eq. 12
  if (length_squared(h) <= 0) return std::nullopt;
  h = normalize(h);
  if (h.z < 0) h = -h;
  return h;
}

std::optional<Vec3> copy_half_vector(const Vec3& wo, const Vec3& h, const Etas& e, bool transmission) {
  Vec3 wi;
  if (!transmission) {
    wi = reflect(wo, h);
    if (wi.z * wo.z <= 0) return std::nullopt;
    return wi;
  }
  // Snell's law at the microfacet h, from wo's side (IOR e.wo) into wi's side (IOR e.wi).
  const Vec3 n = dot(wo, h) < 0 ? -h : h;
  if (!refract_oriented(wo, n, dot(wo, n), e.wi / e.wo, &wi)) return std::nullopt;  // total internal reflection
  if (wi.z * wo.z >= 0) return std::nullopt;  // must cross the surface
  return normalize(wi);
}

float half_vector_jacobian(const Vec3& wo, const Vec3& wi, const Etas& e, const Vec3& wo2,
                           const Vec3& wi2, const Etas& e2, const Vec3& h, bool transmission) {
  if (!transmission) {
    const float d = absdot(wi, h);
    return d > 0 ? absdot(wi2, h) / d : 0.0f;
  }
  // Eq. 13 (o = wi, i = wo): (n_o / n'_o)^2 |o.h| / |o'.h| ((n'_i i'.h + n'_o o'.h) / (n_i i.h + n_o o.h))^2.
  const float base = e.wo * dot(wo, h) + e.wi * dot(wi, h);
  const float off = e2.wo * dot(wo2, h) + e2.wi * dot(wi2, h);
  const float d = absdot(wi2, h) * base * base;
  if (d <= 0) return 0.0f;
  return sqr(e.wi / e2.wi) * absdot(wi, h) * off * off / d;
}

}  // namespace gp
