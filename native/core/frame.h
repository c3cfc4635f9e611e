// Orthonormal shading frame: BSDFs work in local coordinates with the normal on +z.
#pragma once

#include "core/math.h"

namespace gp {

struct Frame {
  Vec3 s{1, 0, 0}, t{0, 1, 0}, n{0, 0, 1};
  Frame() = default;
  // Branchless basis from a unit normal (Duff et al. 2017).
  explicit Frame(const Vec3& normal) : n(normal) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float b = n.x * n.y * a;
    s = Vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    t = Vec3(b, sign + n.y * n.y * a, -n.y);
  }
  Vec3 to_local(const Vec3& v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  Vec3 to_world(const Vec3& v) const { return s * v.x + t * v.y + n * v.z; }
};

// Local-frame trigonometry (normal = +z).
inline float cos_theta(const Vec3& w) { return w.z; }
inline float abs_cos_theta(const Vec3& w) { return std::abs(w.z); }
inline float cos2_theta(const Vec3& w) { return w.z * w.z; }
inline float sin2_theta(const Vec3& w) { return std::max(0.0f, 1.0f - w.z * w.z); }
inline float tan2_theta(const Vec3& w) { return sin2_theta(w) / cos2_theta(w); }
inline bool same_hemisphere(const Vec3& a, const Vec3& b) { return a.z * b.z > 0; }

}  // namespace gp
