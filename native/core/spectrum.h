// Spectral core (DESIGN.md "Units": spectral mode 360–830 nm through CIE 1931 XYZ): the
// wavelength domain, hero-wavelength sets, the colour matching functions, XYZ -> scene-linear
// Rec.709, and RGB -> smooth spectrum upsampling for reflectances and illuminants.
//
// Choices (docs/spectral.md has the reasoning and numbers):
//  - CMFs: the multi-lobe piecewise-Gaussian fit of Wyman, Sloan & Shirley 2013 ("Simple
//    Analytic Approximations to the CIE XYZ Color Matching Functions", JCGT 2(2)), instead of
//    the tabulated CIE data: no large table, error well below the noise of a render.
//  - Upsampling: Jakob & Hanika 2019 ("A Low-Dimensional Function Space for Efficient Spectral
//    Upsampling"), s(lambda) = sigmoid(c0 t^2 + c1 t + c2). Constant colours of materials and
//    lights are fitted here, once per colour, by the same Gauss–Newton optimisation with
//    continuation from grey that produces their table; colours met per hit (image textures,
//    mix components) read the coefficients off their 3D table, fitted by the same code at build
//    time and compiled in (core/spectrum_table.h).
//    Greys (white included) are exact constants.
//  - White point: the spectral pipeline is normalised so that the constant spectrum 1 maps to
//    RGB (1, 1, 1) (Bradford adaptation of the fit's equal-energy white to D65, then the
//    Rec.709 matrix). Reflectances and illuminants are both fitted in that space, so a white
//    light on a white wall renders white in both modes and no D65 table is needed.
//  - Wavelength sampling: uniform hero wavelength plus C - 1 equally spaced rotations (Wilkie
//    et al. 2014); every member of the set is then marginally uniform, so the hero MIS weights
//    (spectral gradient sampling eq. 3-4) reduce to ratios of path pdfs.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/math.h"

