// What every spectral estimator shares, below the method families (spectral path tracing,
// spectral photons, spectral gradients): the spectral mode a scene renders in, the spectra of
// its colours upsampled once, the material and lights seen at a set of wavelengths.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"
#include "core/spectrum.h"
#include "lights/light.h"
#include "materials/bsdf.h"
#include "materials/material.h"
#include "materials/spectral_material.h"
#include "media/medium.h"
#include "scene/scene.h"

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
  std::vector<MediumSpectra> media;  // Scene::media's coefficients, upsampled (media/medium.h)
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
  WavelengthParams(const WavelengthParams&) = delete;
  WavelengthParams& operator=(const WavelengthParams&) = delete;
  // (a mix's parameters hold their components: destroyed with the array)
  ~WavelengthParams() {
    if (made_) std::destroy_at(&params_);
  }
  // The array, constructed (it is then written in full by the caller).
  BsdfParams* make() {
    if (made_) std::destroy_at(&params_);
    made_ = true;
    return std::construct_at(&params_)->data();
  }

 private:
  bool made_ = false;
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
    return at_point(m, shading::ShadingContext::at_uv(uv), local);
  }
  // The same at a hit, a node graph seeing its whole shading context (position, object, ray).
  const BsdfParams* material(const SurfaceHit& hit, WavelengthParams& local) const;
  // Whether material m's parameters are made per point (textures or a graph drive them).
  bool per_point(int m) const { return per_point_[static_cast<size_t>(m)] != 0; }
  // For such a material, at shading context ctx: the parameters at each wavelength, and in *rgb
  // the point's RGB ones, from the same run of its node graph (what Bsdf(m, ctx) holds).
  const BsdfParams* material(int m, const shading::ShadingContext& ctx, WavelengthParams& local, BsdfParams* rgb) const {
    return at_point(m, ctx, local, rgb);
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
  const BsdfParams* at_point(int m, const shading::ShadingContext& ctx, WavelengthParams& local,
                             BsdfParams* rgb = nullptr) const;
};

// Spectral radiance of a light sample over its light's spectrum: lights scale their RGB
// emission by grey factors only (distance, spot falloff), so the factor read off the brightest
// channel applies to the spectrum.
float light_scale(const LightSample& ls, const Light& l);
// Factor turning a light's RGB emission (times grey factors: distance, falloff, pdfs) into its
// spectrum: the grey factor read off the brightest channel of the emission colour `emit`.
float grey_factor(const RGB& value, const RGB& emit);

// The spectrum of radiance `value` (RGB: the light's emission times grey factors, or what an
// environment sends along one direction) that light l sends: for a light of one colour, its
// spectrum (SceneSpectra::light) times the grey factor read off its brightest channel; for an
// environment whose colour varies with direction (an image, Light Path: Is Camera Ray), `value`
// itself upsampled as an illuminant, per hit, as textured emission is.
RgbSpectrum light_spectrum(const SceneSpectra& spectra, const LightSet& lights, int l, const RGB& value);
// Whether light l is an environment whose colour varies with direction (light_spectrum's case 2),
// or an area light whose node graph gives its colour per point (and per ray: Light Path): its
// RGB is upsampled where it is seen.
inline bool varies_with_direction(const LightSet& lights, int l) {
  return (l == lights.environment() && lights.environment_textured()) ||
         (l >= 0 && lights.lights()[l].emission_graph != nullptr);
}

// A wavelength bundle's throughput as medium channels (MediumSegment's per-channel weights)
// and back: the spectral camera path, SPPM's spectral eye and the spectral photon share them.
inline ChannelValues beta_channels(const SpectralValues& beta, int C) {
  ChannelValues w{};
  for (int k = 0; k < C; ++k) w[k] = beta[k];
  return w;
}
inline void scale_by_channels(SpectralValues& beta, const ChannelValues& w, int C) {
  for (int k = 0; k < C; ++k) beta[k] *= w[k];
}

}  // namespace gp
