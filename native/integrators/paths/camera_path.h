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
//   bool prepare(const SurfaceHit& hit, const ClosureFilter& filter);
//                                               // the BSDF(s) at the hit, filtered (Light Paths >
//                                               // Caustics, materials/bsdf.h); false: black, end
//   bool is_delta() const;                      // no next-event estimation
//   void next_event(int depth, const SurfaceHit& hit, const Vec3& wo, const LightSample& ls,
//                   const ShadowTest& shadow);
//   std::optional<BsdfSample> scatter(const SurfaceHit& hit, const Vec3& wo, float uc, Vec2 u);
//                                               // updates the throughput; nullopt: end
//   bool survive(float u, float eta_scale);     // Russian roulette: false ends the path; its
//                                               // probability from the throughput times
//                                               // eta_scale (camera_path_survival)
//
// next_event's shadow ray goes through a ShadowTest (paths/medium_walk.h): Scene::occluded in a
// scene without media or transparent surfaces, else the transmittance through the media and the
// Transparent BSDFs the ray crosses, per channel of the path, which it says with
//
//   ShadowChannels shadow_channels(const RayState& state) const;  // at a vertex of that ray state
//
// A BSDF sample through a Transparent BSDF that shadow rays pass is not a bounce for MIS: `scatter`
// keeps the vertex before's state (Cycles keeps mis_ray_pdf over a transparent bounce).
// Participating media (media/medium.h) add, only in scenes that have them (Scene::has_media),
// per channel of the path (RGB, or its wavelengths):
//
//   int channels() const;                                  // 3, or the path's wavelengths
//   const MediumChannels& medium_channels(int medium);     // a medium's coefficients at them
//   ChannelValues channel_weights() const;                 // the throughput per channel
//   Saved save() const; void restore(const Saved&);        // the throughput, around a disk's hit
//   void medium_weight(const ChannelValues& w);            // throughput *= w (free flight)
//   void medium_emission(int depth, const ChannelValues& e);  // L += throughput * e
//   void medium_next_event(int depth, const LightSample& ls, const ChannelValues& phase,
//                          float phase_pdf, const ChannelValues& transmittance);
//   void medium_scattered(const Vec3& p, float phase_pdf, const ChannelValues& ratio);
//                                               // a phase-sampled direction (ratio: phase / pdf)
#pragma once

#include <optional>

#include "core/progress.h"
#include "core/rng.h"
#include "core/sampler.h"
#include "integrators/paths/medium_stack.h"
#include "integrators/paths/medium_walk.h"
#include "lights/light.h"
#include "scene/scene.h"

