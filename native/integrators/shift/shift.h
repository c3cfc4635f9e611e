// Shift mapping of sensor (camera) subpaths by half-vector copy and reconnection (KMA15 §4.2;
// gradient-domain photon density estimation §3, §4.1). Used vertex by vertex by gradient-domain
// path tracing (gpt.cpp) and meant to serve GPM's sensor-subpath shift, which needs the area
// measure of eq. 4 (solid_angle_to_area_jacobian).
//
// Every shift returns a result that says why it failed; integrators count failures by
// failure_stat_name() in Stats::extra.
//
// Vertex kinds follow the roughness classification of the photon methods (KMA15; GPM §4.3):
// a BSDF is diffuse when Bsdf::is_diffuse_for_photons(threshold) (roughness > 0.05 by default),
// delta when every lobe is a Dirac delta, glossy otherwise. A shift is only invertible when the
// base and offset vertices have the same kind; offset paths reconnect to the base path at the
// first pair of consecutive diffuse vertices and copy half-vectors before that.
#pragma once

#include <string_view>

#include "core/color.h"
#include "core/math.h"
#include "materials/bsdf.h"
#include "materials/material.h"

namespace gp {

enum class ShiftFailure {
  None,
  Occluded,                 // the reconnection segment (or the offset's own ray) is blocked
  NotInvertible,            // vertex kinds differ, or the shifted direction leaves the lobe's side
  ZeroLength,               // reconnection onto the offset vertex itself / degenerate half-vector
  TotalInternalReflection,  // half-vector copy through refraction has no refracted direction
  Missed,                   // the offset ray left the scene where the base path hit a surface
  NotReversible,            // GPM: the inverse shift of the offset does not give the base back (§4.3)
  SpecularChain,            // GPM: a specular/glossy chain the manifold walk cannot take (it
                            // starts at a distant light, or is longer than kMaxChainVertices)
  WalkNotConverged,         // GPM: the manifold walk did not reach the offset photon (JM12 §5.2)
};
inline constexpr int kShiftFailureCount = 9;

// "shift failed: occluded", ... (the Stats::extra key).
std::string_view failure_stat_name(ShiftFailure f);

enum class VertexKind { Diffuse, Glossy, Delta };
VertexKind classify_vertex(const Bsdf& bsdf, float threshold = kDefaultSpecularThreshold);

// Half-vector copy at one vertex, in the local shading frames (normal +z) of the base and the
// offset vertex: the base pair (wo, wi) defines the (generalized) half-vector h, which the offset
// keeps, finding wi' from its own wo' by reflection or refraction about h (the same lobe as the
// base). `jacobian` is the solid-angle Jacobian |d omega_i' / d omega_i| at fixed wo, wo':
//   reflection  |wo'.h| / |wo.h|                                   (d omega_h / d omega_i = 1 / 4|wo.h|)
//   refraction  [|wi.h| / (wi.h + wo.h/eta)^2] / [|wi'.h| / (wi'.h + wo'.h/eta)^2]   (Walter07 eq. 17)
// and 1 for delta BSDFs (the half-vector is the normal; the measure is the Dirac's).
struct DirectionShift {
  ShiftFailure failure = ShiftFailure::None;
  Vec3 wi;              // offset's outgoing (sampled) direction, local frame of the offset vertex
  double jacobian = 0;  // |d omega_i' / d omega_i|
  bool ok() const { return failure == ShiftFailure::None; }
};
DirectionShift shift_half_vector(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi, const Vec3& wo_offset);

// The offset's scattering at a delta or glossy vertex where the base sampled direction `base_wi`
// (a delta lobe when base_delta, refraction when base_transmission): the same delta lobe from the
// offset's own wo' (with its Dirac weight, jacobian 1), or the half-vector copy above with the
// offset BSDF's own density. f_cos = f(wo', wi') |cos wi'|; pdf = the offset's sampling density
// of wi'. Shared by gpt's and gpm's sensor-subpath shifts.
struct ScatterShift {
  ShiftFailure failure = ShiftFailure::None;
  Vec3 wi;  // local frame of the offset vertex
  float pdf = 0;
  RGB f_cos;
  double jacobian = 1;
  bool ok() const { return failure == ShiftFailure::None; }
};
ScatterShift shift_scatter(const Bsdf& bsdf, const Vec3& wo, const Vec3& base_wi, bool base_delta,
                           bool base_transmission, const Vec3& wo_offset);

// Reconnection of the offset vertex to the base path's next vertex `target` (normal n_target):
// the base sampled a direction at `base_p` that reached `target`; the offset takes the direction
// towards the same point. `jacobian` is |d omega' / d omega| = (|cos'| / d'^2) / (|cos| / d^2)
// with the cosines at the target. Visibility is the caller's (it owns the scene).
struct ReconnectShift {
  ShiftFailure failure = ShiftFailure::None;
  Vec3 wi;              // unit world direction from the offset vertex to the target
  float distance = 0;
  double jacobian = 0;
  bool ok() const { return failure == ShiftFailure::None; }
};
// Reconnection Jacobian (KMA15 §5.2), the one place it is written: the direction from the base
// vertex x_k to the next base vertex x_next (normal n_next) replaced by the direction from the
// offset's y_k, (cos_y / |y_k - x_next|^2) / (cos_x / |x_k - x_next|^2) with the cosines at
// x_next: solid angle per area there, offset over base. 0 when a distance or cos_x is 0. Real:
// the precision of the ratio (gpt double, sgpt float).
template <class Real>
Real reconnection_jacobian(const Vec3& x_k, const Vec3& y_k, const Vec3& x_next, const Vec3& n_next) {
  const Vec3 dx = x_k - x_next, dy = y_k - x_next;
  const Real lx2 = length_squared(dx), ly2 = length_squared(dy);
  if (lx2 <= 0 || ly2 <= 0) return Real(0);
  const Real cos_x = std::abs(dot(n_next, dx)) / std::sqrt(lx2);
  const Real cos_y = std::abs(dot(n_next, dy)) / std::sqrt(ly2);
  if (cos_x <= 0) return Real(0);
  return (cos_y / ly2) / (cos_x / lx2);
}

ReconnectShift shift_reconnect(const Vec3& base_p, const Vec3& offset_p, const Vec3& target, const Vec3& n_target);

// Gradient-domain photon density estimation eq. 4: the solid-angle Jacobian J_omega of the last
// sensor-subpath segment (z_i -> z_{i+1} on the base, z'_i -> z'_{i+1} on the offset) in the
// area measure,
//   J = J_omega * [G(z_i, z_{i+1}) / G(z'_i, z'_{i+1})] * [cos(n_i, z_i->z_{i+1}) / cos(n'_i, z'_i->z'_{i+1})],
// which is 1 when z_i and z'_i are specular (pass is_specular = true).
double solid_angle_to_area_jacobian(double j_omega, const Vec3& z_i, const Vec3& n_i, const Vec3& z_next,
                                    const Vec3& n_next, const Vec3& zo_i, const Vec3& no_i, const Vec3& zo_next,
                                    const Vec3& no_next, bool is_specular);

}  // namespace gp
