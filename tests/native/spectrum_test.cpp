// Spectral core: CMF fit sanity, white point, RGB -> spectrum -> RGB round trips, hero
// wavelength sets, and the Monte Carlo conversion of wavelength samples to RGB.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <vector>

#include "core/rng.h"
#include "core/spectrum.h"
#include "core/spectrum_table.h"

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


// Texels and mix components are upsampled through Jakob & Hanika's table (interpolated fit
// coefficients): the spectrum must round-trip to the colour nearly as well as the fit itself,
// stay a bounded reflectance, and be the fit's spectrum up to the interpolation.
TEST(Spectrum, InterpolatedReflectanceRoundTripsLikeTheFit) {
  Rng rng(7, 0);
  double worst_rgb = 0, worst_fit = 0, sum_rgb = 0;
  constexpr int kColours = 60;
  for (int n = 0; n < kColours; ++n) {
    const RGB c(rng.uniform(), rng.uniform(), rng.uniform());
    const RgbSpectrum s = RgbSpectrum::reflectance_interpolated(c);
    const RgbSpectrum fit = RgbSpectrum::reflectance(c);
    const RGB back = s.to_rgb(), back_fit = fit.to_rgb();
    for (int k = 0; k < 3; ++k) {
      // What the fit itself misses (saturated colours lie outside the sigmoid's reach) is not
      // the table's error: compare with the fit's own round trip.
      const double e = std::abs(back[k] - back_fit[k]);
      worst_rgb = std::max(worst_rgb, e);
      sum_rgb += e;
    }
    for (float l = kLambdaMin; l <= kLambdaMax; l += 5.0f) {
      ASSERT_GE(s(l), 0.0f);
      ASSERT_LE(s(l), 1.0f);
      if (l < 420 || l > 680) continue;  // the tails: CMFs near 0, shape free
      worst_fit = std::max(worst_fit, static_cast<double>(std::abs(s(l) - fit(l))));
    }
  }
  std::printf("interpolated vs fitted reflectance: RGB worst %.5f mean %.5f, spectrum worst %.4f\n", worst_rgb,
              sum_rgb / (3 * kColours), worst_fit);
  // Measured (24^3 table): RGB worst 0.0055 (an 8-bit texel's step is 0.004), mean 0.0007;
  // spectrum worst 0.024 over 420-680 nm. Bounds about twice that.
  EXPECT_LT(worst_rgb, 0.01);
  EXPECT_LT(sum_rgb / (3 * kColours), 0.0015);
  EXPECT_LT(worst_fit, 0.05);
  // Greys are the exact constants reflectance() gives.
  EXPECT_TRUE(RgbSpectrum::reflectance_interpolated(RGB(0.3f)).is_constant());
  EXPECT_EQ(RgbSpectrum::reflectance_interpolated(RGB(0.3f))(500.0f), 0.3f);
  EXPECT_EQ(RgbSpectrum::reflectance_interpolated(RGB(0.0f, 0.0f, 0.0f))(500.0f), 0.0f);
}

// The table is fitted at build time (native/tools/make_spectrum_table.cpp) and compiled in: the
// stored copy must be the core's own fit bit for bit (images unchanged), refitted here at
// sampled slices (6 of 72: about 1/12 of the fit), and a colour on a table node must read that
// node (its spectrum integrates back to the colour to the fit's tolerance).
TEST(Spectrum, StoredCoefficientTableIsTheFit) {
  namespace tb = spectrum_table;
  const std::array<float, tb::kRes> z = tb::fit_z_grid();
  for (int k = 0; k < tb::kRes; ++k) EXPECT_EQ(std::bit_cast<std::uint32_t>(tb::kZ[k]), std::bit_cast<std::uint32_t>(z[k])) << k;
  std::vector<float> fresh(tb::kSize, 0.0f);
  const int slices[][2] = {{0, 0}, {0, 23}, {1, 7}, {1, 16}, {2, 3}, {2, 20}};  // (l, j)
  int differ = 0;
  for (const auto& lj : slices) {
    const int l = lj[0], j = lj[1];
    tb::fit_coefficient_slice(l, j, fresh.data());
    for (int k = 1; k < tb::kRes; ++k)
      for (int i = 0; i < tb::kRes; ++i)
        for (int d = 0; d < 3; ++d) {
          const std::size_t e = tb::index(l, k, j, i) + d;
          if (std::bit_cast<std::uint32_t>(tb::kCoefficients[e]) != std::bit_cast<std::uint32_t>(fresh[e]) && ++differ <= 5)
            ADD_FAILURE() << "entry (l " << l << ", k " << k << ", j " << j << ", i " << i << ", c" << d
                          << "): stored " << tb::kCoefficients[e] << ", fitted " << fresh[e];
        }
  }
  EXPECT_EQ(differ, 0);
  // Node (l 1 = green largest, k 16, j 8, i 12): RGB (8/23 z, z, 12/23 z), z = kZ[16].
  const float zn = tb::kZ[16];
  const RGB node(8.0f / 23.0f * zn, zn, 12.0f / 23.0f * zn);
  const RGB back = RgbSpectrum::reflectance_interpolated(node).to_rgb();
  // Measured 3.6e-7 (the fit's 1e-6 tolerance); off the nodes the table is within 0.0055.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(back[c], node[c], 1e-5) << c;
}

}  // namespace
}  // namespace gp
