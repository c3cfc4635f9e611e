// Equiangular sampling in homogeneous media (media/medium.h Equiangular, paths/camera_path.h):
// the sampler against its density (chi-square, bounded and unbounded rays), the shaft of a point
// light in a homogeneous slab against the analytic single-scattering integral for pt, spt and
// spt-hero, and Light Paths > Volume bounces (the scene's volume_bounces) read by the camera path.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "chi2.h"
#include "core/rng.h"
#include "media/medium.h"
#include "integrators/integrator.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// Pearson's chi-square of n distances of `eq` in kBins cells of equal width over [0, t_hi)
// (t_hi < t_max: the tail beyond is one more cell), expected counts from the pdf integrated by
// the midpoint rule (64 points a cell).
Chi2Result equiangular_chi2(const Equiangular& eq, double t_hi, uint64_t seed, int n = 1 << 20) {
  constexpr int kBins = 64, kSub = 64;
  std::vector<double> observed(kBins + 1, 0.0), expected(kBins + 1, 0.0);
  Rng rng = Rng::for_key(seed, 0, 0xe9a1);
  for (int i = 0; i < n; ++i) {
    const float t = eq.sample(rng.uniform());
    const int b = t >= t_hi ? kBins : std::clamp(int(t / t_hi * kBins), 0, kBins - 1);
    observed[b] += 1;
  }
  double inside = 0;
  const double w = t_hi / kBins;
  for (int b = 0; b < kBins; ++b) {
    double s = 0;
    for (int k = 0; k < kSub; ++k) s += eq.pdf(float((b + (k + 0.5) / kSub) * w));
    expected[b] = s / kSub * w * n;
    inside += expected[b];
  }
  expected[kBins] = std::max(0.0, n - inside);  // the tail's mass: 1 minus the rest
  Chi2Result r;
  pearson_pooled(observed, expected, 5.0, r);
  return r;
}

const Vec3 kOrigin(0.2f, -1.0f, 0.3f);
const Vec3 kDir = normalize(Vec3(0.1f, 1.0f, -0.05f));

TEST(Equiangular, SamplingMatchesDensityChi2) {
  // A light beside the ray (near its start, mid-way, behind the origin), bounded and unbounded
  // rays; Sidak-corrected 1 % over the cases.
  struct Case {
    Vec3 c;
    float t_max;
  };
  const std::vector<Case> cases = {{Vec3(0.5f, 0.0f, 0.5f), 3.0f},
                                   {Vec3(0.3f, 1.5f, 0.0f), 3.0f},
                                   {Vec3(0.3f, -3.0f, 0.4f), 2.0f},
                                   {Vec3(0.5f, 0.5f, 0.5f), kInfinity}};
  const double alpha = 1 - std::pow(0.99, 1.0 / cases.size());
  uint64_t seed = 3;
  for (const Case& c : cases) {
    const Equiangular eq(kOrigin, kDir, c.c, c.t_max);
    ASSERT_TRUE(eq.valid);
    const double t_hi = std::isinf(c.t_max) ? 20.0 : c.t_max;
    const Chi2Result r = equiangular_chi2(eq, t_hi, seed++);
    EXPECT_EQ(r.zero_expected_hits, 0u);
    EXPECT_GT(r.p_value, alpha) << "t_max " << c.t_max << " chi2 " << r.statistic << " dof " << r.dof;
  }
}

TEST(Equiangular, DensityIntegratesToOneAndRejectsACentreOnTheRay) {
  const Equiangular eq(kOrigin, kDir, Vec3(0.5f, 0.5f, 0.5f), 4.0f);
  double s = 0;
  constexpr int kN = 1 << 16;
  for (int i = 0; i < kN; ++i) s += eq.pdf(float((i + 0.5) / kN * 4.0));
  EXPECT_NEAR(s * 4.0 / kN, 1.0, 1e-4);
  EXPECT_EQ(eq.pdf(-0.1f), 0.0f);
  EXPECT_EQ(eq.pdf(4.0f), 0.0f);
  // A light on the ray's line: not valid (pdf 0; the free flight alone samples it).
  EXPECT_FALSE(Equiangular(kOrigin, kDir, kOrigin + kDir * 2.0f, 4.0f).valid);
}

