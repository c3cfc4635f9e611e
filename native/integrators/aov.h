// Auxiliary passes for compositing and denoising, as Cycles names them: Denoising Albedo,
// Normal and Depth. They depend only on the scene, not on the rendering method, so one
// estimator serves every method (the Python session runs it beside the method's passes).
//
//   depth   camera-space distance along the view axis of the first surface a camera ray hits
//           (Cycles' Depth/Z pass); 1e10 where the ray leaves the scene
//   normal  world-space shading normal, and albedo the surface's reflectance, both at the first
//           surface that is not a Dirac (smooth mirror or glass) BSDF: camera rays follow
//           mirrors and smooth glass there, weighting the albedo by what they pass, as Cycles'
//           denoising data does; light objects (pass-through surfaces) are crossed
//
// Each pass traces one camera ray per pixel at a jittered film position; the passes are the
// means over the passes run.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/film.h"
#include "materials/bsdf.h"
#include "scene/scene.h"

namespace gp {

// A surface's reflectance for the albedo pass: the colour of diffuse, conductor and glass;
// a plastic's base seen through its coat plus the coat's normal-incidence reflectance; the
// weighted albedo of a mix's parts; 0 for emission only. Of the BSDF the hit evaluated.
RGB bsdf_albedo(const Bsdf& bsdf);

class AovEstimator {
 public:
  static constexpr int kMaxPasses = 16;  // enough for antialiased edges; later passes are free
  AovEstimator(const Scene& scene, uint64_t seed, int threads);
  // One pass; if `cancelled` turns true while it runs, the pass stops and counts for nothing
  // (the means stay those of the whole passes), so a render's Esc is not held up by it.
  void add_pass(const std::function<bool()>& cancelled = {});
  int passes() const { return passes_; }
  // Adds the three passes (means so far; zero before any pass) to `film`, of the camera's size.
  void develop(Film& film) const;

 private:
  const Scene& scene_;
  uint64_t seed_;
  int threads_;
  int width_, height_;
  int passes_ = 0;
  std::vector<float> albedo_, normal_, depth_;  // sums: 3, 3 and 1 per pixel
};

}  // namespace gp
