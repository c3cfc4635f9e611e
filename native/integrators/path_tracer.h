// Reference path tracer: unidirectional path tracing with next-event estimation and multiple
// importance sampling (power heuristic, Veach 1997 §9.2), Russian roulette and a depth limit.
// One sample per pixel per pass, box pixel filter; every pixel of every pass draws from its
// own random stream, so the image is independent of the thread count.
//
// Parameters (defaults):
//   max_depth  32     longest path in segments (camera ray = 1)
//   rr_depth   3      depth from which Russian roulette may end paths
//   seed       0      random seed
//   threads    0      worker threads (0 = all cores)
//   tile_size  16     pixels per tile edge (scheduling only; does not change the image)
//
// Passes: combined.
#pragma once

#include <atomic>
#include <vector>

#include "core/rng.h"
#include "integrators/integrator.h"
#include "integrators/pixel_estimate.h"

namespace gp {

class PathTracer : public Integrator {
 public:
  PathTracer(const Scene& scene, const Params& params);
  std::string name() const override { return "pt"; }
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;

  // Radiance along one camera ray (exposed for tests); counts the rays it traces.
  RGB Li(Ray ray, Rng& rng, RayCounts& rays) const;

 private:
  const Scene& scene_;
  int max_depth_, rr_depth_, threads_, tile_size_;
  uint64_t seed_;
  int width_, height_;
  PixelEstimate estimate_;
};

}  // namespace gp
