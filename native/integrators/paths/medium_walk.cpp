#include "integrators/paths/medium_walk.h"

namespace gp {

bool ShadowTest::visible(const Vec3& p, const Vec3* ng, const LightSample& ls, MediumLengths* lengths) const {
  if (!stack_) return !scene_.occluded(p, *ng, ls);
  // The segment: as Scene::occluded's (both ends pushed off their surfaces for area lights,
  // stopping just short of the light), from p itself in a medium.
  const bool area = ls.light >= 0 && scene_.light_set().lights()[ls.light].type == LightType::Area;
  Vec3 o = ng ? offset_ray_origin(p, *ng, area ? ls.p - p : ls.wi) : p;
  Vec3 dir = ls.wi;
  float remaining = std::isinf(ls.dist) ? kInfinity : ls.dist * (1.0f - 1e-4f);
  if (area) {
    const Vec3 e = offset_ray_origin(ls.p, ls.n, p - ls.p);
    const Vec3 d = e - o;
    const float len = length(d);
    if (!(len > 0)) return true;
    dir = d / len;
    remaining = len * (1.0f - 1e-4f);
  }
  MediumStack stack = *stack_;
  if (interior_ >= 0 && ng && (dot(dir, ng_) < 0) == (dot(ray_d_, ng_) < 0))
    stack.cross(mesh_, interior_, dot(ray_d_, ng_) < 0);
  // Cycles bounds the volume boundaries a path crosses (VOLUME_BOUNDS_MAX); so does this.
  constexpr int kMaxCrossings = 64;
  for (int crossing = 0; crossing <= kMaxCrossings; ++crossing) {
    const std::optional<SurfacePoint> hit = scene_.intersect_point(Ray(o, dir, 0.0f, remaining));
    const float d = hit ? hit->t : remaining;
    for (int i = 0; i < stack.size(); ++i) {
      const int m = stack[i].medium;
      if (scene_.media[m].grid) lengths->add_piece(m, o, dir, d);  // ratio tracking, later
      else lengths->add(m, d);
    }
    if (lengths->overflow) return false;
    if (!hit) return true;
    const Material& m = scene_.material(hit->material);
    if (m.casts_shadow) return false;
    if (m.interior >= 0) stack.cross(hit->mesh, m.interior, dot(dir, hit->ng) < 0);
    o = offset_ray_origin(hit->p, hit->ng, dir);
    remaining -= hit->t;
    if (!(remaining > 0)) return true;
  }
  return false;  // more boundaries than a closed scene has: treated as blocked
}

}  // namespace gp
