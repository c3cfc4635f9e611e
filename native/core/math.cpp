#include "core/math.h"

namespace gp {

Vec3 Transform::normal(const Vec3& n) const {
  // Cofactor matrix of the 3x3 part = det * inverse transpose; the scale drops on normalisation.
  const float a = m[0][0], b = m[0][1], c = m[0][2];
  const float d = m[1][0], e = m[1][1], f = m[1][2];
  const float g = m[2][0], h = m[2][1], i = m[2][2];
  const float c00 = e * i - f * h, c01 = f * g - d * i, c02 = d * h - e * g;
  const float c10 = c * h - b * i, c11 = a * i - c * g, c12 = b * g - a * h;
  const float c20 = b * f - c * e, c21 = c * d - a * f, c22 = a * e - b * d;
  const float det = a * c00 + b * c01 + c * c02;
  // (M^-T) n = C n / det with C the cofactor matrix (rows c0*, c1*, c2*).
  Vec3 r{c00 * n.x + c01 * n.y + c02 * n.z, c10 * n.x + c11 * n.y + c12 * n.z,
         c20 * n.x + c21 * n.y + c22 * n.z};
  return det < 0 ? -r : r;
}

Transform Transform::translate(const Vec3& t) {
  Transform r;
  r.m[0][3] = t.x; r.m[1][3] = t.y; r.m[2][3] = t.z;
  return r;
}

Transform Transform::scale(const Vec3& s) {
  Transform r;
  r.m[0][0] = s.x; r.m[1][1] = s.y; r.m[2][2] = s.z;
  return r;
}

Transform Transform::rotate(float degrees, const Vec3& axis) {
  const Vec3 a = normalize(axis);
  const float th = degrees * kPi / 180.0f, s = std::sin(th), c = std::cos(th);
  Transform r;
  r.m[0][0] = a.x * a.x + (1 - a.x * a.x) * c;
  r.m[0][1] = a.x * a.y * (1 - c) - a.z * s;
  r.m[0][2] = a.x * a.z * (1 - c) + a.y * s;
  r.m[1][0] = a.x * a.y * (1 - c) + a.z * s;
  r.m[1][1] = a.y * a.y + (1 - a.y * a.y) * c;
  r.m[1][2] = a.y * a.z * (1 - c) - a.x * s;
  r.m[2][0] = a.x * a.z * (1 - c) - a.y * s;
  r.m[2][1] = a.y * a.z * (1 - c) + a.x * s;
  r.m[2][2] = a.z * a.z + (1 - a.z * a.z) * c;
  return r;
}

// The inverse of an affine transform (3x3 part by its adjugate; identity where singular).
Transform invert_affine(const Transform& t) {
  const auto& m = t.m;
  const float det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                    m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  Transform r;
  if (!(std::abs(det) > 0) || !std::isfinite(det)) return r;
  const float id = 1.0f / det;
  r.m[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * id;
  r.m[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * id;
  r.m[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * id;
  r.m[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * id;
  r.m[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * id;
  r.m[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * id;
  r.m[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * id;
  r.m[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * id;
  r.m[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * id;
  for (int i = 0; i < 3; ++i) r.m[i][3] = -(r.m[i][0] * m[0][3] + r.m[i][1] * m[1][3] + r.m[i][2] * m[2][3]);
  return r;
}

}  // namespace gp
