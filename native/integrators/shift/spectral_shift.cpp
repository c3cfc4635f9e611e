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


}  // namespace gp
