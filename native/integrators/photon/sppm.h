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
// Parameters (defaults):
//   photons             100000  photons emitted per pass
//   alpha               0.7     fraction of new photons kept (eq. 7.2)
//   radius              0       initial radius in metres; 0 = from the pixel footprint
//                               (the pixel's cone grown along the eye path, two pixels wide)
//   confidence          0.5     confidence 1 - beta of the error bound (eq. 6.10)
//   error_bound         calibrated  calibrated | thesis: the error pass's bound (progressive_photon.h,
//                               docs/error-calibration.md); thesis = eq. 6.12 as written
//   hash                exact   photon lookup: exact | stochastic (thesis ch. 10)
//   specular_threshold  0.05    roughness at or below which a surface is specular for photons
//   max_depth           32      longest eye or photon path in segments
//   rr_depth            3       eye-path depth from which Russian roulette may end it
//   photon_sampler      uniform uniform | adaptive: photon paths by adaptive MCMC on their
//                               visibility (thesis ch. 8, adaptive_photons.h; alias sppm-adaptive)
//   chains              64      Markov chains of the adaptive sampler
//   seed 0, threads 0, tile_size 16 as for "pt"
//   spectral            auto    auto | rgb | spectral (spectral_pt.h use_spectral): spectral
//                               photons; auto only on scenes with a dispersive material
//   wavelengths         4       wavelengths per pass in spectral mode (1..8)
//   film_transparent    false   camera rays that escape see no background; writes pass alpha
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
  // default_sampler "adaptive" makes the method alias "sppm-adaptive" (adaptive_photons.h).
  Sppm(const Scene& scene, const Params& params, const std::string& default_sampler = "uniform")
      : ProgressivePhotonMapping(scene, params, true, true, default_sampler, true),
        name_(default_sampler == "uniform" ? "sppm" : "sppm-adaptive") {
    read_film_transparent(params);
  }
  std::string name() const override { return name_; }

 private:
  std::string name_;
};

}  // namespace gp
