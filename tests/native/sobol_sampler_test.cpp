// The Sobol pattern of the camera-path loop (core/sobol.h, core/sampler.h SobolSampler): its
// points are stratified for every power-of-two prefix of a pixel's samples, in the dimensions
// the loop uses; its estimates are unbiased over seeds and converge faster than independent
// sampling; different pixels and different seeds are decorrelated; pt with it agrees with pt
// with independent numbers, and renders at lower error per sample.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/rng.h"
#include "core/sampler.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// The 2D dimensions the loop uses at its first vertices (film, lens, light point, BSDF
// direction, a deeper vertex's) and its 1D ones (time, light pick, lobe pick, roulette).
const int k2d[] = {kDimFilter, kDimLens, path_dim(0, kDimLight2), path_dim(0, kDimScatter2),
                   path_dim(5, kDimScatter2), path_dim(1, kDimEquiangularLight2)};
const int k1d[] = {kDimTime, kDimWavelength, path_dim(0, kDimLight), path_dim(0, kDimLobe),
                   path_dim(2, kDimRoulette), path_dim(3, kDimMediumDistance)};

SobolSampler sampler(uint64_t seed, uint64_t pixel, uint64_t index) {
  return SobolSampler(seed, pixel, index, Rng::for_key(seed, pixel, index));
}

// Points first..first+n-1 of dimension `dim` of one pixel form a (0,m,2)-net (n = 2^m): every
// elementary interval of 2^a x 2^(m-a) cells holds exactly one point.
bool is_net(uint64_t seed, uint64_t pixel, int dim, int first, int m) {
  const int n = 1 << m;
  std::vector<Vec2> p;
  for (int i = 0; i < n; ++i) p.push_back(sampler(seed, pixel, first + i).get2d(dim));
  for (int a = 0; a <= m; ++a) {
    std::vector<int> count(n, 0);
    for (const Vec2& q : p) {
      const int cx = static_cast<int>(q.x * (1 << a)), cy = static_cast<int>(q.y * (1 << (m - a)));
      ++count[cx * (1 << (m - a)) + cy];
    }
    for (int c : count)
      if (c != 1) return false;
  }
  return true;
}

// sobol_owen works on bit-reversed indices and values (no reversals around the scrambles): the
// same numbers as Burley's nested_uniform_scramble of the shuffled index and of the point, with
// the Sobol point computed directly (dimension 0: van der Corput; 1: v_k = v_{k-1} ^ v_{k-1} >> 1).
uint32_t sobol_direct(uint32_t i, int d) {
  uint32_t v = 0, c = 1u << 31;
  for (int k = 0; k < 32; ++k, c = d == 0 ? c >> 1 : c ^ (c >> 1))
    if (i & (1u << k)) v ^= c;
  return v;
}
TEST(SobolSampler, ReversedDomainEqualsNestedUniformScrambling) {
  Rng r(3, 4);
  for (int n = 0; n < 20000; ++n) {
    const uint32_t i = n < 1000 ? n : r.next_u32(), s0 = r.next_u32(), s1 = r.next_u32();
    const uint32_t shuffled = nested_uniform_scramble(i, s0);
    for (int d = 0; d < kSobolDimensions; ++d)
      ASSERT_EQ(sobol_owen(laine_karras_permutation(reverse_bits(i), s0), d, s1),
                nested_uniform_scramble(sobol_direct(shuffled, d), s1)) << i << " " << d;
  }
}

TEST(SobolSampler, EveryPowerOfTwoPrefixIsStratifiedIn2D) {
  for (uint64_t pixel : {0ull, 1ull, 12345ull})
    for (int dim : k2d)
      for (int m = 0; m <= 10; ++m) EXPECT_TRUE(is_net(7, pixel, dim, 0, m)) << "pixel " << pixel << " dim " << dim << " 2^" << m;
}

TEST(SobolSampler, AlignedBlocksOfSamplesAreStratifiedToo) {
  // Passes 64..127 of a pixel (the progressive render's second block of 64) are a net as well.
  for (int dim : k2d) EXPECT_TRUE(is_net(3, 99, dim, 64, 6)) << dim;
  for (int dim : k2d) EXPECT_TRUE(is_net(3, 99, dim, 1024, 8)) << dim;
}

