#include "integrators/path_tracer.h"

#include <chrono>

#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/lobe_split.h"
#include "materials/bsdf.h"

namespace gp {

PathTracer::PathTracer(const Scene& scene, const Params& params)
    : scene_(scene),
      film_transparent_(params.get<bool>("film_transparent")),
      clamp_direct_(params.get<float>("clamp_direct")),
      clamp_indirect_(params.get<float>("clamp_indirect")),
      max_depth_(params.get<int>("max_depth")),
      rr_depth_(params.get<int>("rr_depth")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      seed_(params.get<uint64_t>("seed")),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      estimate_(std::max(1, width_), std::max(1, height_), &scene.camera) {  // sizes checked just below
  check_image_size(width_, height_);  // the parameters are checked by their declarations (methods.cpp)
}

RGB PathTracer::clamped(const RGB& c, bool direct) const {
  const float limit = direct ? clamp_direct_ : clamp_indirect_;
  const float sum = std::abs(c.r) + std::abs(c.g) + std::abs(c.b);
  return limit > 0 && sum > limit ? c * (limit / sum) : c;
}

RGB PathTracer::Li(Ray ray, Rng& rng, RayCounts& rays, bool* escaped, const std::optional<SurfaceHit>* first) const {
  const LightSet& lights = scene_.light_set();
  const bool split_lobes = scene_.lights_hidden_from_some_lobes();
  RGB L(0.0f), beta(1.0f);
  bool specular_bounce = false;
  float prev_pdf = 0;  // solid-angle pdf of the BSDF sample that produced `ray`
  Vec3 prev_p;
  LobeSplit prev;      // the previous vertex's lobes, where some light is hidden from some kinds
  // Emission Le found by the BSDF ray from a light visible to `vis` (MIS against pdf_light).
  auto emitted = [&](int depth, const RGB& Le, uint8_t vis, float pdf_light) -> RGB {
    if (depth == 0) return beta * Le;
    if (vis != kAllLobes) return prev.weigh(Le, vis, specular_bounce, beta, pdf_light);
    return beta * Le * (specular_bounce ? 1.0f : power_heuristic(prev_pdf, pdf_light));
  };
  constexpr int kMaxPassThrough = 8;  // Cycles: Light Paths > Transparent, 8 by default
  int pass_through = 0;
  for (int depth = 0;; ++depth) {
    ++rays.closest;
    const std::optional<SurfaceHit> traced = first ? std::nullopt : scene_.intersect(ray);
    const std::optional<SurfaceHit>& hit = first ? *first : traced;
    first = nullptr;  // only the camera ray's hit is given

    // Cycles' point and spot lights of radius > 0: disks that BSDF rays may hit (MIS with
    // their sampling above; a mirror shows them). Camera rays do not see them.
    if (depth > 0) {
      float t_disk, pdf_disk;
      RGB Le;
      if (const int l = lights.intersect_disk(ray, hit ? hit->t : kInfinity, &t_disk, &Le, &pdf_disk); l >= 0)
        L += clamped(emitted(depth, Le, lights.lights()[l].visible_lobes, pdf_disk), depth <= 1);
    }

    // ---- Emission found by the ray: full weight for camera and specular rays, MIS otherwise
    // Emission found at depth 0 or 1 is direct light (Cycles' clamping), deeper is indirect.
    if (!hit) {
      if (depth == 0 && (film_transparent_ || ray.held_out)) {  // no background; a holdout: black
        if (escaped) *escaped = true;
        break;
      }
      // The World's Ray Visibility: Camera for camera rays, its lobes for bounce rays, by
      // Cycles' rule for the World (lobe_split.h), not a light's.
      const int env = lights.environment();
      if (env >= 0 && (depth > 0 || lights.lights()[env].visible_to_camera)) {
        const RGB Le = lights.environment_radiance(ray.d);
        const Light& world = lights.lights()[env];
        L += clamped(depth > 0 && world.lit_by_bsdf_rays_only()
                         ? prev.weigh_world(Le, world.visible_lobes, specular_bounce, beta)
                         : emitted(depth, Le, world.visible_lobes, lights.pdf_environment(ray.d)),
                     depth <= 1);
      }
      break;
    }
    if (hit->light >= 0) {
      const RGB Le = lights.area_radiance(hit->light, -ray.d);
      if (!Le.is_black())
        L += clamped(emitted(depth, Le, lights.lights()[hit->light].visible_lobes,
                             depth == 0 ? 0.0f : lights.pdf_area(hit->light, prev_p, hit->p, ray.d)),
                     depth <= 1);
    }
    // ---- A pass-through surface (a light object): the path goes on as if it were not there,
    // keeping its MIS state and not counting a bounce (Cycles' lights, a transparent bounce) ----
    if (scene_.material(hit->material).is_pass_through() && pass_through < kMaxPassThrough) {
      ++pass_through;
      const bool camera = ray.camera;
      const uint8_t bounce = ray.bounce;
      ray = Ray(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
      ray.camera = camera;
      ray.bounce = bounce;
      --depth;
      continue;
    }
    if (depth + 1 >= max_depth_) break;

    const Bsdf bsdf = scene_.bsdf(*hit);
    if (bsdf.is_black()) break;
    const Vec3 wo = hit->frame.to_local(-ray.d);
    if (wo.z == 0) break;

    // ---- Emitter sampling (next-event estimation) ----
    // A light hidden from some kinds of bounce ray lights only the lobes of the kinds it is
    // visible to (Cycles' closure exclusion), with the MIS density of those lobes.
    if (!bsdf.is_delta() && !lights.empty()) {
      const float u_light = rng.uniform();
      const Vec2 u2(rng.uniform(), rng.uniform());
      if (auto ls = lights.sample_li(hit->p, u_light, u2);
          ls && ls->pdf > 0 && !ls->L.is_black() && !(ls->light >= 0 && lights.lights()[ls->light].lit_by_bsdf_rays_only())) {
        const uint8_t vis = ls->light >= 0 ? lights.lights()[ls->light].visible_lobes : kAllLobes;
        const Vec3 wi = hit->frame.to_local(ls->wi);
        const RGB f = bsdf.eval(wo, wi, TransportMode::Radiance, vis) * std::abs(wi.z);
        if (!f.is_black()) {
          ++rays.shadow;
          const bool blocked = scene_.occluded(hit->p, hit->ng, *ls);
          if (!blocked) {
            const float w = !ls->delta       ? power_heuristic(ls->pdf, bsdf.pdf(wo, wi, vis))
                            : ls->mis_pdf > 0 ? power_heuristic(ls->mis_pdf, bsdf.pdf(wo, wi, vis))
                                              : 1.0f;
            L += clamped(beta * f * ls->L * (w / ls->pdf), depth == 0);
          }
        }
      }
    }

    // ---- BSDF sampling ----
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto bs = bsdf.sample(wo, uc, u);
    if (!bs || bs->pdf <= 0 || bs->f.is_black()) break;
    if (split_lobes) {
      prev.beta = beta;
      prev.lobe = bs->lobe;
      if (!bs->delta) prev.fill(bsdf, wo, bs->wi);
    }
    beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
    specular_bounce = bs->delta;
    prev_pdf = bs->pdf;
    prev_p = hit->p;
    const Vec3 wi = hit->frame.to_world(bs->wi);
    ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
    ray.bounce = bs->lobe;  // surfaces hidden from this kind of ray let it through

    // ---- Russian roulette ----
    float survival = 1.0f;
    if (depth + 1 >= rr_depth_ && !russian_roulette(beta, rng.uniform(), &survival)) break;
    prev.beta = prev.beta / survival;
  }
  return L;
}

void PathTracer::iterate(ProgressSink* sink) {
  // A tile's camera rays are traced together (Embree packets: the same hits, several times
  // faster than one by one), then each path goes on alone from its first hit.
  estimate_.run_pass_tiles(seed_, tile_size_, threads_, sink, stats_,
                           [this](PixelStart* starts, size_t n, RayCounts& rays, PixelSample* out) {
                             CameraRays first(scene_, starts, n);
                             const std::vector<Ray>& camera = first.rays;
                             std::vector<std::optional<SurfaceHit>>& hits = first.hits;
                             for (size_t i = 0; i < n; ++i) {
                               bool escaped = false;
                               const RGB L = Li(camera[i], starts[i].rng, rays, &escaped, &hits[i]);
                               out[i] = PixelSample{L, escaped ? 0.0f : 1.0f};
                             }
                           });
}

void PathTracer::develop(Film& film) const {
  estimate_.develop(film, pass::kCombined);
  if (film_transparent_) estimate_.develop_alpha(film);
}

}  // namespace gp
