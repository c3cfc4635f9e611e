#include "integrators/paths/spectral_scene.h"

namespace gp {

std::string first_dispersive_material(const Scene& scene) {
  for (const Material& m : scene.materials)
    if (is_dispersive(m)) return m.name.empty() ? "(unnamed)" : m.name;
  return "";
}

SpectralMode parse_spectral_mode(const std::string& s) {
  if (s == "auto") return SpectralMode::Auto;
  if (s == "rgb") return SpectralMode::Rgb;
  if (s == "spectral") return SpectralMode::Spectral;
  throw ParamError("spectral mode must be auto, rgb or spectral, got '" + s + "'");
}

bool use_spectral(SpectralMode mode, const Scene& scene) {
  switch (mode) {
    case SpectralMode::Rgb: return false;
    case SpectralMode::Spectral: return true;
    case SpectralMode::Auto: return !first_dispersive_material(scene).empty();
  }
  return false;
}

SceneSpectra::SceneSpectra(const Scene& scene) {
  for (const Material& m : scene.materials) albedo.push_back(RgbSpectrum::reflectance(m.color));
  for (const Medium& m : scene.media) media.emplace_back(m);
  for (const Light& l : scene.light_set().lights()) {
    if (l.lines.empty()) {
      light.push_back(RgbSpectrum::illuminant(l.emit));
    } else {  // luminance from emit = the lines' unit-luminance RGB x luminance
      const RGB unit = spectral_lines_rgb(l.lines, l.line_fwhm);
      const float m = unit.max_component();
      light.push_back(RgbSpectrum::lines(l.lines, l.line_fwhm, m > 0 ? l.emit.max_component() / m : 0.0f));
    }
  }
}

BsdfParams monochromatic(const Material& m, const RgbSpectrum& albedo, Vec2 uv, float lambda) {
  return SpectralSurface(m, uv, &albedo).at(lambda);
}

void SpectraAtWavelengths::evaluate(const Scene& scene, const SceneSpectra& spectra, const SampledWavelengths& wl) {
  count_ = wl.count;
  scene_ = &scene;
  spectra_ = &spectra;
  wl_ = wl;
  bsdf_.resize(scene.materials.size() * count_);
  per_point_.resize(scene.materials.size());
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    per_point_[m] = scene.materials[m].has_bsdf_textures();
    if (per_point_[m]) continue;  // made per point (material())
    const SpectralSurface surface(scene.materials[m], Vec2(), &spectra.albedo[m]);
    for (int k = 0; k < count_; ++k) bsdf_[m * count_ + k] = surface.at(wl.lambda[k]);
  }
  light_.resize(spectra.light.size() * count_);
  for (size_t l = 0; l < spectra.light.size(); ++l)
    for (int k = 0; k < count_; ++k) light_[l * count_ + k] = spectra.light[l](wl.lambda[k]);
}

const BsdfParams* SpectraAtWavelengths::material(const SurfaceHit& hit, WavelengthParams& local) const {
  if (!per_point_[static_cast<size_t>(hit.material)]) return &bsdf_[static_cast<size_t>(hit.material) * count_];
  return at_point(hit.material, scene_->shading_context(hit), local);
}

const BsdfParams* SpectraAtWavelengths::at_point(int m, const shading::ShadingContext& ctx, WavelengthParams& local,
                                                  BsdfParams* rgb) const {
  const SpectralSurface surface(scene_->materials[static_cast<size_t>(m)], ctx, &spectra_->albedo[static_cast<size_t>(m)]);
  BsdfParams* params = local.make();
  for (int k = 0; k < count_; ++k) params[k] = surface.at(wl_.lambda[k]);
  if (rgb) *rgb = surface.rgb();
  return params;
}

float grey_factor(const RGB& value, const RGB& emit) {
  const float m = emit.max_component();
  if (m <= 0) return 0.0f;
  const int c = emit.r == m ? 0 : (emit.g == m ? 1 : 2);
  return value[c] / emit[c];
}

float light_scale(const LightSample& ls, const Light& l) { return grey_factor(ls.L, l.emit); }

RgbSpectrum light_spectrum(const SceneSpectra& spectra, const LightSet& lights, int l, const RGB& value) {
  if (varies_with_direction(lights, l)) return RgbSpectrum::illuminant_interpolated(value);
  const RGB& emit = lights.lights()[l].emit;
  const float m = emit.max_component();
  if (m <= 0) return spectra.light[l].scaled(0.0f);
  const int c = emit.r == m ? 0 : (emit.g == m ? 1 : 2);
  return spectra.light[l].scaled(std::max(0.0f, value[c] / emit[c]));
}

void SpectraAtWavelengths::emitted(int l, const RGB& value, float* out) const {
  const LightSet& lights = scene_->light_set();
  if (varies_with_direction(lights, l)) {
    const RgbSpectrum s = RgbSpectrum::illuminant_interpolated(value);
    for (int k = 0; k < count_; ++k) out[k] = s(wl_.lambda[k]);
    return;
  }
  const float grey = grey_factor(value, lights.lights()[l].emit);
  for (int k = 0; k < count_; ++k) out[k] = grey * light(l)[k];
}

}  // namespace gp
