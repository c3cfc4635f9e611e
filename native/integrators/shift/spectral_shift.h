// The local pieces of the spectral shift mapping (spectral gradient sampling §3.1): the
// generalised half vector of a scattering pair (eq. 12), its copy to an offset path with other
// indices of refraction, and the Jacobian determinants of that copy (eq. 13 for refraction,
// [KMA*15] §5.2 for reflection) and of a reconnection. Local shading frame, normal +z; wo and wi
// both point away from the surface (wo towards the previous vertex, wi the sampled direction).
#pragma once

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

// |d wi' / d wi| (solid angle) of the half-vector copy: eq. 13 for refraction,
// |wi'.h| / |wi.h| for reflection. Base pair (wo, wi, e), offset pair (wo', wi', e').
float half_vector_jacobian(const Vec3& wo, const Vec3& wi, const Etas& e, const Vec3& wo_offset,
                           const Vec3& wi_offset, const Etas& e_offset, const Vec3& h,
                           bool transmission);

}  // namespace gp
