#include "materials/spectral_material.h"

namespace gp {

SpectralSurface::SpectralSurface(const Material& m, Vec2 uv, const RgbSpectrum* constant)
    : m_(m), rgb_(bsdf_params(m, uv)) {
  if (constant && !m.color_tex) color_ = constant;
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
