// Half-vector copy and reconnection shifts (see shift.h).
#include "integrators/shift/shift.h"

#include <cmath>
#include <optional>

#include "integrators/shift/spectral_shift.h"
#include "materials/bsdf.h"

namespace gp {

std::string_view failure_stat_name(ShiftFailure f) {
  switch (f) {
    case ShiftFailure::None: return "shift ok";
    case ShiftFailure::Occluded: return "shift failed: occluded";
    case ShiftFailure::NotInvertible: return "shift failed: not invertible";
    case ShiftFailure::ZeroLength: return "shift failed: zero length";
    case ShiftFailure::TotalInternalReflection: return "shift failed: total internal reflection";
    case ShiftFailure::Missed: return "shift failed: offset left the scene";
    case ShiftFailure::NotReversible: return "shift failed: not reversible";
    case ShiftFailure::SpecularChain: return "shift failed: specular chain not walkable";
    case ShiftFailure::WalkNotConverged: return "shift failed: manifold walk did not converge";
  }
  return "shift failed: ?";
}

VertexKind classify_vertex(const Bsdf& bsdf, float threshold) {
  if (bsdf.is_diffuse_for_photons(threshold)) return VertexKind::Diffuse;
  if (bsdf.is_delta()) return VertexKind::Delta;
  return VertexKind::Glossy;
}


namespace {

// The same delta lobe (reflection or transmission) from the offset's own wo, with its Dirac
// weights; sample() picks the lobe from uc.
std::optional<BsdfSample> sample_same_lobe(const Bsdf& bsdf, const Vec3& wo, bool transmission) {
  const float uc = transmission ? 1.0f - 0x1p-24f : 0.0f;
  auto s = bsdf.sample(wo, uc, Vec2(0.5f, 0.5f));
  if (!s || s->transmission != transmission) return std::nullopt;
  return s;
}

}  // namespace

ScatterShift shift_scatter(const Bsdf& bsdf, const Vec3& wo, const Vec3& base_wi, bool base_delta,
                           bool base_transmission, const Vec3& wo_offset) {
  ScatterShift r;
  if (base_delta) {
    const auto os = sample_same_lobe(bsdf, wo_offset, base_transmission);
    if (!os) {
      r.failure = base_transmission ? ShiftFailure::TotalInternalReflection : ShiftFailure::NotInvertible;
      return r;
    }
    r.wi = os->wi;
    r.pdf = os->pdf;
    r.f_cos = os->f * std::abs(r.wi.z);
    return r;
  }
  const DirectionShift hs = shift_half_vector(bsdf, wo, base_wi, wo_offset);
  if (!hs.ok()) {
    r.failure = hs.failure;
    return r;
  }
  r.wi = hs.wi;
  r.jacobian = hs.jacobian;
  r.pdf = bsdf.pdf(wo_offset, r.wi);
  r.f_cos = bsdf.eval(wo_offset, r.wi) * std::abs(r.wi.z);
  return r;
}

DirectionShift shift_half_vector(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi, const Vec3& wo_offset) {
  DirectionShift r;
  const BsdfParams& m = bsdf.params();
  if (wo.z == 0 || wi.z == 0 || wo_offset.z == 0) {
    r.failure = ShiftFailure::ZeroLength;
    return r;
  }
  // The offset must see the surface from the same side, or the lobe (and eta) would change.
  if ((wo.z > 0) != (wo_offset.z > 0)) {
    r.failure = ShiftFailure::NotInvertible;
    return r;
  }
  const bool reflection = wo.z * wi.z > 0;
  const bool delta = bsdf.is_delta();
  if (reflection) {
    Vec3 h = delta ? Vec3(0, 0, 1) : wo + wi;
    if (length_squared(h) == 0) {
      r.failure = ShiftFailure::ZeroLength;
      return r;
    }
    h = normalize(h);
    r.wi = reflect(wo_offset, h);
    if (r.wi.z * wo_offset.z <= 0) {  // reflected below the horizon: no such offset path
      r.failure = ShiftFailure::NotInvertible;
      return r;
    }
    const Etas same = dielectric_etas(1.0f, wo.z, false);
    r.jacobian = delta ? 1.0 : half_vector_jacobian<double>(wo, wi, same, wo_offset, r.wi, same, h, false);
    if (!(r.jacobian > 0)) r.failure = ShiftFailure::ZeroLength;
    return r;
  }
  if (m.type != MaterialType::Dielectric) {  // only dielectrics transmit
    r.failure = ShiftFailure::NotInvertible;
    return r;
  }
  // Generalized half-vector (Walter07 eq. 16) with etap = IOR on wi's side / IOR on wo's side.
  const float etap = wo.z > 0 ? m.ior : 1.0f / m.ior;
  Vec3 h = delta ? Vec3(0, 0, 1) : wo + wi * etap;
  if (length_squared(h) == 0) {
    r.failure = ShiftFailure::ZeroLength;
    return r;
  }
  h = normalize(h);
  if (h.z < 0) h = -h;
  if (!refract(wo_offset, h, m.ior, nullptr, &r.wi)) {  // about h, the interior IOR below +z
    r.failure = ShiftFailure::TotalInternalReflection;
    return r;
  }
  if (r.wi.z * wo_offset.z >= 0) {  // "refracted" to the wrong side of the macro-surface
    r.failure = ShiftFailure::NotInvertible;
    return r;
  }
  if (delta) {
    r.jacobian = 1.0;
    return r;
  }
  // Base and offset cross the same interface (the same IORs on each side).
  const Etas e = dielectric_etas(m.ior, wo.z, true);
  r.jacobian = half_vector_jacobian<double>(wo, wi, e, wo_offset, r.wi, e, h, true);
  if (!(r.jacobian > 0) || !std::isfinite(r.jacobian)) r.failure = ShiftFailure::ZeroLength;
  return r;
}

ReconnectShift shift_reconnect(const Vec3& base_p, const Vec3& offset_p, const Vec3& target, const Vec3& n_target) {
  ReconnectShift r;
  const Vec3 d_base = target - base_p, d_off = target - offset_p;
  const double l2_base = length_squared(d_base), l2_off = length_squared(d_off);
  if (l2_off <= 0 || l2_base <= 0) {
    r.failure = ShiftFailure::ZeroLength;
    return r;
  }
  r.distance = static_cast<float>(std::sqrt(l2_off));
  r.wi = d_off / r.distance;
  r.jacobian = reconnection_jacobian<double>(base_p, offset_p, target, n_target);
  if (!(r.jacobian > 0)) r.failure = ShiftFailure::ZeroLength;  // a cosine at the target is 0
  return r;
}

double solid_angle_to_area_jacobian(double j_omega, const Vec3& z_i, const Vec3& n_i, const Vec3& z_next,
                                    const Vec3& n_next, const Vec3& zo_i, const Vec3& no_i, const Vec3& zo_next,
                                    const Vec3& no_next, bool is_specular) {
  if (is_specular) return 1.0;  // eq. 4, last sentence
  auto G = [](const Vec3& a, const Vec3& na, const Vec3& b, const Vec3& nb) {
    const Vec3 d = b - a;
    const double l2 = length_squared(d);
    if (l2 <= 0) return 0.0;
    const Vec3 w = d / std::sqrt(static_cast<float>(l2));
    return std::abs(dot(na, w)) * std::abs(dot(nb, w)) / l2;
  };
  auto cosine = [](const Vec3& a, const Vec3& na, const Vec3& b) { return std::abs(dot(na, normalize(b - a))); };
  const double g_off = G(zo_i, no_i, zo_next, no_next), c_off = cosine(zo_i, no_i, zo_next);
  if (g_off <= 0 || c_off <= 0) return 0.0;
  return j_omega * (G(z_i, n_i, z_next, n_next) / g_off) * (cosine(z_i, n_i, z_next) / c_off);  // eq. 4
}

}  // namespace gp
