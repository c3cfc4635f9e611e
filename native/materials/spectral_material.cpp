#include "materials/spectral_material.h"

namespace gp {

SpectralSurface::SpectralSurface(const Material& m, const shading::ShadingContext& ctx, const RgbSpectrum* constant)
    : m_(m), rgb_(bsdf_params(m, ctx, /*spectral=*/true)) {
  if (constant && !m.color_tex && !m.color_in) color_ = constant;
  else upsampled_ = RgbSpectrum::reflectance_interpolated(rgb_.color);
}

BsdfParams at_wavelength(const Material& m, const BsdfParams& rgb, const RgbSpectrum& color, float lambda) {
  BsdfParams p = rgb;
  p.color = RGB(color(lambda));
  if (is_dispersive(m)) p.ior = cauchy_ior(m.ior, m.cauchy_b, lambda);
  p.lambda = lambda;
  return p;
}

BsdfParams SpectralSurface::at(float lambda) const { return at_wavelength(m_, rgb_, *color_, lambda); }

}  // namespace gp
