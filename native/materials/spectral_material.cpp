#include "materials/spectral_material.h"

namespace gp {

SpectralSurface::SpectralSurface(const Material& m, const shading::ShadingContext& ctx, const RgbSpectrum* constant)
    : m_(m), rgb_(bsdf_params(m, ctx)) {
  if (constant && !m.color_tex && !m.color_in) color_ = constant;
  else upsampled_ = RgbSpectrum::reflectance_interpolated(rgb_.color);
}

BsdfParams SpectralSurface::at(float lambda) const {
  BsdfParams p = rgb_;
  p.color = RGB((*color_)(lambda));
  if (is_dispersive(m_)) p.ior = cauchy_ior(m_.ior, m_.cauchy_b, lambda);
  p.lambda = lambda;
  return p;
}

}  // namespace gp
