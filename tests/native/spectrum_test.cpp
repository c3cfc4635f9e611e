// Spectral core: CMF fit sanity, white point, RGB -> spectrum -> RGB round trips, hero
// wavelength sets, and the Monte Carlo conversion of wavelength samples to RGB.
#include <gtest/gtest.h>

#include "core/rng.h"
#include "core/spectrum.h"

namespace gp {
namespace {

TEST(Spectrum, CmfFitHasKnownPeaks) {
  // CIE 1931: y-bar peaks at 555 nm with value 1.0; x-bar ~1.06 near 600 nm; z-bar ~1.78 near 445.
  EXPECT_NEAR(cie_xyz_bar(555).y, 1.0, 0.02);
  EXPECT_NEAR(cie_xyz_bar(600).x, 1.06, 0.03);
  EXPECT_NEAR(cie_xyz_bar(445).z, 1.78, 0.05);
  EXPECT_NEAR(cie_y_integral(), 106.9, 1.5);  // the tabulated y-bar integrates to ~106.86 nm
}

TEST(Spectrum, ConstantOneIsWhite) {
  const RGB w = spectrum_to_rgb([](float) { return 1.0f; });
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(w[c], 1.0, 1e-4) << c;
}

TEST(Spectrum, UpsampledWhiteIsOneEverywhere) {
  const RgbSpectrum s = RgbSpectrum::reflectance(RGB(1.0f));
  const RgbSpectrum e = RgbSpectrum::illuminant(RGB(3.0f));
  for (float l = kLambdaMin; l <= kLambdaMax; l += 1.0f) {
    EXPECT_EQ(s(l), 1.0f) << l;
    EXPECT_EQ(e(l), 3.0f) << l;
  }
}

TEST(Spectrum, ReflectanceRoundTripsAndStaysBounded) {
  const RGB colours[] = {{0.63f, 0.065f, 0.05f}, {0.14f, 0.45f, 0.091f}, {0.2f, 0.3f, 0.9f},
                         {0.9f, 0.8f, 0.1f},      {0.5f, 0.5f, 0.4f}};
  for (const RGB& c : colours) {
    const RgbSpectrum s = RgbSpectrum::reflectance(c);
    const RGB back = s.to_rgb();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], c[k], 2e-3) << c.r << " " << c.g << " " << c.b;
    for (float l = kLambdaMin; l <= kLambdaMax; l += 5.0f) {
      EXPECT_GE(s(l), 0.0f);
      EXPECT_LE(s(l), 1.0f);
    }
  }
}

TEST(Spectrum, IlluminantRoundTrips) {
  const RGB c(12.0f, 10.2f, 7.2f);  // cornell-box's light
  const RGB back = RgbSpectrum::illuminant(c).to_rgb();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], c[k], 1e-2 * c[k]);
}

TEST(Spectrum, HeroWavelengthsAreEquallySpacedAndWrapped) {
  const SampledWavelengths wl = SampledWavelengths::sample_uniform(0.9f, 4);
  ASSERT_EQ(wl.count, 4);
  EXPECT_NEAR(wl.lambda[0], kLambdaMin + 0.9f * kLambdaRange, 1e-3);
  for (int j = 0; j < 4; ++j) {
    EXPECT_GE(wl.lambda[j], kLambdaMin);
    EXPECT_LT(wl.lambda[j], kLambdaMax);
    const float d = wrap_wavelength(wl.lambda[j] - wl.lambda[0] + kLambdaMin) - kLambdaMin;
    EXPECT_NEAR(d, j * kLambdaRange / 4, 1e-2);
  }
}

TEST(Spectrum, MonteCarloConversionIsUnbiased) {
  // Averaging sample_to_rgb over random hero sets converges to the quadrature.
  const RgbSpectrum s = RgbSpectrum::reflectance(RGB(0.63f, 0.065f, 0.05f));
  const RGB want = s.to_rgb();
  Rng rng(7, 0);
  double sum[3] = {0, 0, 0};
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const SampledWavelengths wl = SampledWavelengths::sample_uniform(rng.uniform(), 4);
    SpectralValues L{};
    for (int j = 0; j < wl.count; ++j) L[j] = s(wl.lambda[j]);
    const RGB c = sample_to_rgb(L, wl);
    for (int k = 0; k < 3; ++k) sum[k] += c[k];
  }
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(sum[k] / n, want[k], 0.005) << k;
}

TEST(Spectrum, CauchyIor) {
  EXPECT_FLOAT_EQ(cauchy_ior(1.5f, 0.0f, 500.0f), 1.5f);
  EXPECT_NEAR(cauchy_ior(1.5f, 0.01f, 500.0f), 1.54f, 1e-5);  // 0.01 / 0.25
}

}  // namespace
}  // namespace gp
