// What the integrator tests share: run a method for a fixed number of passes and develop its
// film (the CLI's progressive loop without a progress sink), and the photon methods' parameters.
#pragma once

#include <cstdint>
#include <string>

#include "core/film.h"
#include "integrators/integrator.h"

namespace gp {

inline Film render(const std::string& method, const Scene& scene, int passes, const Params& params,
                   Stats* stats = nullptr) {
  auto integ = make_integrator(method, scene, params);
  run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  Film film;
  integ->develop(film);
  if (stats) *stats = integ->stats();
  return film;
}

inline Params photon_params(int64_t photons, uint64_t seed = 1, int threads = 0) {
  Params p;
  p.set("photons", photons);
  p.set("seed", seed);
  p.set("threads", threads);
  return p;
}

}  // namespace gp
