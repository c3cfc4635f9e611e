// Spectral path tracer: the reference path tracer's estimator (NEE + MIS, Russian roulette,
// depth limit) carried out at sampled wavelengths instead of RGB, with Cauchy dispersion in
// dielectrics (n = A + B / lambda^2) and spectra upsampled from the scene's RGB colours
// (core/spectrum.h). Each path carries C wavelengths: a uniformly sampled hero wavelength that
// drives every sampling decision and C - 1 rotations of it (hero wavelength sampling, Wilkie et
// al. 2014 [WND*14]). The contributions to the C wavelengths are combined with the balance
// heuristic over the wavelengths' path pdfs (spectral gradient sampling, eq. 3-4), extended to
// the two strategies of NEE and BSDF sampling in the "rescaled path probability" form (ratios
// r_k = p(x | lambda_k) / p(x | lambda_hero), as pbrt-v4's PathIntegrator). Non-dispersive
// vertices leave the ratios at 1 (the sampled direction does not depend on the wavelength);
// a rough dispersive dielectric scales them by its per-wavelength pdfs; a smooth dispersive
// refraction sets them to 0 for every wavelength but the hero's, which then carries the path
// alone (C = 1 is plain single-wavelength spectral path tracing).
//
// Methods: `spt` (C = 1) and `spt-hero` (C = 4); `pt` on a dispersive scene in spectral mode
// "auto" (see spectral_mode()) runs `spt-hero`.
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods spt`, docs/methods.md#spt).
//
// Passes: combined (RGB through CIE XYZ).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/rng.h"
#include "core/spectrum.h"
#include "integrators/integrator.h"
#include "integrators/paths/spectral_scene.h"
#include "integrators/paths/camera_path.h"
#include "integrators/pixel_estimate.h"
#include "materials/bsdf.h"
#include "materials/material.h"
#include "materials/spectral_material.h"

namespace gp {

class SpectralPathTracer : public Integrator {
 public:
  // `hero` selects the default C (4, else 1) and the method name.
  SpectralPathTracer(const Scene& scene, const Params& params, bool hero);
  std::string name() const override { return hero_ ? "spt-hero" : "spt"; }
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;

  int wavelengths() const { return count_; }
  // Spectral radiance at the wavelengths `wl` along one camera ray (exposed for tests).
  // `first`, when given, is the closest hit of `ray` already traced (trace_camera_rays).
  // With film_transparent, a camera ray that escapes (after transparent bounces only) gives 0 and
  // sets *transparent to its transparency (paths/medium_walk.h path_transparency; 0 otherwise).
  SpectralValues Li(Ray ray, const SampledWavelengths& wl, Rng& rng, RayCounts& rays,
                    const std::optional<SurfaceHit>* first = nullptr, float* transparent = nullptr) const;
  // The same with the path's numbers from a sampler (core/sampler.h), as iterate() draws them.
  template <class S>
  SpectralValues Li(Ray ray, const SampledWavelengths& wl, S& sampler, RayCounts& rays,
                    const std::optional<SurfaceHit>* first = nullptr, float* transparent = nullptr) const;

 private:
  const Scene& scene_;
  SceneSpectra spectra_;
  bool hero_;
  CameraPathSettings settings_;
  int count_, threads_, tile_size_;
  uint64_t seed_;
  SamplingPattern pattern_;
  int width_, height_;
  PixelEstimate estimate_;
};

}  // namespace gp
