// Progressive photon mapping (PPM): Hachisuka, "Progressive density estimation" thesis ch. 5
// (Hachisuka, Ogaki, Jensen 2008). One eye pass stores a measurement point per pixel (the
// first non-specular vertex, following every specular and glossy bounce); then every
// iterate() traces a photon pass, gathers the photons around each point, reduces its radius
// (eq. 5.9) and corrects its flux (eq. 5.12). Radiance is eq. 5.13. All light at the point,
// direct included, comes from photons; emission seen along the eye path is added as is.
// The error estimate is thesis ch. 6 (error_estimate.h).
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods ppm`, docs/methods.md#ppm).
//
//   film_transparent    false   camera rays that escape see no background; writes pass alpha
//
// Passes: combined, error, radius, photon_count; alpha with film_transparent.
#pragma once

#include "integrators/photon/progressive_photon.h"

namespace gp {

class Ppm : public ProgressivePhotonMapping {
 public:
  Ppm(const Scene& scene, const Params& params)
      : ProgressivePhotonMapping(scene, params, {.retrace = false, .nee = false, .adaptive_photons = true, .media = true}) {
    read_film_transparent(params);
  }
  std::string name() const override { return "ppm"; }
};

}  // namespace gp
