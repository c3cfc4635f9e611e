#include "integrators/path_tracer.h"

#include <chrono>

#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/lobe_split.h"
#include "integrators/paths/camera_path.h"
#include "materials/bsdf.h"

namespace gp {

PathTracer::PathTracer(const Scene& scene, const Params& params)
    : scene_(scene),
      settings_{.max_depth = params.get<int>("max_depth"), .rr_depth = params.get<int>("rr_depth"),
                .film_transparent = params.get<bool>("film_transparent"), .camera_media = CameraMedia(scene)},
      clamp_direct_(params.get<float>("clamp_direct")),
      clamp_indirect_(params.get<float>("clamp_indirect")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      seed_(params.get<uint64_t>("seed")),
      pattern_(parse_sampling_pattern(params.get<std::string>("sampling_pattern"))),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      estimate_(std::max(1, width_), std::max(1, height_), &scene.camera) {  // sizes checked just below
  check_image_size(width_, height_);  // the parameters are checked by their declarations (methods.cpp)
  for (const Medium& m : scene.media) media_.push_back(rgb_channels(m));
}

namespace {

// The RGB path (paths/camera_path.h): throughput beta, emission found by BSDF rays weighed by
// the power heuristic against light sampling, Cycles' clamping (direct: emission the camera
// sees and light reaching the first surface; indirect: the rest), Cycles' per-kind light
// visibility through LobeSplit.
struct RgbPath {
  const Scene& scene;
  const LightSet& lights;
  float clamp_direct, clamp_indirect;
  bool split_lobes;
  RGB L{0.0f}, beta{1.0f};
  // The last bounce was smooth: emission found next takes full weight. True for the camera ray
  // (Cycles' PATH_RAY_MIS_SKIP), which only a transparent pass carries past depth 0.
  bool specular_bounce = true;
  float prev_pdf = 0;  // solid-angle pdf of the BSDF sample that produced the ray
  Vec3 prev_p;
  LobeSplit prev;      // the previous vertex's lobes, where some light is hidden from some kinds
  bool medium_vertex = false;  // the ray was scattered by a medium (every light sees it)
  std::optional<Bsdf> bsdf;
  const std::vector<MediumChannels>* media;  // the scene's media at R, G, B (PathTracer)

  RgbPath(const Scene& s, float cd, float ci, const std::vector<MediumChannels>* m)
      : scene(s), lights(s.light_set()), clamp_direct(cd), clamp_indirect(ci),
        split_lobes(s.lights_hidden_from_some_lobes()), media(m) {}

  // A contribution clamped as Cycles does (sum of |R|+|G|+|B| at most the limit; 0 = off).
  RGB clamped(const RGB& c, bool direct) const {
    const float limit = direct ? clamp_direct : clamp_indirect;
    const float sum = std::abs(c.r) + std::abs(c.g) + std::abs(c.b);
    return limit > 0 && sum > limit ? c * (limit / sum) : c;
  }
  // Emission Le found by the BSDF ray from a light visible to `vis` (MIS against pdf_light).
  RGB emitted(int depth, const RGB& Le, uint8_t vis, float pdf_light) {
    if (depth == 0) return beta * Le;
    if (vis != kAllLobes && !medium_vertex) return prev.weigh(Le, vis, specular_bounce, beta, pdf_light);
    return beta * Le * (specular_bounce ? 1.0f : power_heuristic(prev_pdf, pdf_light));
  }
  // Emission found at depth 0 or 1 is direct light (Cycles' clamping), deeper is indirect.
  void disk_light(int depth, int l, const RGB& Le, float pdf) {
    L += clamped(emitted(depth, Le, lights.lights()[l].visible_lobes, pdf), depth <= 1);
  }
  // The World's Ray Visibility: Camera for camera rays, its lobes for bounce rays, by Cycles'
  // rule for the World (lobe_split.h), not a light's.
  void environment(int depth, const Ray& ray) {
    const int env = lights.environment();
    if (env < 0 || !(depth > 0 || lights.lights()[env].visible_to_camera)) return;
    const Light& world = lights.lights()[env];
    // A World lit only by BSDF rays is not sampled by next-event estimation: a phase-sampled
    // ray finds it with full weight.
    if (depth > 0 && world.lit_by_bsdf_rays_only()) {
      const RGB Le = lights.environment_radiance(ray);
      L += clamped(medium_vertex ? beta * Le : prev.weigh_world(Le, world.visible_lobes, specular_bounce, beta), depth <= 1);
      return;
    }
    // The light's density only where MIS weighs the hit (emitted(): not for the camera ray or
    // after a singular bounce), from the same projection of the direction as the radiance.
    float pdf_light = 0.0f;
    const RGB Le = depth > 0 && !specular_bounce ? lights.environment_radiance(ray, &pdf_light)
                                                 : lights.environment_radiance(ray);
    L += clamped(emitted(depth, Le, world.visible_lobes, pdf_light), depth <= 1);
  }
  void area_light(int depth, const SurfaceHit& hit, const Ray& ray) {
    const RGB Le = lights.area_radiance(hit.light, -ray.d, hit.p, &hit.ray);
    if (!Le.is_black())
      L += clamped(emitted(depth, Le, lights.lights()[hit.light].visible_lobes,
                           depth == 0 ? 0.0f : lights.pdf_area(hit.light, prev_p, hit.p, ray.d)),
                   depth <= 1);
  }
  bool prepare(const SurfaceHit& hit, const ClosureFilter& filter) {
    bsdf.emplace(scene.bsdf(hit));
    if (filter.active()) bsdf->filter(filter);
    return !bsdf->is_black();
  }
  bool is_delta() const { return bsdf->is_delta(); }
  // Next-event estimation's MIS weight against the BSDF's (or phase function's) density, which
  // `other_pdf()` gives, evaluated only when needed: a delta light without a disk takes it all.
  template <class Pdf>
  static float light_weight(const LightSample& ls, Pdf other_pdf) {
    return !ls.delta       ? power_heuristic(ls.pdf, other_pdf())
           : ls.mis_pdf > 0 ? power_heuristic(ls.mis_pdf, other_pdf())
                            : 1.0f;
  }
  // A light hidden from some kinds of bounce ray lights only the lobes of the kinds it is
  // visible to (Cycles' closure exclusion), with the MIS density of those lobes.
  void next_event(int depth, const SurfaceHit& hit, const Vec3& wo, const LightSample& ls, const ShadowTest& shadow) {
    const uint8_t vis = ls.light >= 0 ? lights.lights()[ls.light].visible_lobes : kAllLobes;
    const Vec3 wi = hit.frame.to_local(ls.wi);
    RGB f = bsdf->eval(wo, wi, TransportMode::Radiance, vis) * std::abs(wi.z);
    if (f.is_black()) return;
    ++shadow_rays;
    const ChannelValues T = shadow.transmittance(hit.p, &hit.ng, ls, shadow_channels(hit.ray));
    if (is_blocked(T, 3)) return;
    f *= to_rgb(T);  // media and transparent surfaces (1 where there are none)
    const float w = light_weight(ls, [&] { return bsdf->pdf(wo, wi, vis); });
    L += clamped(beta * f * ls.L * (w / ls.pdf), depth == 0);
  }
  std::optional<BsdfSample> scatter(const SurfaceHit& hit, const Vec3& wo, float uc, Vec2 u) {
    auto bs = bsdf->sample(wo, uc, u);
    if (!bs || bs->pdf <= 0 || bs->f.is_black()) return std::nullopt;
    if (is_transparent_pass(*bs) && scene.material(hit.material).transparent_shadow()) {
      // Through a Transparent BSDF: the MIS state of the vertex before it stays (next-event
      // estimation from there passed this surface too).
      beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
      if (split_lobes) prev.beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
      return bs;
    }
    if (split_lobes) {
      prev.beta = beta;
      prev.lobe = bs->lobe;
      if (!bs->delta) prev.fill(*bsdf, wo, bs->wi);
    }
    beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
    specular_bounce = bs->delta;
    medium_vertex = false;
    prev_pdf = bs->pdf;
    prev_p = hit.p;
    return bs;
  }
  bool survive(float u, float eta_scale) {
    const float survival = camera_path_survival(beta.max_component() * eta_scale);
    if (!(u < survival)) return false;
    beta = beta / survival;
    prev.beta = prev.beta / survival;
    return true;
  }
  int64_t shadow_rays = 0;

  // ---- Participating media (paths/camera_path.h), at the three channels R, G, B ----
  static RGB to_rgb(const ChannelValues& v) { return {v[0], v[1], v[2]}; }
  int channels() const { return 3; }
  const MediumChannels& medium_channels(int m) const { return (*media)[m]; }
  ShadowChannels shadow_channels(const RayState& state) const {
    return {.count = 3, .media = media->empty() ? nullptr : media->data(), .state = state};
  }
  ChannelValues channel_weights() const { return {beta.r, beta.g, beta.b}; }
  struct Saved {
    RGB beta, prev_beta;
  };
  Saved save() const { return {beta, prev.beta}; }
  void restore(const Saved& s) {
    beta = s.beta;
    prev.beta = s.prev_beta;
  }
  // The free flight's factor; the previous vertex's throughput for per-kind light visibility
  // (LobeSplit) sees the same medium.
  void medium_weight(const ChannelValues& w) {
    beta *= to_rgb(w);
    prev.beta *= to_rgb(w);
  }
  // Emission of the medium along the ray (found by the ray only: no next-event estimation of
  // it, as in Cycles); direct light on the segments to the first vertex, as emitters found there.
  void medium_emission(int depth, const ChannelValues& e) {
    if (e[0] > 0 || e[1] > 0 || e[2] > 0) L += clamped(beta * to_rgb(e), depth <= 1);
  }
  void medium_next_event(int depth, const LightSample& ls, const ChannelValues& phase, float phase_pdf,
                         const ChannelValues& transmittance) {
    ++shadow_rays;  // counted as the loop traced it
    const RGB T = to_rgb(transmittance);
    const float w = light_weight(ls, [&] { return phase_pdf; });
    L += clamped(beta * to_rgb(phase) * T * ls.L * (w / ls.pdf), depth == 0);
  }
  void medium_scattered(const Vec3& p, float phase_pdf, const ChannelValues& ratio) {
    beta *= to_rgb(ratio);
    specular_bounce = false;
    medium_vertex = true;
    prev_pdf = phase_pdf;
    prev_p = p;
  }
};

}  // namespace

template <class S>
RGB PathTracer::Li(Ray ray, S& sampler, RayCounts& rays, float* transparent, const std::optional<SurfaceHit>* first) const {
  RgbPath path(scene_, clamp_direct_, clamp_indirect_, &media_);
  return camera_path_radiance(scene_, settings_, ray, sampler, rays, path, first, transparent);
}
template RGB PathTracer::Li(Ray, SobolSampler&, RayCounts&, float*, const std::optional<SurfaceHit>*) const;
template RGB PathTracer::Li(Ray, IndependentSampler&, RayCounts&, float*, const std::optional<SurfaceHit>*) const;

RGB PathTracer::Li(Ray ray, Rng& rng, RayCounts& rays, float* transparent, const std::optional<SurfaceHit>* first) const {
  IndependentSampler sampler{rng};
  return Li(ray, sampler, rays, transparent, first);
}

void PathTracer::iterate(ProgressSink* sink) {
  estimate_.run_camera_pass(scene_, seed_, tile_size_, threads_, sink, stats_, pattern_,
                            [this](const Ray& ray, auto& rng, RayCounts& rays, const std::optional<SurfaceHit>* first) {
                              float transparent = 0.0f;  // Cycles' transparent pass: alpha 1 - it
                              const RGB L = Li(ray, rng, rays, &transparent, first);
                              return PixelSample{L, 1.0f - transparent};
                            });
}

void PathTracer::develop(Film& film) const {
  estimate_.develop(film, pass::kCombined);
  if (writes_alpha(settings_.film_transparent, scene_)) estimate_.develop_alpha(film);
}

}  // namespace gp