TEST(Equiangular, Chi2RejectsAWrongDensity) {
  // The test has power: the density of a centre 3 % further from the ray is rejected.
  const Equiangular eq(kOrigin, kDir, Vec3(0.5f, 0.0f, 0.5f), 3.0f);
  Equiangular wrong = eq;
  wrong.D *= 1.03;
  wrong.theta_a = std::atan2(-wrong.delta, wrong.D);
  wrong.theta_b = std::atan2(3.0 - wrong.delta, wrong.D);
  constexpr int kBins = 64, n = 1 << 20;
  std::vector<double> observed(kBins, 0.0), expected(kBins, 0.0);
  Rng rng = Rng::for_key(9, 0, 0xe9a1);
  for (int i = 0; i < n; ++i) observed[std::clamp(int(eq.sample(rng.uniform()) / 3.0f * kBins), 0, kBins - 1)] += 1;
  for (int b = 0; b < kBins; ++b) {
    double s = 0;
    for (int k = 0; k < 64; ++k) s += wrong.pdf(float((b + (k + 0.5) / 64) * 3.0 / kBins));
    expected[b] = s / 64 * 3.0 / kBins * n;
  }
  Chi2Result r;
  pearson_pooled(observed, expected, 5.0, r);
  EXPECT_LT(r.p_value, 1e-3);
}

// ---- The shaft of a point light in a slab: single scattering, analytic ----

Film render_with(const std::string& method, const Scene& s, int passes, uint64_t seed, int max_depth) {
  Params p;
  p.set("seed", seed);
  p.set("max_depth", max_depth);
  return render(method, s, passes, p);
}

// A slab of medium z in [-0.5, 0.5] (wide), a point light of intensity I at the origin inside
// it, nothing else; the camera 2 m above at x = 0.3 looks straight down through a field of 0.1
// degrees (the pixels' rays within 2 mm of the axis).
constexpr double kSigmaS = 0.8, kSigmaA = 0.2, kG = 0.3, kIntensity = 5.0, kX = 0.3;
std::string slab_scene(const std::string& extra = "") {
  return R"({"camera": {"position": [0.3, 0, 2], "look_at": [0.3, 0, 0], "up": [0, 1, 0], "fov": 0.1, "width": 4, "height": 4},
    "media": {"fog": {"sigma_a": 0.2, "sigma_s": 0.8, "g": 0.3}},
    "materials": {"slab": {"type": "volume", "interior": "fog"}},
    "lights": [{"type": "point", "position": [0, 0, 0], "intensity": 5}],
    "objects": [{"type": "box", "min": [-40, -40, -0.5], "max": [40, 40, 0.5], "material": "slab"}])" +
         extra + "}";
}
// The same in World fog down to a black floor at z = -1 (the photon walk starts in the World's
// medium only: a light inside a mesh's medium is not one it sees).
std::string fog_scene(const std::string& extra = "") {
  return R"({"camera": {"position": [0.3, 0, 2], "look_at": [0.3, 0, 0], "up": [0, 1, 0], "fov": 0.1, "width": 4, "height": 4},
    "media": {"fog": {"sigma_a": 0.2, "sigma_s": 0.8, "g": 0.3}}, "world_medium": "fog",
    "materials": {"black": {"type": "diffuse", "color": 0}},
    "lights": [{"type": "point", "position": [0, 0, 0], "intensity": 5}],
    "objects": [{"type": "quad", "center": [0, 0, -1], "u": [50, 0, 0], "v": [0, 50, 0], "material": "black"}])" +
         extra + "}";
}

// The radiance single scattering sends up the axis x = 0.3 toward the camera:
// L = integral over z of exp(-sigma_t (0.5 - z)) sigma_s HG(cos) I / r^2 exp(-sigma_t r),
// r = |x(z) - light|, cos between the ray's direction (down) and the direction to the light.
double single_scattering(double z_lo = -0.5, double z_hi = 0.5) {
  const double st = kSigmaS + kSigmaA;
  constexpr int kN = 200000;
  double L = 0;
  for (int i = 0; i < kN; ++i) {
    const double z = z_lo + (i + 0.5) / kN * (z_hi - z_lo);
    const double r = std::sqrt(kX * kX + z * z);
    const double cos_theta = z / r;  // (0, 0, -1) . (-x, 0, -z) / r
    const double denom = 1 + kG * kG - 2 * kG * cos_theta;
    const double hg = (1 - kG * kG) / (4 * M_PI * denom * std::sqrt(denom));
    L += std::exp(-st * (z_hi - z)) * kSigmaS * hg * kIntensity / (r * r) * std::exp(-st * r);
  }
  return L / kN * (z_hi - z_lo);
}