namespace gp {

inline constexpr float kLambdaMin = 360.0f;  // nm
inline constexpr float kLambdaMax = 830.0f;  // nm
inline constexpr float kLambdaRange = kLambdaMax - kLambdaMin;
inline constexpr int kMaxWavelengths = 8;    // most wavelengths one path may carry

// Values at the wavelengths of a SampledWavelengths (only the first `count` are meaningful).
using SpectralValues = std::array<float, kMaxWavelengths>;

// Wraps a wavelength into [kLambdaMin, kLambdaMax) (the spectrum is treated as cyclic, as in
// spectral gradient sampling §4).
float wrap_wavelength(float lambda);

// A hero wavelength and count - 1 rotations, equally spaced over the domain (WND*14).
struct SampledWavelengths {
  int count = 1;
  std::array<float, kMaxWavelengths> lambda{};
  // u in [0, 1) places the hero uniformly; count in [1, kMaxWavelengths].
  static SampledWavelengths sample_uniform(float u, int count);
  // Marginal density of each member (uniform over the domain).
  static constexpr float pdf() { return 1.0f / kLambdaRange; }
};

// CIE 1931 2-degree colour matching functions (x-bar, y-bar, z-bar) at lambda (nm), from the
// Wyman–Sloan–Shirley 2013 multi-lobe fit.
Vec3 cie_xyz_bar(float lambda);
// Integral of y-bar over [kLambdaMin, kLambdaMax] (nm), for normalising XYZ so Y(1) = 1.
float cie_y_integral();

// XYZ (normalised so the constant spectrum 1 has Y = 1) to scene-linear Rec.709, adapted so the
// constant spectrum 1 maps to RGB (1, 1, 1).
RGB xyz_to_rgb(const Vec3& xyz);
// The Rec.709 colour (D65 white, not adapted) of a black body at T kelvin (clamped to 800 K,
// where Cycles' fit stops too) normalised to luminance 1: Planck's law through the CIE 1931
// observer, as Cycles 3.4's svm_math_blackbody_color_rec709 (a fitted table of the same curve).
// The Blackbody node and the volumes' blackbody emission both read it.
RGB blackbody_rec709(float T);
// XYZ (Y-normalised) of the spectrum s integrated over the domain (5 nm trapezoid), as RGB.
template <typename F>
RGB spectrum_to_rgb(F&& s);

// One Monte Carlo sample of spectral radiance L at the wavelengths `wl` to an RGB estimate:
// the average over the set of L(lambda_j) cmf(lambda_j) / pdf(lambda_j), normalised and converted.
RGB sample_to_rgb(const SpectralValues& L, const SampledWavelengths& wl);

// One emission line of a line spectrum: centre (nm) and relative weight (its integral).
struct SpectralLine {
  float nm = 0, weight = 0;
};
inline constexpr int kMaxSpectralLines = 8;
// Named line spectra (scene format "spectrum": "<name>"): "sodium" (low-pressure sodium, the D
// lines 589.0 / 589.6 nm, 2:1) and "mercury" (404.7, 435.8, 546.1, 577.0, 579.1 nm). nullopt
// for an unknown name.
std::optional<std::vector<SpectralLine>> spectral_line_preset(const std::string& name);
// XYZ (Y-normalised as xyz_to_rgb expects) of Gaussian lines of full width at half maximum
// `fwhm` nm, integrated finely around each line (a 5 nm quadrature would miss them).
Vec3 spectral_lines_xyz(const std::vector<SpectralLine>& lines, float fwhm);
// RGB of those lines at luminance 1, negative components (outside the Rec.709 gamut, e.g. the
// blue of sodium) clipped to 0: the colour an RGB render and the light's power use.
RGB spectral_lines_rgb(const std::vector<SpectralLine>& lines, float fwhm);

// Smooth spectrum from an RGB colour: Jakob–Hanika sigmoid polynomial, optionally scaled; or a
// line spectrum (emission only: Gaussian lines, the spiky-illuminant case of spectral gradient
// sampling §4).
class RgbSpectrum {
 public:
  RgbSpectrum() = default;
  // Bounded spectrum in [0, 1] for a reflectance (components clamped to [0, 1]).
  static RgbSpectrum reflectance(const RGB& rgb);
  // The same upsampling for colours met per hit (a texel, a mix component's colour): the fit's
  // coefficients interpolated in Jakob & Hanika's table (§4) instead of a fit (~1 ms); greys
  // exact. The table (3 x 24^3 entries of 3 coefficients) is fitted at build time and compiled
  // in (core/spectrum_table.h): nothing to load, no fit in the process.
  static RgbSpectrum reflectance_interpolated(const RGB& rgb);
  // Unbounded spectrum for emission: scale * reflectance(rgb / scale) with scale = max(rgb).
  static RgbSpectrum illuminant(const RGB& rgb);
  // The same from the interpolated table (reflectance_interpolated): for emission met per hit
  // (an environment map's texel), where a fit per value would cost a millisecond.
  static RgbSpectrum illuminant_interpolated(const RGB& rgb);
  // This spectrum times f (f >= 0).
  RgbSpectrum scaled(float f) const {
    RgbSpectrum s = *this;
    s.scale_ *= f;
    return s;
  }
  // Gaussian lines of one FWHM (nm), scaled so that the spectrum has luminance Y = scale (Y of
  // the constant spectrum 1 is 1). At most kMaxSpectralLines lines.
  static RgbSpectrum lines(const std::vector<SpectralLine>& lines, float fwhm, float scale);

  float operator()(float lambda) const;
  // The RGB the spectrum integrates to (what the fit was aiming at), for tests and reports.
  RGB to_rgb() const;
  bool is_constant() const { return constant_; }

 private:
  bool constant_ = true;
  float value_ = 0;               // the constant (grey) value, before scale
  float c0_ = 0, c1_ = 0, c2_ = 0;  // polynomial in t = (lambda - kLambdaMin) / kLambdaRange
  float scale_ = 1;
  int n_lines_ = 0;  // > 0: a line spectrum (the sigmoid fields are unused)
  std::array<float, kMaxSpectralLines> line_nm_{}, line_peak_{};
  float line_inv_2sigma2_ = 0;
};

// Cauchy's equation n(lambda) = A + B / lambda^2 with lambda in micrometres (spectral gradient
// sampling §4, [JW01]).
inline float cauchy_ior(float a, float b_um2, float lambda_nm) {
  const float l_um = lambda_nm * 1e-3f;
  return a + b_um2 / (l_um * l_um);
}

// ---- template definition ----
template <typename F>
RGB spectrum_to_rgb(F&& s) {
  constexpr int kSteps = 94;  // 5 nm
  Vec3 xyz(0, 0, 0);
  for (int i = 0; i <= kSteps; ++i) {
    const float lambda = kLambdaMin + kLambdaRange * i / kSteps;
    const float w = (i == 0 || i == kSteps) ? 0.5f : 1.0f;
    xyz = xyz + cie_xyz_bar(lambda) * (w * s(lambda));
  }
  return xyz_to_rgb(xyz * (kLambdaRange / kSteps / cie_y_integral()));
}

}  // namespace gp
