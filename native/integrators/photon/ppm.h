// Progressive photon mapping (PPM): Hachisuka, "Progressive density estimation" thesis ch. 5
// (Hachisuka, Ogaki, Jensen 2008). One eye pass stores a measurement point per pixel (the
// first non-specular vertex, following every specular and glossy bounce); then every
// iterate() traces a photon pass, gathers the photons around each point, reduces its radius
// (eq. 5.9) and corrects its flux (eq. 5.12). Radiance is eq. 5.13. All light at the point,
// direct included, comes from photons; emission seen along the eye path is added as is.
// The error estimate is thesis ch. 6 (error_estimate.h).
//
// Parameters (defaults):
//   photons             100000  photons emitted per pass (thesis default)
//   alpha               0.7     fraction of new photons kept (eq. 5.7)
//   radius              0       initial radius in metres; 0 = two pixel footprints
//   confidence          0.5     confidence 1 - beta of the error bound (eq. 6.10; §6.5.1 uses 50 %)
//   error_bound         calibrated  calibrated | thesis: the error pass's bound (progressive_photon.h,
//                               docs/error-calibration.md); thesis = eq. 6.12 as written
//   hash                exact   photon lookup: exact | stochastic (thesis ch. 10)
//   specular_threshold  0.05    roughness at or below which a surface is specular for photons
//   max_depth           32      longest eye or photon path in segments
//   rr_depth            3       eye-path depth from which Russian roulette may end it
//   photon_sampler      uniform uniform | adaptive (thesis ch. 8, adaptive_photons.h)
//   chains              64      Markov chains of the adaptive sampler
//   seed 0, threads 0, tile_size 16 as for "pt"
//
//   film_transparent    false   camera rays that escape see no background; writes pass alpha
//
// Passes: combined, error, radius, photon_count; alpha with film_transparent.
#pragma once

#include "integrators/photon/progressive_photon.h"

namespace gp {

class Ppm : public ProgressivePhotonMapping {
 public:
  Ppm(const Scene& scene, const Params& params) : ProgressivePhotonMapping(scene, params, false, false) {
    read_film_transparent(params);
  }
  std::string name() const override { return "ppm"; }
};

}  // namespace gp