TEST(SobolSampler, EveryPowerOfTwoPrefixIsStratifiedIn1D) {
  for (int dim : k1d)
    for (int m = 0; m <= 12; ++m) {
      const int n = 1 << m;
      std::vector<int> count(n, 0);
      for (int i = 0; i < n; ++i) ++count[static_cast<int>(sampler(5, 42, i).get1d(dim) * n)];
      for (int c : count) ASSERT_EQ(c, 1) << "dim " << dim << " 2^" << m;
    }
}

TEST(SobolSampler, PointsLieInTheUnitSquare) {
  for (int i = 0; i < 4096; ++i) {
    SobolSampler s = sampler(11, 3, i);
    for (int d = 0; d < SobolSampler::kSobolDims + 20; ++d) {
      const Vec2 u = s.get2d(d);
      const float v = s.get1d(d);
      ASSERT_TRUE(u.x >= 0 && u.x < 1 && u.y >= 0 && u.y < 1 && v >= 0 && v < 1) << i << " " << d;
    }
  }
}

// A smooth integrand on the unit square and its integral.
double f(Vec2 u) { return std::exp(u.x) * std::sin(kPi * u.y) + u.x * u.y; }
const double kExact = (std::exp(1.0) - 1.0) * 2.0 / kPi + 0.25;

// The n-sample estimate of pixel `pixel` (seed `seed`) in dimension `dim`.
double estimate(uint64_t seed, uint64_t pixel, int dim, int n) {
  double s = 0;
  for (int i = 0; i < n; ++i) s += f(sampler(seed, pixel, i).get2d(dim));
  return s / n;
}
double estimate_independent(uint64_t seed, uint64_t pixel, int n) {
  double s = 0;
  for (int i = 0; i < n; ++i) {
    Rng r = Rng::for_key(seed, pixel, i);
    const float x = r.uniform();
    s += f(Vec2(x, r.uniform()));
  }
  return s / n;
}

struct Moments {
  double mean, rmse, sd;
};
template <class E>
Moments over_pixels(int pixels, E e) {
  double s = 0, s2 = 0, e2 = 0;
  for (int p = 0; p < pixels; ++p) {
    const double v = e(p);
    s += v;
    s2 += v * v;
    e2 += (v - kExact) * (v - kExact);
  }
  const double mean = s / pixels;
  return {mean, std::sqrt(e2 / pixels), std::sqrt(std::max(0.0, s2 / pixels - mean * mean))};
}

TEST(SobolSampler, ScrambledEstimatesAreUnbiased) {
  // 4000 pixels' 4-sample estimates (and 1- and 3-sample ones: prefixes that are no power of
  // two): their mean within 4 standard errors of the integral.
  for (int dim : {int(kDimFilter), path_dim(0, kDimScatter2), path_dim(4, kDimLight2)})
    for (int n : {1, 3, 4, 32}) {
      const int pixels = 4000;
      const Moments m = over_pixels(pixels, [&](int p) { return estimate(17, p, dim, n); });
      EXPECT_NEAR(m.mean, kExact, 4 * m.sd / std::sqrt(pixels) + 1e-7) << "dim " << dim << " n " << n;
    }
}

TEST(SobolSampler, ConvergesFasterThanIndependentSamples) {
  // Owen-scrambled nets of a smooth integrand: RMSE ~ n^-1.5 (Owen 1997); independent: n^-0.5.
  // Asserted: a slope below -1.1 from 16 to 1024 samples (headroom 0.4 to the theory) and an
  // RMSE at 1024 samples under a tenth of the independent one (theory: about 1/32).
  const int pixels = 200;
  const Moments s16 = over_pixels(pixels, [](int p) { return estimate(2, p, kDimLens, 16); });
  const Moments s1024 = over_pixels(pixels, [](int p) { return estimate(2, p, kDimLens, 1024); });
  const Moments i16 = over_pixels(pixels, [](int p) { return estimate_independent(2, p, 16); });
  const Moments i1024 = over_pixels(pixels, [](int p) { return estimate_independent(2, p, 1024); });
  const double slope = std::log(s1024.rmse / s16.rmse) / std::log(64.0);
  const double slope_independent = std::log(i1024.rmse / i16.rmse) / std::log(64.0);
  EXPECT_LT(slope, -1.1);
  EXPECT_NEAR(slope_independent, -0.5, 0.15);
  EXPECT_LT(s1024.rmse, 0.1 * i1024.rmse);
}

