#include "integrators/paths/medium_walk.h"

#include <algorithm>
#include <cmath>

#include "materials/bsdf.h"
#include "materials/spectral_material.h"

namespace gp {

namespace {
ChannelValues ones(int count) {
  ChannelValues T{};
  for (int k = 0; k < count; ++k) T[k] = 1.0f;
  return T;
}
}  // namespace

bool ShadowTest::filter(const SurfaceHit& hit, const ShadowChannels& ch, ChannelValues& T) const {
  // Cycles evaluates the surface's shader for the shadow ray and keeps the transparent closures'
  // weight (shade_shadow.h, integrate_transparent_surface_shadow: throughput *=
  // shader_bsdf_transparency). Its colour comes from the node graph at the hit (alpha textures);
  // spectrally, upsampled at the hit and read at each wavelength (SpectralSurface).
  const Material& m = scene_.material(hit.material);
  const shading::ShadingContext ctx = scene_.shading_context(hit);
  bool any = false;
  auto keep = [&](int k, float t) {
    T[k] *= std::isfinite(t) && t > 0 ? t : 0.0f;
    any = any || T[k] > 0;
  };
  if (!ch.lambda) {
    const RGB c = Bsdf(m, ctx).transparency();
    for (int k = 0; k < std::min(ch.count, 3); ++k) keep(k, c[k]);
  } else {
    const SpectralSurface surface(m, ctx, nullptr);
    for (int k = 0; k < ch.count; ++k) keep(k, Bsdf(surface.at(ch.lambda[k]), ctx).transparency()[0]);
  }
  return any;
}

ChannelValues ShadowTest::transmittance(const Vec3& p, const Vec3* ng, const LightSample& ls,
                                        const ShadowChannels& ch) const {
  // The transparent surfaces a shadow ray may cross (intersect_shadow.h,
  // integrate_shadow_max_transparent_hits); the (left + 1)-th makes it opaque.
  int left = std::max(scene_.transparent_bounces - ch.state.transparent - 1, 0);
  const auto through = [&](SurfaceHit& hit, ChannelValues& T) {
    if (left-- <= 0) return false;
    // Its shader sees the shadow ray (Light Path: Is Shadow Ray, the path's depths), as
    // Cycles evaluates it with PATH_RAY_SHADOW (shade_shadow.h).
    const float length = hit.ray.length;
    hit.ray = ch.state;
    hit.ray.flags = kPathShadow;
    hit.ray.length = length;
    return filter(hit, ch, T);
  };
  if (!stack_) {
    const Ray ray = scene_.shadow_ray(p, *ng, ls);
    if (!scene_.has_transparent_shadows()) return scene_.occluded(ray) ? ChannelValues{} : ones(ch.count);
    // One any-hit query decides most rays, as without transparent surfaces: blocked by an
    // opaque one, or clear of transparent ones. Only a ray through transparent surfaces finds
    // them one by one, nearest first, from the same origin and direction (so that coverage
    // cut-outs are decided as the any-hit query decided them).
    bool crossed = false;
    if (scene_.occluded_opaque(ray, &crossed)) return ChannelValues{};
    ChannelValues T = ones(ch.count);
    if (!crossed) return T;
    Ray r = ray;
    while (std::optional<SurfaceHit> hit = scene_.shadow_hit(r)) {
      // (A surface that casts no shadow may still be reported where its mesh has no filter for
      // closest-hit rays: let through. An opaque one: blocked, whatever the any-hit query said.)
      const Material& m = scene_.material(hit->material);
      if (m.casts_shadow && !(m.transparent_shadow() && through(*hit, T))) return ChannelValues{};
      r.tmin = hit->t * (1.0f + 1e-5f);  // past this surface (same t for the same triangle)
      if (!(r.tmin < r.tmax)) break;
    }
    return T;
  }
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
    if (!(len > 0)) return ones(ch.count);
    dir = d / len;
    remaining = len * (1.0f - 1e-4f);
  }
  MediumStack stack = *stack_;
  if (interior_ >= 0 && ng && (dot(dir, ng_) < 0) == (dot(ray_d_, ng_) < 0))
    stack.cross(mesh_, interior_, dot(ray_d_, ng_) < 0);
  ChannelValues surfaces = ones(ch.count);  // the transparent surfaces' filters
  MediumLengths lengths;
  const bool transparent = scene_.has_transparent_shadows();
  // The light reached: the media's transmittance (exp(-sum sigma_t d), ratio tracking through
  // grids) times the surfaces'.
  const auto with_media = [&] {
    if (lengths.empty()) return surfaces;
    ChannelValues T = gp::transmittance(lengths, ch.count, [&](int m) -> const MediumChannels& { return ch.media[m]; });
    for (int k = 0; k < ch.count; ++k) T[k] *= surfaces[k];
    return T;
  };
  // Cycles bounds the volume boundaries a path crosses (VOLUME_BOUNDS_MAX); so does this.
  constexpr int kMaxCrossings = 64;
  for (int crossing = 0; crossing <= kMaxCrossings; ++crossing) {
    const Ray ray(o, dir, 0.0f, remaining);
    // (A full hit only where a transparent surface's colour may be needed.)
    std::optional<SurfaceHit> full = transparent ? scene_.intersect(ray) : std::nullopt;
    const std::optional<SurfacePoint> hit =
        transparent ? (full ? std::optional<SurfacePoint>(*full) : std::nullopt) : scene_.intersect_point(ray);
    const float d = hit ? hit->t : remaining;
    for (int i = 0; i < stack.size(); ++i) {
      const int m = stack[i].medium;
      if (scene_.media[m].grid) lengths.add_piece(m, o, dir, d);  // ratio tracking, later
      else lengths.add(m, d);
    }
    if (lengths.overflow) return ChannelValues{};
    if (!hit) return with_media();
    const Material& m = scene_.material(hit->material);
    if (m.casts_shadow && !(m.transparent_shadow() && through(*full, surfaces))) return ChannelValues{};
    if (m.interior >= 0) stack.cross(hit->mesh, m.interior, dot(dir, hit->ng) < 0);
    o = offset_ray_origin(hit->p, hit->ng, dir);
    remaining -= hit->t;
    if (!(remaining > 0)) return with_media();
  }
  return ChannelValues{};  // more boundaries than a closed scene has: treated as blocked
}

}  // namespace gp
