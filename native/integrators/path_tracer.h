// Reference path tracer: unidirectional path tracing with next-event estimation and multiple
// importance sampling (power heuristic, Veach 1997 §9.2), Russian roulette and a depth limit.
// One sample per pixel per pass, box pixel filter; every pixel of every pass draws from its
// own random stream, so the image is independent of the thread count.
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods pt`, docs/methods.md#pt). Clamping as Cycles' Light Paths > Clamping:
// direct is emission seen by the camera and light reaching the first surface (NEE there, or
// emission hit by its BSDF ray); indirect is the rest.
//
// Participating media (media/medium.h) are tracked in the shared loop (paths/camera_path.h):
// free-flight distances by a throughput-weighted channel, next-event estimation through the
// phase function with MIS against phase sampling, exact Beer-Lambert transmittance on shadow
// rays, the media's emission integrated along each segment.
//
// Passes: combined; alpha with film_transparent.
#pragma once

#include <atomic>
#include <vector>

#include "core/rng.h"
#include "integrators/integrator.h"
#include "integrators/paths/camera_path.h"
#include "integrators/pixel_estimate.h"

namespace gp {

class PathTracer : public Integrator {
 public:
  PathTracer(const Scene& scene, const Params& params);
  std::string name() const override { return "pt"; }
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;

  // Radiance along one camera ray (exposed for tests); counts the rays it traces. With
  // film_transparent, a camera ray that escapes (after transparent bounces only) gives 0 and sets
  // *transparent to its transparency (paths/medium_walk.h path_transparency; 0 otherwise).
  // `first`, when given, is the closest hit of `ray` already traced (a tile's camera rays are
  // traced together, Scene::intersect_coherent).
  RGB Li(Ray ray, Rng& rng, RayCounts& rays, float* transparent = nullptr,
         const std::optional<SurfaceHit>* first = nullptr) const;
  // The same with the path's numbers from a sampler (core/sampler.h), as iterate() draws them.
  template <class S>
  RGB Li(Ray ray, S& sampler, RayCounts& rays, float* transparent = nullptr,
         const std::optional<SurfaceHit>* first = nullptr) const;

 private:
  const Scene& scene_;
  CameraPathSettings settings_;
  float clamp_direct_, clamp_indirect_;
  int threads_, tile_size_;
  uint64_t seed_;
  SamplingPattern pattern_;
  int width_, height_;
  PixelEstimate estimate_;
  std::vector<MediumChannels> media_;  // the scene's media at R, G, B
};

}  // namespace gp
