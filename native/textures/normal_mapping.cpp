#include "textures/normal_mapping.h"

#include <cmath>

namespace gp {

namespace {
Vec3 blend(const Vec3& ns, const Vec3& n, float strength) {
  if (strength == 1.0f) return n;
  const Vec3 b = ns + (n - ns) * std::max(0.0f, strength);
  const float len = length(b);
  return len > 0 && std::isfinite(len) ? b / len : ns;
}
}  // namespace

bool triangle_dpduv(const Vec3& p0, const Vec3& p1, const Vec3& p2, Vec2 uv0, Vec2 uv1, Vec2 uv2, Vec3* dpdu,
                    Vec3* dpdv) {
  const Vec2 d1 = uv1 - uv0, d2 = uv2 - uv0;
  const Vec3 e1 = p1 - p0, e2 = p2 - p0;
  const float det = d1.x * d2.y - d1.y * d2.x;
  if (!(std::abs(det) > 1e-20f)) return false;
  const float inv = 1.0f / det;
  *dpdu = (e1 * d2.y - e2 * d1.y) * inv;
  *dpdv = (e2 * d1.x - e1 * d2.x) * inv;
  return is_finite(*dpdu) && is_finite(*dpdv) && length_squared(*dpdu) > 0 && length_squared(*dpdv) > 0;
}

Vec3 normal_mapped(const TextureRef& tex, float strength, Vec2 uv, const Vec3& ns, const Vec3& dpdu,
                   const Vec3& dpdv) {
  const Vec3 tu = dpdu - ns * dot(ns, dpdu);
  if (!(length_squared(tu) > 0)) return ns;
  const Vec3 T = normalize(tu);
  Vec3 B = cross(ns, T);
  if (dot(B, dpdv) < 0) B = -B;  // mirrored uvs: the bitangent follows v
  const RGB c = tex.rgb(uv);
  const Vec3 n = T * (2 * c.r - 1) + B * (2 * c.g - 1) + ns * (2 * c.b - 1);
  const float len = length(n);
  if (!(len > 0) || !std::isfinite(len)) return ns;
  return blend(ns, n / len, strength);
}

Vec3 bump_mapped(const TextureRef& tex, float strength, float distance, Vec2 uv, const Vec3& ns, const Vec3& dpdu,
                 const Vec3& dpdv) {
  // grad u and grad v on the tangent plane of ns: the dual basis of (dp/du, dp/dv).
  const Vec3 c = cross(dpdu, dpdv);
  const float det = dot(ns, c);
  if (!(std::abs(det) > 0)) return ns;
  const Vec3 grad_u = cross(dpdv, ns) / det, grad_v = cross(ns, dpdu) / det;
  const Vec2 dh = tex.gradient(uv);
  const Vec3 n = ns - (grad_u * dh.x + grad_v * dh.y) * distance;
  const float len = length(n);
  if (!(len > 0) || !std::isfinite(len)) return ns;
  return blend(ns, n / len, strength);
}

Vec3 valid_reflection_normal(const Vec3& ng_in, const Vec3& wo, const Vec3& n_in) {
  // Work on wo's side: ng and n (given on the same side) flipped together.
  const float side = dot(wo, ng_in) < 0 ? -1.0f : 1.0f;
  const Vec3 ng = ng_in * side, n = n_in * side;
  const float threshold = std::min(0.9f * dot(wo, ng), 0.01f);
  auto ok = [&](const Vec3& m) { return dot(m * (2 * dot(m, wo)) - wo, ng) >= threshold; };
  if (ok(n)) return n_in;
  // Bisect t in [0, 1] on normalize(n + t (ng - n)): t = 1 (ng itself) reflects wo correctly.
  float lo = 0, hi = 1;
  for (int k = 0; k < 12; ++k) {
    const float mid = 0.5f * (lo + hi);
    (ok(normalize(n + (ng - n) * mid)) ? hi : lo) = mid;
  }
  return normalize(n + (ng - n) * hi) * side;
}

}  // namespace gp
