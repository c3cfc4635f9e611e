// Gradient-domain path tracing (Kettunen et al. 2015, "Gradient-domain path tracing", KMA15;
// gradient-domain photon density estimation §3). Each pass traces one base path per pixel
// (path tracing with next-event estimation and power-heuristic MIS, as PathTracer) and shifts it
// to the four neighbouring pixels (integrators/shift/shift.h): the offset path starts at the
// same sub-pixel position and lens sample one pixel over, copies half-vectors through glossy and
// delta vertices, and reconnects to the base path at the first pair of consecutive diffuse
// vertices (an emitter hit counts as diffuse; a base ray that leaves the scene from a diffuse
// vertex is reconnected "at infinity", keeping its direction).
//
// Each forward difference I(i+1) - I(i) is sampled from both sides (base at i shifted right, base
// at i+1 shifted left); the two are combined by the balance heuristic of the path densities,
// w = p(x) / (p(x) + p(T x) |T'(x)|) per strategy (NEE or BSDF hit), as KMA15 §4.3. A failed
// shift gives the offset zero and the base weight 1; failures are counted by reason
// ("shift failed: ...") in Stats::extra.
//
// Light that reaches the camera through delta vertices only (emitters seen directly or in
// mirrors and glass) does not go through the gradients: it is kept apart and added after the
// reconstruction, as in the public gradient-domain code.
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods gpt`, docs/methods.md#gpt).
//
// Passes: combined (reconstruction + direct light), primal (the base paths' plain path-traced
// image, direct light included), gradient_x, gradient_y (the estimated forward differences plus
// those of the direct light, so that they describe the primal pass: `gradphoton reconstruct`
// of primal + gradients gives combined back).
#pragma once

#include <vector>

#include "core/rng.h"
#include "core/sampler.h"
#include "integrators/integrator.h"
#include "reconstruction/poisson.h"

namespace gp {

class GradientPathTracer : public Integrator {
 public:
  GradientPathTracer(const Scene& scene, const Params& params);
  std::string name() const override { return "gpt"; }
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;
  // Every per-kind switch, as the path tracer: trace() tags base and offset rays with the
  // base's lobes and weighs lights hidden from some kinds by the lobes that see them.

  // Offsets, in the order the per-pixel gradient sums are kept.
  enum Direction { kRight = 0, kLeft = 1, kDown = 2, kUp = 3 };

  // One base sample at film position `film` (in pixels) with its four offsets. The path's random
  // decisions come from `sampler` in a fixed order (NEE: 3, BSDF: 3, Russian roulette: 1 per
  // vertex), so a primary-sample-space chain can drive it (gdmlt.h). Thread-safe (const).
  struct Sample {
    RGB primal;      // base path radiance without the direct light
    RGB direct;      // light through delta vertices only (and emitters seen directly)
    RGB diff[4];     // MIS-weighted (offset - base) for right/down, (base - offset) for left/up
    bool has[4];     // offset inside the image
  };
  // `pixel_x`, `pixel_y` (whole-image pixels): the pixel the sample counts in, whose neighbours
  // the offsets are; -1: the pixel `film` lies in (gdmlt's splats). A pixel filter wider than a
  // pixel puts `film` outside its own pixel (core/rng.h start_pixel), so iterate() passes them.
  Sample trace(Vec2 film, Vec2 lens, Sampler& sampler, RayCounts& rays, std::map<std::string, double>* failures,
               int pixel_x = -1, int pixel_y = -1) const;

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  const Scene& scene_;
  int max_depth_, rr_depth_, threads_, tile_size_;
  uint64_t seed_;
  ReconOptions recon_;
  int width_, height_;
  std::vector<double> primal_, direct_, grad_;  // 3 per pixel; grad_ 4 * 3 per pixel
  std::vector<uint32_t> samples_;
};

}  // namespace gp