double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) ma += a[i] / n, mb += b[i] / n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

TEST(SobolSampler, PixelsSeedsAndDimensionsAreDecorrelated) {
  // 3000 trials of two 8-sample estimates each: neighbouring pixels (same seed), the same pixel
  // with consecutive seeds, and two dimensions of one pixel. Independent estimates have a
  // sample correlation of sd 1/sqrt(3000) = 0.018: asserted below 0.08 (4.4 sd).
  const int trials = 3000, n = 8;
  std::vector<double> a, b, c, d, e, g;
  for (int t = 0; t < trials; ++t) {
    a.push_back(estimate(t, 1000, kDimFilter, n));
    b.push_back(estimate(t, 1001, kDimFilter, n));
    c.push_back(estimate(2 * t, 7, kDimFilter, n));
    d.push_back(estimate(2 * t + 1, 7, kDimFilter, n));
    e.push_back(estimate(9, t, path_dim(0, kDimLight2), n));
    g.push_back(estimate(9, t, path_dim(0, kDimScatter2), n));
  }
  EXPECT_LT(std::abs(correlation(a, b)), 0.08) << "pixels";
  EXPECT_LT(std::abs(correlation(c, d)), 0.08) << "seeds";
  EXPECT_LT(std::abs(correlation(e, g)), 0.08) << "dimensions";
}

TEST(SobolSampler, DeepDimensionsFallBackToThePixelsStream) {
  SobolSampler s = sampler(1, 2, 3);
  Rng r = Rng::for_key(1, 2, 3);
  EXPECT_EQ(s.get1d(SobolSampler::kSobolDims), r.uniform());
}

// pt renders the Cornell box to the same mean with either pattern (8 seeds of 32 passes each:
// a z-test on the seeds' spread, |z| < 4), and the Sobol pattern's per-pixel squared error
// against a long reference (1024 passes) is lower at equal samples (asserted below 0.9x; the
// reference's own noise counts in both).
TEST(SobolSampler, PathTracerAgreesWithIndependentSamplingAndHasLessError) {
  const Scene scene = cornell_box(24, 24);
  auto run = [&](const char* pattern, int passes, uint64_t seed) {
    Params p;
    p.set("sampling_pattern", std::string(pattern));
    p.set("seed", seed);
    return render("pt", scene, passes, p);
  };
  const Film reference = run("independent", 1024, 100);
  auto mse = [&](const Film& f) {
    double s = 0;
    for (int y = 0; y < f.height(); ++y)
      for (int x = 0; x < f.width(); ++x)
        for (int k = 0; k < 3; ++k) {
          const double dv = f.rgb(pass::kCombined, x, y)[k] - reference.rgb(pass::kCombined, x, y)[k];
          s += dv * dv;
        }
    return s;
  };
  const int seeds = 8;
  double mean[2] = {0, 0}, sq[2] = {0, 0}, err[2] = {0, 0};
  for (int seed = 1; seed <= seeds; ++seed)
    for (int k = 0; k < 2; ++k) {
      const Film f = run(k ? "sobol" : "independent", 32, seed);
      const RGB m = image_mean(f);
      const double v = m.r + m.g + m.b;
      mean[k] += v / seeds;
      sq[k] += v * v / seeds;
      err[k] += mse(f) / seeds;
    }
  const double var = (sq[0] - mean[0] * mean[0] + sq[1] - mean[1] * mean[1]) / (seeds - 1);
  EXPECT_LT(std::abs(mean[1] - mean[0]), 4 * std::sqrt(var)) << mean[1] << " " << mean[0];
  EXPECT_LT(err[1], 0.9 * err[0]);
}

}  // namespace
}  // namespace gp
