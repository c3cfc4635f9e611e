// The camera path every path tracer follows (pt, spt, spt-hero), written once and generic over
// what the path carries: an RGB throughput (path_tracer.cpp) or a bundle of wavelengths
// (spectral/spectral_pt.cpp). The loop owns what does not depend on the colour: tracing, the
// order of the random numbers, lights found by rays (disks, the World, emissive triangles),
// light objects crossed as Cycles crosses them, the depth limit, next-event estimation's light
// sample and the shadow test's preconditions, the BSDF sample's ray and Russian roulette's
// place. The path type `P` owns the estimator at each of those steps (MIS weights, clamping,
// per-wavelength factors), with this interface:
//
//   void disk_light(int depth, int light, const RGB& Le, float pdf);  // a point/spot disk hit
//   void environment(int depth, const Ray& ray);                       // the ray left the scene
//   void area_light(int depth, const SurfaceHit& hit, const Ray& ray); // an emissive triangle
//   bool prepare(const SurfaceHit& hit);        // the BSDF(s) at the hit; false: black, end
//   bool is_delta() const;                      // no next-event estimation
//   void next_event(int depth, const SurfaceHit& hit, const Vec3& wo, const LightSample& ls);
//   std::optional<BsdfSample> scatter(const SurfaceHit& hit, const Vec3& wo, float uc, Vec2 u);
//                                               // updates the throughput; nullopt: end
//   bool survive(float u);                      // Russian roulette: false ends the path
#pragma once

#include <optional>

#include "core/progress.h"
#include "core/rng.h"
#include "lights/light.h"
#include "scene/scene.h"

namespace gp {

struct CameraPathSettings {
  int max_depth = 32, rr_depth = 3;
  bool film_transparent = false;  // a camera ray that leaves the scene sees no background
};

// Follows `ray` from the camera (its closest hit `first`, when given, already traced); returns
// false when the camera ray escaped with a transparent film or met a holdout (Ray::held_out: the
// pixel's sample is then uncovered and black), true otherwise.
template <class P>
bool trace_camera_path(const Scene& scene, const CameraPathSettings& s, Ray ray, Rng& rng, RayCounts& rays, P& path,
                       const std::optional<SurfaceHit>* first = nullptr) {
  const LightSet& lights = scene.light_set();
  constexpr int kMaxPassThrough = 8;  // Cycles: Light Paths > Transparent, 8 by default
  int pass_through = 0;
  for (int depth = 0;; ++depth) {
    ++rays.closest;
    const std::optional<SurfaceHit> traced = first ? std::nullopt : scene.intersect(ray);
    const std::optional<SurfaceHit>& hit = first ? *first : traced;
    first = nullptr;  // only the camera ray's hit is given

    // Cycles' point and spot lights of radius > 0: disks that BSDF rays may hit (MIS with
    // their sampling; a mirror shows them). Camera rays do not see them.
    if (depth > 0) {
      float t_disk, pdf_disk;
      RGB Le;
      if (const int l = lights.intersect_disk(ray, hit ? hit->t : kInfinity, &t_disk, &Le, &pdf_disk); l >= 0)
        path.disk_light(depth, l, Le, pdf_disk);
    }
    if (!hit) {
      if (depth == 0 && (s.film_transparent || ray.held_out)) return false;  // a holdout: black, uncovered
      path.environment(depth, ray);
      return true;
    }
    if (hit->light >= 0) path.area_light(depth, *hit, ray);
    // ---- A pass-through surface (a light object): the path goes on as if it were not there,
    // keeping its state and its kind of ray, not counting a bounce (Cycles' transparent bounce)
    if (scene.material(hit->material).is_pass_through() && pass_through < kMaxPassThrough) {
      ++pass_through;
      const bool camera = ray.camera;
      const uint8_t bounce = ray.bounce;
      ray = Ray(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
      ray.camera = camera;
      ray.bounce = bounce;
      --depth;
      continue;
    }
    if (depth + 1 >= s.max_depth) return true;
    if (!path.prepare(*hit)) return true;
    const Vec3 wo = hit->frame.to_local(-ray.d);
    if (wo.z == 0) return true;

    // ---- Emitter sampling (next-event estimation). A light lit only by BSDF rays (the World
    // hidden from some kinds, lobe_split.h) is not sampled.
    if (!path.is_delta() && !lights.empty()) {
      const float u_light = rng.uniform();
      const Vec2 u2(rng.uniform(), rng.uniform());
      if (auto ls = lights.sample_li(hit->p, u_light, u2);
          ls && ls->pdf > 0 && !ls->L.is_black() &&
          !(ls->light >= 0 && lights.lights()[ls->light].lit_by_bsdf_rays_only()))
        path.next_event(depth, *hit, wo, *ls);
    }

    // ---- BSDF sampling ----
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const std::optional<BsdfSample> bs = path.scatter(*hit, wo, uc, u);
    if (!bs) return true;
    const Vec3 wi = hit->frame.to_world(bs->wi);
    ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
    ray.bounce = bs->lobe;  // surfaces hidden from this kind of ray let it through

    // ---- Russian roulette ----
    if (depth + 1 >= s.rr_depth && !path.survive(rng.uniform())) return true;
  }
}

}  // namespace gp
