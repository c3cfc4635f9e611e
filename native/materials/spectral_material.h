// A material seen by one wavelength, for the spectral methods (spt, spt-hero, sgpt, spectral
// SPPM): the RGB BSDF's parameters at a surface point (bsdf_params: textures looked up at uv)
// with the colour replaced by a grey, the value at lambda of the colour's reflectance spectrum
// (Jakob–Hanika upsampling, core/spectrum.h), and a dispersive IOR by Cauchy's equation at
// lambda. The RGB Bsdf then evaluates it unchanged; a mix carries lambda to its components,
// which are seen the same way at the same point (Bsdf::component).
//
// Which spectrum: a constant colour's is fitted once per scene by the integrator
// (SceneSpectra, exact); a textured colour's (the texel at uv) and a mix component's come from
// RgbSpectrum::reflectance_interpolated, per point.
#pragma once

#include "core/spectrum.h"
#include "materials/bsdf.h"
#include "materials/material.h"

namespace gp {

// True when the material's scattering depends on the wavelength through its IOR (a dielectric
// with a non-zero Cauchy B).
inline bool is_dispersive(const Material& m) {
  return m.type == MaterialType::Dielectric && m.cauchy_b != 0.0f;
}

// Material m's RGB parameters `rgb` at a point seen at wavelength lambda (nm): the colour
// replaced by `color`'s value at lambda (a grey), a dispersive IOR by Cauchy's equation.
BsdfParams at_wavelength(const Material& m, const BsdfParams& rgb, const RgbSpectrum& color, float lambda);

// Material m at texture coordinate uv, ready to be read at any wavelength: its textures are
// looked up and its colour upsampled once, however many wavelengths a path carries.
class SpectralSurface {
 public:
  // `constant`: the spectrum of m's constant colour (used unless a texture drives the colour);
  // null: upsample that colour here too (a mix's component).
  SpectralSurface(const Material& m, Vec2 uv, const RgbSpectrum* constant)
      : SpectralSurface(m, shading::ShadingContext::at_uv(uv), constant) {}
  SpectralSurface(const Material& m, const shading::ShadingContext& ctx, const RgbSpectrum* constant);
  SpectralSurface(const SpectralSurface&) = delete;  // color_ may point into itself
  SpectralSurface& operator=(const SpectralSurface&) = delete;
  // m's parameters at wavelength lambda (nm).
  BsdfParams at(float lambda) const;
  // Its RGB parameters at the point (a mix's components with their spectra).
  const BsdfParams& rgb() const { return rgb_; }

 private:
  const Material& m_;
  BsdfParams rgb_;  // the parameters at uv, RGB colour
  RgbSpectrum upsampled_;          // the colour's spectrum when it is not `constant`
  const RgbSpectrum* color_ = &upsampled_;
};

}  // namespace gp
