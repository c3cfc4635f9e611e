// Stochastic progressive photon mapping (SPPM): thesis ch. 7 (Hachisuka, Jensen 2009).
// Every iterate() re-traces one camera path per pixel (jittered in the pixel and on the lens,
// through specular and glossy bounces) to a new measurement point, then gathers one photon
// pass there into statistics shared by the whole pixel: radius eq. 7.3, count eq. 7.2, flux
// eq. 7.4-7.5, radiance eq. 7.1. Anti-aliasing, depth of field and glossy-seen-through-
// specular converge because the statistics are shared over the pixel (§7.3).
//
// Light at the measurement point: direct light by next-event estimation (one light sample,
// no MIS because the camera path ends there) and everything else from photons deposited
// after at least one bounce; emission is added where the camera path meets it at depth 0 or
// after a specular/glossy bounce. Each light path is thus counted by exactly one estimator.
// The error estimate (thesis ch. 6) treats each pixel as one measurement point whose per-pass
// sample is this pass's direct light plus its photon estimate.
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods sppm`, docs/methods.md#sppm).
//
// Spectral photons (progressive_photon_spectral.cpp, docs/spectral.md): each pass samples one
// set of wavelengths (hero + rotations; the heroes of successive passes stratified), shared by
// its eye paths and photons; throughput and photon power are values at those wavelengths, and
// each pixel's gathered flux is converted to RGB before the RGB statistics. Not with the
// adaptive photon sampler (sppm-adaptive stays RGB).
//
// Passes: combined, error, radius, photon_count; alpha with film_transparent (RGB photons only;
// spectral photons leave the parameter unread).
#pragma once

#include "integrators/photon/progressive_photon.h"

namespace gp {

class Sppm : public ProgressivePhotonMapping {
 public:
  // `name`: "sppm", or its alias "sppm-adaptive", whose photon_sampler defaults to "adaptive"
  // (methods.cpp, adaptive_photons.h).
  Sppm(const Scene& scene, const Params& params, std::string name)
      : ProgressivePhotonMapping(scene, params, {.retrace = true, .nee = true, .adaptive_photons = true,
                                                 .spectral_photons = true, .media = true}),
        name_(std::move(name)) {
    read_film_transparent(params);
  }
  std::string name() const override { return name_; }

 private:
  std::string name_;
};

}  // namespace gp
