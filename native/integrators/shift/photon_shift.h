// Shift of a photon (the last light-subpath vertex) for gradient-domain photon density
// estimation, §4.2 step 1, and the DD reconnection of step 2. Pure geometry, no scene access:
// the integrator (gpm.cpp) traces the rays; tests check the Jacobian against finite differences.
#pragma once

#include "core/frame.h"
#include "core/math.h"

namespace gp {

// Eq. 5: candidate offset photon y*_s = z'_t + M' M^{-1} (y_s - z_t), with M and M' the
// tangent-to-world maps (shading frames) of the base and offset gather points. M' M^{-1} is a
// rotation, so |d y*_s / d y_s| = 1 between the two tangent planes.
inline Vec3 photon_offset_candidate(const Vec3& z, const Frame& frame_z, const Vec3& z_off, const Frame& frame_off,
                                    const Vec3& y) {
  return z_off + frame_off.to_world(frame_z.to_local(y - z));
}

// Eq. 6: |d y'_s / d y_s| = G(y_{s-1}, y*_s) / G(y_{s-1}, y'_s), where y'_s is where the ray from
// y_{s-1} through y*_s meets the scene. The cosine at y_{s-1} is the same in both (one
// direction), so only the far-end cosines and the distances remain. n_star: the normal of the
// element y*_s carries (candidate_normal; the paper's plane is the offset gather point's, the same
// on a flat receiver); n_off: the surface normal at y'_s.
// Returns 0 for degenerate configurations.
inline double photon_shift_jacobian(const Vec3& y_prev, const Vec3& y_star, const Vec3& n_star, const Vec3& y_off,
                                    const Vec3& n_off) {
  const Vec3 a = y_star - y_prev, b = y_off - y_prev;
  const double da2 = length_squared(a), db2 = length_squared(b);
  if (!(da2 > 0) || !(db2 > 0)) return 0.0;
  const double cos_star = std::abs(dot(n_star, a)) / std::sqrt(da2);
  const double cos_off = std::abs(dot(n_off, b)) / std::sqrt(db2);
  if (!(cos_off > 0)) return 0.0;
  return (cos_star / da2) / (cos_off / db2);  // eq. 6
}

// The normal of the surface element that eq. 5 moves y_s's element to: y_s's own normal n_y,
// rotated by the same map. On a flat receiver it is the offset gather point's normal; on a
// curved one (a torus a few pixels across) the two differ by tenths of a radian between
// neighbouring pixels, and eq. 6 must take this one.
inline Vec3 candidate_normal(const Frame& frame_z, const Frame& frame_off, const Vec3& n_y) {
  return frame_off.to_world(frame_z.to_local(n_y));
}

// |dA(y'_s) / dA(y_s)| when y'_s is y*_s projected onto the receiver along the direction n_proj
// (gpm.cpp projects a chain photon's candidate along the offset gather point's normal): the
// rigidly moved element (normal n_star, candidate_normal) and the receiver's element at y'_s
// (normal n_off) have the same area across the projection direction.
inline double projection_jacobian(const Vec3& n_star, const Vec3& n_proj, const Vec3& n_off) {
  const double c_off = std::abs(dot(n_off, n_proj));
  return c_off > 0 ? std::abs(dot(n_star, n_proj)) / c_off : 0.0;
}

}  // namespace gp
