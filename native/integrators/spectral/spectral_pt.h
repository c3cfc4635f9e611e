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
#include "integrators/pixel_estimate.h"
#include "materials/bsdf.h"
#include "materials/material.h"
#include "materials/spectral_material.h"

namespace gp {

// Name of the first dispersive material of the scene, or "" when there is none.
std::string first_dispersive_material(const Scene& scene);

// Spectral mode selection (`--spectral auto|rgb|spectral`, parameter `spectral`): `rgb` and
// `spectral` force the mode; `auto` renders spectrally only when the scene has a dispersive
// material. Throws ParamError for other values.
enum class SpectralMode { Auto, Rgb, Spectral };
SpectralMode parse_spectral_mode(const std::string& s);
bool use_spectral(SpectralMode mode, const Scene& scene);

// Spectra of a scene's colours, upsampled once (materials by index, lights by LightSet index).
struct SceneSpectra {
  explicit SceneSpectra(const Scene& scene);
  std::vector<RgbSpectrum> albedo;  // Material::color as a reflectance
  std::vector<RgbSpectrum> light;   // Light::emit as an illuminant
};

// The material seen by one wavelength at texture coordinate uv, as BSDF parameters
// (materials/spectral_material.h): a grey colour, the colour's spectrum at lambda (`albedo`,
// the constant colour's, or the texel's upsampled), a Cauchy IOR at lambda; textures, mix
// components and the rest as the RGB Bsdf has them.
BsdfParams monochromatic(const Material& m, const RgbSpectrum& albedo, Vec2 uv, float lambda);

// Room for the parameters of one material at each wavelength of a set, filled only for a
// textured material (SpectraAtWavelengths::at_point): eight BsdfParams are worth not
// initialising per vertex. Not a std::optional: GCC 12 zeroes a disengaged optional's whole
// storage (648 bytes per vertex: 12 % of spectral SPPM's eye pass on pool, docs/benchmarks.md).
class WavelengthParams {
 public:
  WavelengthParams() {}  // leaves params_ unconstructed: nothing is written unless make() is called
  // The array, constructed (it is then written in full by the caller).
  BsdfParams* make() { return std::construct_at(&params_)->data(); }

 private:
  union {
    std::array<BsdfParams, kMaxWavelengths> params_;
  };
};

// The scene's materials (monochromatic() per wavelength) and light spectra at one set of
// wavelengths, evaluated once for the set. SPPM shares one set per pass between all its eye
// paths, photons and gathers, so nothing spectral is evaluated per vertex, except for materials
// an image texture drives, which are looked up per point.
class SpectraAtWavelengths {
 public:
  void evaluate(const Scene& scene, const SceneSpectra& spectra, const SampledWavelengths& wl);
  // The parameters of material m at uv at each wavelength of the set (count of them): the
  // shared ones, or for a textured material those at uv, made in `local`.
  const BsdfParams* material(int m, Vec2 uv, WavelengthParams& local) const {
    if (!per_point_[static_cast<size_t>(m)]) return &bsdf_[static_cast<size_t>(m) * count_];
    return at_point(m, uv, local);
  }
  // Light l's spectrum (SceneSpectra::light) at each wavelength of the set.
  const float* light(int l) const { return &light_[static_cast<size_t>(l) * count_]; }
  // The spectral radiance at each wavelength of the set of the RGB `value` light l sends
  // (light_spectrum): out[k] for k < count.
  void emitted(int l, const RGB& value, float* out) const;

 private:
  int count_ = 0;
  const Scene* scene_ = nullptr;
  const SceneSpectra* spectra_ = nullptr;
  SampledWavelengths wl_;
  std::vector<BsdfParams> bsdf_;
  std::vector<uint8_t> per_point_;  // the material has textures: parameters per point
  std::vector<float> light_;
  const BsdfParams* at_point(int m, Vec2 uv, WavelengthParams& local) const;
};

// Spectral radiance of a light sample over its light's spectrum: lights scale their RGB
// emission by grey factors only (distance, spot falloff), so the factor read off the brightest
// channel applies to the spectrum.
float light_scale(const LightSample& ls, const Light& l);

// The spectrum of radiance `value` (RGB: the light's emission times grey factors, or what an
// environment sends along one direction) that light l sends: for a light of one colour, its
// spectrum (SceneSpectra::light) times the grey factor read off its brightest channel; for an
// environment whose colour varies with direction (an image, Light Path: Is Camera Ray), `value`
// itself upsampled as an illuminant, per hit, as textured emission is.
RgbSpectrum light_spectrum(const SceneSpectra& spectra, const LightSet& lights, int l, const RGB& value);

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
  SpectralValues Li(Ray ray, const SampledWavelengths& wl, Rng& rng, RayCounts& rays,
                    const std::optional<SurfaceHit>* first = nullptr) const;

 private:
  const Scene& scene_;
  SceneSpectra spectra_;
  bool hero_;
  int max_depth_, rr_depth_, count_, threads_, tile_size_;
  uint64_t seed_;
  int width_, height_;
  PixelEstimate estimate_;
};

}  // namespace gp
