// The local pieces of the spectral shift mapping (spectral gradient sampling §3.1): the
// generalised half vector of a scattering pair (eq. 12), its copy to an offset path with other
// indices of refraction, and the Jacobian determinants of that copy (eq. 13 for refraction,
// [KMA*15] §5.2 for reflection) and of a reconnection. Local shading frame, normal +z; wo and wi
// both point away from the surface (wo towards the previous vertex, wi the sampled direction).
#pragma once

#include <cmath>
#include <optional>

#include "core/math.h"

namespace gp {

// Indices of refraction on the two sides of a scattering event: on wo's side and on wi's side
// (equal for a reflection).
struct Etas {
  float wo = 1.0f, wi = 1.0f;
};
// The IORs a dielectric of interior IOR `eta` (outside 1) presents to the pair: wo.z > 0 means wo
// is outside; a transmission puts wi on the other side.
Etas dielectric_etas(float eta, float wo_z, bool transmission);

// Generalised half vector, eq. 12: h ~ -(eta_wo wo + eta_wi wi) for refraction and wo + wi for
// reflection, oriented to +z. nullopt for degenerate pairs.
std::optional<Vec3> half_vector(const Vec3& wo, const Vec3& wi, const Etas& e, bool transmission);

// The offset's outgoing direction with the same half vector h: the mirror of wo' about h, or
// its refraction through a microfacet h with the offset's IORs. nullopt on total internal
// reflection or when the result leaves on the wrong side of the surface.
std::optional<Vec3> copy_half_vector(const Vec3& wo_offset, const Vec3& h, const Etas& e_offset,
                                     bool transmission);

// |d wi' / d wi| (solid angle) of the half-vector copy, the one place it is written: eq. 13 for
// refraction (Walter et al. 2007 eq. 17 for base and offset, whose IORs may differ: the spectral
// shift's wavelengths), |wi'.h| / |wi.h| for reflection. Base pair (wo, wi, e), offset pair
// (wo', wi', e'). Both shifts use it: the spectral shift in float, gradient-domain path
// tracing's half-vector copy (shift.cpp) in double. 0 where it is undefined.
template <typename Real = float>
Real half_vector_jacobian(const Vec3& wo, const Vec3& wi, const Etas& e, const Vec3& wo2, const Vec3& wi2,
                          const Etas& e2, const Vec3& h, bool transmission) {
  if (!transmission) {
    const Real d = std::abs(Real(dot(wi, h)));
    return d > 0 ? std::abs(Real(dot(wi2, h))) / d : Real(0);
  }
  // Eq. 13 (o = wi, i = wo): (n_o / n'_o)^2 |o.h| / |o'.h| ((n'_i i'.h + n'_o o'.h) / (n_i i.h + n_o o.h))^2.
  const Real base = Real(e.wo) * Real(dot(wo, h)) + Real(e.wi) * Real(dot(wi, h));
  const Real off = Real(e2.wo) * Real(dot(wo2, h)) + Real(e2.wi) * Real(dot(wi2, h));
  const Real d = std::abs(Real(dot(wi2, h))) * base * base;
  if (d <= 0) return Real(0);
  const Real r = Real(e.wi) / Real(e2.wi);
  return r * r * std::abs(Real(dot(wi, h))) * off * off / d;
}

}  // namespace gp
