#include "core/motion.h"

#include <cmath>
#include <cstring>

namespace gp {

DecomposedTransform decompose(const Transform& m) {
  DecomposedTransform d;
  // Columns of the 3x3 part, orthonormalised in order (Gram-Schmidt): A = Q U.
  const Vec3 a0(m.m[0][0], m.m[1][0], m.m[2][0]), a1(m.m[0][1], m.m[1][1], m.m[2][1]),
      a2(m.m[0][2], m.m[1][2], m.m[2][2]);
  d.s00 = length(a0);
  const Vec3 q0 = a0 / d.s00;
  d.s01 = dot(q0, a1);
  Vec3 r1 = a1 - q0 * d.s01;
  d.s11 = length(r1);
  const Vec3 q1 = r1 / d.s11;
  d.s02 = dot(q0, a2);
  d.s12 = dot(q1, a2);
  Vec3 r2 = a2 - q0 * d.s02 - q1 * d.s12;
  d.s22 = length(r2);
  Vec3 q2 = r2 / d.s22;
  // A mirroring matrix: Q a rotation, the reflection kept in the scale's last entry.
  if (dot(cross(q0, q1), q2) < 0) {
    q2 = -q2;
    d.s22 = -d.s22;
  }
  // Rotation matrix (columns q0 q1 q2) to a unit quaternion (Shepperd's method).
  const float r00 = q0.x, r11 = q1.y, r22 = q2.z;
  const float r01 = q1.x, r10 = q0.y, r02 = q2.x, r20 = q0.z, r12 = q2.y, r21 = q1.z;
  const float tr = r00 + r11 + r22;
  if (tr > 0) {
    const float s = 2.0f * std::sqrt(tr + 1.0f);
    d.qr = 0.25f * s;
    d.qi = (r21 - r12) / s;
    d.qj = (r02 - r20) / s;
    d.qk = (r10 - r01) / s;
  } else if (r00 > r11 && r00 > r22) {
    const float s = 2.0f * std::sqrt(1.0f + r00 - r11 - r22);
    d.qr = (r21 - r12) / s;
    d.qi = 0.25f * s;
    d.qj = (r01 + r10) / s;
    d.qk = (r02 + r20) / s;
  } else if (r11 > r22) {
    const float s = 2.0f * std::sqrt(1.0f + r11 - r00 - r22);
    d.qr = (r02 - r20) / s;
    d.qi = (r01 + r10) / s;
    d.qj = 0.25f * s;
    d.qk = (r12 + r21) / s;
  } else {
    const float s = 2.0f * std::sqrt(1.0f + r22 - r00 - r11);
    d.qr = (r10 - r01) / s;
    d.qi = (r02 + r20) / s;
    d.qj = (r12 + r21) / s;
    d.qk = 0.25f * s;
  }
  const float qn = std::sqrt(d.qr * d.qr + d.qi * d.qi + d.qj * d.qj + d.qk * d.qk);
  d.qr /= qn; d.qi /= qn; d.qj /= qn; d.qk /= qn;
  d.translation = Vec3(m.m[0][3], m.m[1][3], m.m[2][3]);
  return d;
}

Transform compose(const DecomposedTransform& d) {
  const float w = d.qr, x = d.qi, y = d.qj, z = d.qk;
  const float R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                         {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                         {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  const float S[3][3] = {{d.s00, d.s01, d.s02}, {0, d.s11, d.s12}, {0, 0, d.s22}};
  Transform m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.m[r][c] = R[r][0] * S[0][c] + R[r][1] * S[1][c] + R[r][2] * S[2][c];
    m.m[r][3] = d.translation[r];
  }
  return m;
}

TransformMotion::TransformMotion(const std::vector<Transform>& steps) {
  steps_.reserve(steps.size());
  for (const Transform& m : steps) {
    DecomposedTransform d = decompose(m);
    if (!steps_.empty()) {  // the shorter arc from the previous step
      const DecomposedTransform& p = steps_.back();
      if (p.qr * d.qr + p.qi * d.qi + p.qj * d.qj + p.qk * d.qk < 0) {
        d.qr = -d.qr; d.qi = -d.qi; d.qj = -d.qj; d.qk = -d.qk;
      }
    }
    steps_.push_back(d);
  }
}

bool TransformMotion::still() const {
  for (const DecomposedTransform& d : steps_)
    if (std::memcmp(&d, &steps_[0], sizeof(DecomposedTransform)) != 0) return false;
  return true;
}

Transform TransformMotion::at(float t) const {
  size_t i;
  float f;
  motion_step(t, steps_.size(), &i, &f);
  const DecomposedTransform &a = steps_[i], &b = steps_[i + 1];
  const auto lerp = [f](float x, float y) { return x + (y - x) * f; };
  DecomposedTransform d;
  d.s00 = lerp(a.s00, b.s00); d.s01 = lerp(a.s01, b.s01); d.s02 = lerp(a.s02, b.s02);
  d.s11 = lerp(a.s11, b.s11); d.s12 = lerp(a.s12, b.s12); d.s22 = lerp(a.s22, b.s22);
  d.translation = a.translation + (b.translation - a.translation) * f;
  // Slerp (Cycles' quat_interpolate): along the great arc, a plain lerp where the arc is tiny.
  const float c = std::clamp(a.qr * b.qr + a.qi * b.qi + a.qj * b.qj + a.qk * b.qk, -1.0f, 1.0f);
  float wa = 1 - f, wb = f;
  if (c < 0.9995f) {
    const float theta = std::acos(c), s = std::sin(theta);
    wa = std::sin((1 - f) * theta) / s;
    wb = std::sin(f * theta) / s;
  }
  d.qr = wa * a.qr + wb * b.qr; d.qi = wa * a.qi + wb * b.qi;
  d.qj = wa * a.qj + wb * b.qj; d.qk = wa * a.qk + wb * b.qk;
  const float qn = std::sqrt(d.qr * d.qr + d.qi * d.qi + d.qj * d.qj + d.qk * d.qk);
  d.qr /= qn; d.qi /= qn; d.qj /= qn; d.qk /= qn;
  return compose(d);
}

Vec3 MeshMotion::object_vertex(uint32_t v, float t) const {
  if (positions.empty()) return object_positions[v];
  size_t i;
  float f;
  motion_step(t, positions.size(), &i, &f);
  const Vec3 &a = positions[i][v], &b = positions[i + 1][v];
  return a + (b - a) * f;  // Embree's linear interpolation of vertex time steps
}

void MeshMotion::triangle(const uint32_t* tri, float t, Vec3 out[3]) const {
  const Transform m = to_world_at(t);
  for (int k = 0; k < 3; ++k) out[k] = m.point(object_vertex(tri[k], t));
}

}  // namespace gp