TEST(Equiangular, PointLightShaftInASlabMatchesSingleScattering) {
  // max_depth 2: the camera segment and the segment to the light, single scattering only. The
  // grey medium's spectra are exact; the spectral methods' colour noise (one or four
  // wavelengths a path) is kept out by comparing the channels' mean. 1024 passes of 16 pixels.
  const double ref = single_scattering();
  const Scene s = scene_from(slab_scene());
  for (const char* method : {"pt", "spt", "spt-hero"}) {
    bool finite = false;
    const RGB m = image_mean(render_with(method, s, 1024, 7, 2), &finite);
    EXPECT_TRUE(finite) << method;
    const double mean = (double(m.r) + m.g + m.b) / 3;
    std::printf("slab shaft %s: %.4f %.4f %.4f (mean %.4f) of single scattering\n", method, m.r / ref, m.g / ref,
                m.b / ref, mean / ref);
    EXPECT_NEAR(mean / ref, 1.0, 0.01) << method << " ref " << ref;
    if (std::string(method) == "pt")
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c] / ref, 1.0, 0.01) << method << " channel " << c;
  }
}

TEST(Equiangular, VolumeBouncesZeroIsSingleScattering) {
  // Light Paths > Volume bounces 0 (the scene's volume_bounces): with unlimited bounces the
  // image is single scattering still; without it, multiple scattering adds light.
  const double ref = single_scattering();
  const Scene single = scene_from(slab_scene(R"(, "volume_bounces": 0)"));
  EXPECT_EQ(single.volume_bounces, 0);
  const RGB m = image_mean(render_with("pt", single, 256, 7, 256));
  std::printf("volume_bounces 0: %.4f of single scattering\n", m.g / ref);
  EXPECT_NEAR(m.g / ref, 1.0, 0.01);
  const RGB all = image_mean(render_with("pt", scene_from(slab_scene()), 256, 7, 256));
  EXPECT_GT(all.g / ref, 1.03);
  // One more volume bounce: between the two.
  const RGB two = image_mean(render_with("pt", scene_from(slab_scene(R"(, "volume_bounces": 1)")), 256, 7, 256));
  std::printf("unlimited %.4f, volume_bounces 1 %.4f\n", all.g / ref, two.g / ref);
  EXPECT_GT(two.g / ref, 1.01);
  EXPECT_LT(two.g, all.g * 1.005);
  EXPECT_THROW(scene_from(slab_scene(R"(, "volume_bounces": -1)")), std::exception);
}

TEST(Equiangular, PhotonsKeepVolumeBouncesToo) {
  // SPPM's volume photons follow the same count: with volume_bounces 0 a photon is stored at its
  // first scattering only, and the beam estimate is single scattering; without the limit
  // multiple scattering doubles it. SPPM's progressive bias and noise at 24 passes: 0.942 of the
  // integral (0.992 at 96 passes), hence 8 %: a photon kept for one more scattering gives ~1.4.
  const double ref = single_scattering(-1.0, 2.0);
  Params p;
  p.set("seed", uint64_t{3});
  p.set("photons", int64_t{100000});
  p.set("radius", 0.02);
  p.set("max_depth", 64);
  const RGB single = image_mean(render("sppm", scene_from(fog_scene(R"(, "volume_bounces": 0)")), 24, p));
  const RGB all = image_mean(render("sppm", scene_from(fog_scene()), 24, p));
  // pt in the same World fog (its mean moves ~0.4 % between seeds at 2048 passes).
  const RGB pt = image_mean(render_with("pt", scene_from(fog_scene(R"(, "volume_bounces": 0)")), 2048, 7, 64));
  std::printf("pt in World fog, volume_bounces 0: %.4f of single scattering\n", pt.g / ref);
  EXPECT_NEAR(pt.g / ref, 1.0, 0.01);
  std::printf("sppm: volume_bounces 0 %.4f, unlimited %.4f of single scattering\n", single.g / ref, all.g / ref);
  EXPECT_NEAR(single.g / ref, 1.0, 0.08);
  EXPECT_GT(all.g / ref, 1.5);
}

}  // namespace
}  // namespace gp