namespace gp {

struct CameraPathSettings {
  int max_depth = 32, rr_depth = 3;
  bool film_transparent = false;  // a camera ray that leaves the scene sees no background
  CameraMedia camera_media;       // the media camera rays start in (a camera inside a Volume cube)
};

// ---- Equiangular sampling in homogeneous media (Kulla & Fajardo 2012; media/medium.h
// Equiangular) ----
// Next-event estimation at a scattering point is estimated along each medium segment by two
// strategies, both drawing the light l and the point c it aims at from
// LightSet::sample_position's distribution (independent of the point): the free flight's
// distance (density p_f(t) = MediumSegment::distance_pdf) and an equiangular distance toward c
// (p_e(t)), weighed by the power heuristic in t (the light-versus-phase MIS at the point is
// inside each). Cycles 3.4 does the same for point, spot and area lights (shade_volume.h, one
// sample of either strategy); distant lights and the World keep the free flight alone.
inline std::optional<Vec3> equiangular_centre(const LightSet& lights, const LightSample& ls) {
  if (ls.light < 0) return std::nullopt;
  const LightType type = lights.lights()[ls.light].type;
  if (type == LightType::Area) return ls.p;  // sample_position's point, drawn alike
  if (type == LightType::Point || type == LightType::Spot) return lights.position(ls.light);
  return std::nullopt;
}
inline ChannelValues uniform_channels(float w) {
  ChannelValues v;
  v.fill(w);
  return v;
}
// The free flight's MIS weight of next-event estimation toward `ls` from distance t on the segment
// along `ray` ending at t_end.
inline float free_flight_weight(const LightSet& lights, const LightSample& ls, const Ray& ray, float t_end,
                                const MediumSegment& segment, float t) {
  const std::optional<Vec3> c = equiangular_centre(lights, ls);
  if (!c) return 1.0f;
  const float p_e = Equiangular(ray.o, ray.d, *c, t_end).pdf(t), p_f = segment.distance_pdf(t);
  return p_f * p_f / (p_f * p_f + p_e * p_e);
}
// The equiangular strategy on one segment: its light and point, its distance, and next-event
// estimation there with weight sigma_s T(t) / p_e(t) times its MIS weight; the path's throughput
// is left as it was.
template <class P, class S>
void equiangular_next_event(const LightSet& lights, const Ray& ray, float t_end, const MediumSegment& segment,
                            ShadowTest& shadow, S& sampler, int vertex, int depth, P& path) {
  const float u_light = sampler.get1d(path_dim(vertex, kDimEquiangularLight));
  const Vec2 u2 = sampler.get2d(path_dim(vertex, kDimEquiangularLight2));
  const float u_t = sampler.get1d(path_dim(vertex, kDimEquiangularT));
  int light;
  const std::optional<Vec3> c = lights.sample_position(u_light, u2, &light);
  if (!c) return;
  const Equiangular eq(ray.o, ray.d, *c, t_end);
  if (!eq.valid) return;
  const float t = eq.sample(u_t), p_e = eq.pdf(t);
  if (!(p_e > 0)) return;
  const float p_f = segment.distance_pdf(t);
  const float w = p_e / (p_e * p_e + p_f * p_f);  // power heuristic / p_e
  ChannelValues f = segment.transmittance(t);
  bool any = false;
  for (int k = 0; k < segment.n; ++k) {
    f[k] *= segment.sigma_s[k] * w;
    any = any || f[k] > 0;
  }
  if (!any || !std::isfinite(w)) return;
  const Vec3 p = ray.at(t);
  const std::optional<LightSample> ls = lights.sample_li(p, u_light, u2);  // the same light and point
  if (!ls || !(ls->pdf > 0) || ls->L.is_black()) return;
  const float cos_theta = dot(ray.d, ls->wi);
  shadow.in_medium();
  const ChannelValues T = shadow.transmittance(p, nullptr, *ls, path.shadow_channels(ray.state));
  if (is_blocked(T, segment.n)) return;
  const auto saved = path.save();
  path.medium_weight(f);
  path.medium_next_event(depth, *ls, segment.phase(cos_theta), segment.phase_pdf(cos_theta), T);
  path.restore(saved);
}

// Follows `ray` from the camera (its closest hit `first`, when given, already traced); returns
// the sample's transparency (Cycles' transparent pass, alpha = 1 - it): 0 where the path met the
// scene; where the camera ray escaped, after transparent bounces only, with a transparent film
// or past a holdout (Ray::held_out), the average of its throughput, with no background. `sampler` gives the path's numbers
// by dimension (core/sampler.h: IndependentSampler or SobolSampler), the camera's taken before.
template <class P, class S>
float trace_camera_path(const Scene& scene, const CameraPathSettings& s, Ray ray, S& sampler, RayCounts& rays, P& path,
                       const std::optional<SurfaceHit>* first = nullptr) {
  // Motion blur: the whole path at its camera ray's shutter time (drawn once per camera path by
  // start_pixel), which every ray, hit and light sample on the path then takes (core/math.h).
  const ShutterTime at_time(ray.time);
  const LightSet& lights = scene.light_set();
  constexpr int kMaxPassThrough = 8;  // light objects crossed (they count no transparent bounce)
  constexpr int kMaxBoundaries = 64;  // volume boundaries crossed (Cycles: VOLUME_BOUNDS_MAX)
  int pass_through = 0, boundaries = 0;
  // The media the path is in (Cycles' volume stack), only in scenes that have media: from those
  // around the camera ray's origin (CameraMedia).
  const bool media = scene.has_media();
  MediumStack stack = media ? s.camera_media.at(scene, ray) : scene.initial_medium_stack();
  ShadowTest shadow(scene, media ? &stack : nullptr);
  // Light Paths > Volume bounces (Scene::volume_bounces; -1: only max_depth bounds them), as
  // Cycles 3.4 counts them apart from Max Bounces (path_state_next, max_volume_bounce =
  // volume_bounces + 1): after the (volume_bounces + 1)-th scattering in a medium (0: single
  // scattering) the path only passes through media (transmittance, emission) and ends at the
  // next surface that is not a pass-through one, with that surface's emission.
  int volume_scatters = 0;
  bool volume_done = false;
  // Light Paths > Caustics (Scene::filter_glossy, caustics_*; materials/bsdf.h ClosureFilter):
  // the smallest pdf of the path's non-singular bounces so far (Cycles' min_ray_pdf, lowered by
  // BSDF and phase samples, not by a transparent pass; a singular one's stand-in pdf 1e6 would
  // lower it only below Filter Glossy 1e-6), and whether the ray left a diffuse bounce.
  float min_ray_pdf = kInfinity;
  const bool filter_closures = scene.filters_caustics();
  // Russian roulette, as Cycles places it (integrator_intersect_terminate): decided where the
  // next ray meets a surface or scatters in a medium, after the emission it found, so a ray that
  // leaves the scene (to an HDRI's sun, through glass) is never ended by it. Its probability reads
  // the throughput times eta_scale, the product of eta^2 over the path's refractions, which
  // divides out the radiance scaling 1/eta^2 that a refraction into glass puts in the throughput
  // (pbrt-v4's etaScale; Cycles leaves that factor out of its throughput altogether): a path
  // inside a clear glass ball survives as one outside it does. Before, the roulette came right
  // after each scatter, from min(0.95, throughput) with the 1/2.25: a glass ball's relMSE
  // at equal samples was 2.2x Cycles' (docs/benchmarks.md, issue 31).
  float eta_scale = 1.0f;
  bool roulette_pending = false;
  // The segment's index for the sampler's dimensions (path_dim): unlike depth it also counts
  // pass-through segments, so no dimension is used twice on one path.
  for (int depth = 0, vertex = 0;; ++depth, ++vertex) {
    ++rays.closest;
    const std::optional<SurfaceHit> traced = first ? std::nullopt : scene.intersect(ray);
    const std::optional<SurfaceHit>& hit = first ? *first : traced;
    first = nullptr;  // only the camera ray's hit is given

    // ---- Participating media along the ray: emission integrated exactly, a free-flight
    // distance sampled against the channels' mean density (MediumSegment; grid media: by
    // ratio and delta tracking) ----
    std::optional<MediumSegment> segment;
    float t_scatter = kInfinity;
    bool use_equiangular = false;
    if (media && !stack.empty()) {
      segment.emplace(stack, ray, path.channels(), [&](int m) -> const MediumChannels& { return path.medium_channels(m); });
      if (volume_done) segment->scatters = false;  // transmittance only
      const float t_end = hit ? hit->t : kInfinity;
      path.medium_emission(depth, segment->emission_integral(t_end));
      segment->set_channel_weights(path.channel_weights());
      const float u_channel = sampler.get1d(path_dim(vertex, kDimMediumChannel));
      const float u_distance = sampler.get1d(path_dim(vertex, kDimMediumDistance));
      t_scatter = segment->sample_distance(u_channel, u_distance, t_end);
      if (!(t_scatter < t_end)) t_scatter = kInfinity;
      // Homogeneous media: next-event estimation also from an equiangular distance toward a
      // point-like light, MIS with the free flight's (grid media keep free flights only).
      if (!segment->heterogeneous() && segment->scatters && !lights.empty() && depth + 1 < s.max_depth) {
        equiangular_next_event(lights, ray, t_end, *segment, shadow, sampler, vertex, depth, path);
        use_equiangular = true;
      }
    }

    // Cycles' point and spot lights of radius > 0: disks that BSDF rays may hit (MIS with
    // their sampling; a mirror shows them). Camera rays do not see them. In a medium, a disk
    // before the sampled scattering point is reached with the free flight's factor to it.
    if (depth > 0) {
      float t_disk, pdf_disk;
      RGB Le;
      const float t_max = std::min(hit ? hit->t : kInfinity, t_scatter);
      if (const int l = lights.intersect_disk(ray, t_max, &t_disk, &Le, &pdf_disk); l >= 0) {
        if (segment) {
          const auto saved = path.save();
          path.medium_weight(segment->pass_weight(t_disk));
          path.disk_light(depth, l, Le, pdf_disk);
          path.restore(saved);
        } else {
          path.disk_light(depth, l, Le, pdf_disk);
        }
      }
    }

    if (segment && t_scatter < kInfinity) {
      // ---- Scattering in the medium: next-event estimation through the phase function, MIS
      // with phase sampling (the phase function as the BSDF of a medium vertex) ----
      path.medium_weight(segment->scatter_weight(t_scatter));
      const Vec3 p = ray.at(t_scatter);
      if (depth + 1 >= s.max_depth) return 0.0f;
      if (roulette_pending) {
        roulette_pending = false;
        if (!path.survive(sampler.get1d(path_dim(vertex, kDimRoulette)), eta_scale)) return 0.0f;
      }
      if (!lights.empty()) {
        const float u_light = sampler.get1d(path_dim(vertex, kDimLight));
        const Vec2 u2 = sampler.get2d(path_dim(vertex, kDimLight2));
        if (auto ls = lights.sample_li(p, u_light, u2);
            ls && ls->pdf > 0 && !ls->L.is_black() &&
            !(ls->light >= 0 && lights.lights()[ls->light].lit_by_bsdf_rays_only())) {
          const float cos_theta = dot(ray.d, ls->wi);
          shadow.in_medium();
          if (const ChannelValues T = shadow.transmittance(p, nullptr, *ls, path.shadow_channels(ray.state));
              !is_blocked(T, path.channels())) {
            // The free flight's share of the MIS with equiangular sampling toward this light.
            const float w = use_equiangular ? free_flight_weight(lights, *ls, ray, hit ? hit->t : kInfinity, *segment, t_scatter) : 1.0f;
            const auto saved = path.save();
            if (w < 1) path.medium_weight(uniform_channels(w));
            path.medium_next_event(depth, *ls, segment->phase(cos_theta), segment->phase_pdf(cos_theta), T);
            path.restore(saved);
          }
        }
      }
      const float u_lobe = sampler.get1d(path_dim(vertex, kDimLobe));
      const Vec2 u = sampler.get2d(path_dim(vertex, kDimScatter2));
      const Vec3 wi = segment->sample_phase(ray.d, u_lobe, u);
      const float cos_theta = dot(ray.d, wi);
      const float pdf = segment->phase_pdf(cos_theta);
      if (!(pdf > 0)) return 0.0f;
      min_ray_pdf = std::min(min_ray_pdf, pdf);
      ChannelValues ratio = segment->phase(cos_theta);
      for (float& r : ratio) r /= pdf;
      path.medium_scattered(p, pdf, ratio);
      if (scene.volume_bounces >= 0 && ++volume_scatters > scene.volume_bounces) volume_done = true;
      const RayState state = ray.state.volume_next();
      ray = Ray(p, wi);  // a volume ray: every surface is there for it
      ray.state = state;
      roulette_pending = depth + 1 >= s.rr_depth;  // Russian roulette at the next vertex
      continue;
    }
    if (segment) path.medium_weight(segment->pass_weight(hit ? hit->t : kInfinity));

    if (!hit) {
      // A camera ray that leaves the scene after transparent bounces only (depth 0) sees no
      // background with a transparent film (Cycles' PATH_RAY_TRANSPARENT_BACKGROUND): the
      // sample's transparency is the average of its throughput (integrate_background: a red
      // pane leaves 1/3, alpha 2/3, no colour). A holdout leaves the camera's throughput, 1.
      if (depth == 0 && (s.film_transparent || ray.held_out)) return path_transparency(path);
      path.environment(depth, ray);
      return 0.0f;
    }
    if (hit->light >= 0) path.area_light(depth, *hit, ray);
    // Light Paths > Transparent reached: the ray that made the last allowed transparent bounce
    // sees this surface's emission and ends here (Cycles' PATH_RAY_TERMINATE_ON_NEXT_SURFACE,
    // path_state.h path_state_next).
    if (transparent_done(scene.transparent_bounces, ray.state)) return 0.0f;
    // ---- A pass-through surface: the path goes on as if it were not there, keeping its kind of
    // ray, not counting a bounce. A clear Transparent BSDF counts a transparent bounce (Cycles'
    // LABEL_TRANSPARENT); a light object (no shadow: Cycles' lights are not geometry) and a
    // volume boundary (Cycles' volume_bounds_bounce) count none.
    const Material& material = scene.material(hit->material);
    if (material.is_pass_through() && (media && material.interior >= 0 ? boundaries < kMaxBoundaries
                                       : material.transparent_shadow() || pass_through < kMaxPassThrough)) {
      // A volume boundary (Blender's Volume-only material) enters or leaves its medium.
      if (media && material.interior >= 0) {
        ++boundaries;
        stack.cross(hit->mesh, material.interior, dot(ray.d, hit->ng) < 0);
      } else if (!material.transparent_shadow()) {
        ++pass_through;
      }
      const bool camera = ray.camera;
      const uint8_t bounce = ray.bounce;
      RayState state = ray.state;
      if (material.transparent_shadow() && material.interior < 0) ++state.transparent;
      ray = Ray(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
      ray.camera = camera;
      ray.bounce = bounce;
      ray.state = state;
      --depth;
      continue;
    }
    if (depth + 1 >= s.max_depth || volume_done) return 0.0f;
    if (roulette_pending) {
      roulette_pending = false;
      if (!path.survive(sampler.get1d(path_dim(vertex, kDimRoulette)), eta_scale)) return 0.0f;
    }
    ClosureFilter filter;
    if (filter_closures) {
      // Filter Glossy g: blur where p_min / g < 1 (Cycles stores 1 / g: surface_shader.h).
      if (scene.filter_glossy > 0.0f && min_ray_pdf < scene.filter_glossy)
        filter.blur_alpha = 0.5f * std::sqrt(1.0f - min_ray_pdf / scene.filter_glossy);
      if (ray.bounce == kRayDiffuse) {  // Cycles' PATH_RAY_DIFFUSE: the last bounce's kind only
        if (!scene.caustics_reflective) filter.lobes &= ~kRayGlossy;
        if (!scene.caustics_refractive) filter.lobes &= ~kRayTransmission;
      }
    }
    if (!path.prepare(*hit, filter)) return 0.0f;
    const Vec3 wo = hit->frame.to_local(-ray.d);
    if (wo.z == 0) return 0.0f;

    // ---- Emitter sampling (next-event estimation). A light lit only by BSDF rays (the World
    // hidden from some kinds, lobe_split.h) is not sampled.
    if (!path.is_delta() && !lights.empty()) {
      const float u_light = sampler.get1d(path_dim(vertex, kDimLight));
      const Vec2 u2 = sampler.get2d(path_dim(vertex, kDimLight2));
      if (auto ls = lights.sample_li(hit->p, u_light, u2);
          ls && ls->pdf > 0 && !ls->L.is_black() &&
          !(ls->light >= 0 && lights.lights()[ls->light].lit_by_bsdf_rays_only())) {
        if (media) shadow.at_surface(hit->mesh, material.interior, hit->ng, ray.d);
        path.next_event(depth, *hit, wo, *ls, shadow);
      }
    }

    // ---- BSDF sampling ----
    const float uc = sampler.get1d(path_dim(vertex, kDimLobe));
    const Vec2 u = sampler.get2d(path_dim(vertex, kDimScatter2));
    const std::optional<BsdfSample> bs = path.scatter(*hit, wo, uc, u);
    if (!bs) return 0.0f;
    const Vec3 wi = hit->frame.to_world(bs->wi);
    // A sample through a surface with an interior medium (glass of murky water) crosses it.
    if (media && material.interior >= 0 && (dot(wi, hit->ng) < 0) == (dot(ray.d, hit->ng) < 0))
      stack.cross(hit->mesh, material.interior, dot(ray.d, hit->ng) < 0);
    if (!bs->delta && !is_transparent_pass(*bs)) min_ray_pdf = std::min(min_ray_pdf, bs->pdf);
    const RayState state = next_ray_state(ray.state, bs->lobe, bs->transmission, bs->delta, bs->eta);
    if (is_transparent_pass(*bs)) {
      // Through a Transparent BSDF: a transparent bounce, not a bounce (Cycles' path_state_next
      // counts it against Light Paths > Transparent only and keeps the ray's flags), so the
      // depth and the kind of ray stay: a camera ray is still one behind the surface.
      const bool camera = ray.camera;
      const uint8_t bounce = ray.bounce;
      ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
      ray.camera = camera;
      ray.bounce = bounce;
      ray.state = state;
      --depth;
    } else {
      ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
      ray.bounce = bs->lobe;  // surfaces hidden from this kind of ray let it through
      ray.state = state;      // Light Path's view of it (Cycles' path_state_next)
    }

    if (bs->transmission) eta_scale *= sqr(bs->eta);  // 1 through a Transparent BSDF
    // ---- Russian roulette: at the next vertex, if the ray meets one ----
    roulette_pending = depth + 1 >= s.rr_depth;
  }
}

// The radiance of one camera path (path.L after trace_camera_path), with its transparency (0:
// it covered its pixel; trace_camera_path) and its shadow rays counted: the path tracers' Li,
// RGB and spectral.
template <typename P, typename S>
auto camera_path_radiance(const Scene& scene, const CameraPathSettings& s, Ray ray, S& sampler, RayCounts& rays, P& path,
                          const std::optional<SurfaceHit>* first, float* transparent) {
  const float t = trace_camera_path(scene, s, ray, sampler, rays, path, first);
  if (transparent) *transparent = t;
  rays.shadow += path.shadow_rays;
  return path.L;
}

}  // namespace gp
