// Participating media (media/medium.h, paths/camera_path.h): the Henyey-Greenstein phase
// function's sampling against its density (chi-square), Beer-Lambert transmittance through a slab
// for camera rays and for next-event shadow rays (analytic), an albedo-1 medium in a uniform
// environment (furnace), the RGB and hero-wavelength path tracers on one medium scene, the
// scene format's media and its errors, and the warning of methods that do not render media.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "chi2.h"
#include "core/rng.h"
#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "media/medium.h"
#include "render_for_tests.h"
#include "scene/loader.h"
#include "session/render_session.h"

namespace gp {
namespace {

// ---- Henyey-Greenstein: density and sampling ----

// Cells of (cos theta, phi) in the world frame (not the phase function's own), so the frame
// built around the travel direction is tested too.
constexpr int kCosBins = 24, kPhiBins = 48;
int cell_of(const Vec3& w) {
  const int c = std::clamp(static_cast<int>((w.z + 1) * 0.5f * kCosBins), 0, kCosBins - 1);
  float phi = std::atan2(w.y, w.x);
  if (phi < 0) phi += 2 * kPi;
  const int p = std::clamp(static_cast<int>(phi / (2 * kPi) * kPhiBins), 0, kPhiBins - 1);
  return c * kPhiBins + p;
}
Vec3 direction_at(double c, double phi) {
  const double s = std::sqrt(std::max(0.0, 1 - c * c));
  return Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(c));
}

// Pearson's chi-square of n samples of `sample` against `pdf` integrated over each cell
// (midpoint rule on a 12 x 12 grid per cell: the density is smooth for |g| <= 0.9 at this size).
template <class Sample, class Pdf>
Chi2Result phase_chi2(Sample&& sample, Pdf&& pdf, uint64_t seed, int n = 1 << 20) {
  std::vector<double> observed(kCosBins * kPhiBins, 0.0), expected(kCosBins * kPhiBins, 0.0);
  Rng rng = Rng::for_key(seed, 0, 0x9a5e);
  for (int i = 0; i < n; ++i) {
    const float u0 = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    observed[cell_of(sample(u0, u))] += 1;
  }
  constexpr int kSub = 12;
  const double dc = 2.0 / kCosBins, dp = 2 * M_PI / kPhiBins;
  for (int ci = 0; ci < kCosBins; ++ci)
    for (int pi = 0; pi < kPhiBins; ++pi) {
      double s = 0;
      for (int a = 0; a < kSub; ++a)
        for (int b = 0; b < kSub; ++b)
          s += pdf(direction_at(-1 + (ci + (a + 0.5) / kSub) * dc, (pi + (b + 0.5) / kSub) * dp));
      expected[ci * kPhiBins + pi] = s / (kSub * kSub) * dc * dp * n;  // solid angle = dcos dphi
    }
  Chi2Result r;
  pearson_pooled(observed, expected, 5.0, r);
  return r;
}

const Vec3 kTravel = normalize(Vec3(0.3f, -0.5f, 0.8f));

TEST(HenyeyGreenstein, DensityIntegratesToOneAndIsCyclesClamped) {
  for (float g : {-0.9f, -0.3f, 0.0f, 0.5f, 0.95f}) {
    // integral over the sphere = 2 pi * integral over cos theta (Simpson, 2e5 intervals: g 0.95 peaks)
    const int n = 200000;
    double s = 0;
    for (int i = 0; i <= n; ++i) {
      const double c = -1 + 2.0 * i / n;
      s += (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2)) * henyey_greenstein(float(c), g);
    }
    EXPECT_NEAR(s * (2.0 / n) / 3 * 2 * M_PI, 1.0, 2e-3) << "g " << g;
  }
  // Isotropic: 1 / (4 pi) everywhere.
  EXPECT_NEAR(henyey_greenstein(0.3f, 0.0f), 1 / (4 * M_PI), 1e-7);
  // The scene format clamps g to Cycles' 1 - 1e-3.
  const Scene s = scene_from(R"({"media": {"m": {"sigma_s": 1, "g": 1}}, "world_medium": "m"})");
  EXPECT_FLOAT_EQ(s.media[0].g, kMaxAnisotropy);
}

TEST(HenyeyGreenstein, SamplingMatchesDensityChi2) {
  // Sidak-corrected 1 % over the cases (pbrt-v4's Chi2Test threshold).
  const std::vector<float> gs = {-0.7f, 0.0f, 0.3f, 0.8f};
  const double alpha = 1 - std::pow(0.99, 1.0 / (gs.size() + 1));
  uint64_t seed = 11;
  for (float g : gs) {
    const Chi2Result r = phase_chi2([&](float, Vec2 u) { return sample_henyey_greenstein(kTravel, g, u); },
                                    [&](const Vec3& w) { return henyey_greenstein(dot(kTravel, w), g); }, seed++);
    EXPECT_TRUE(r.error.empty()) << r.error;
    EXPECT_GT(r.p_value, alpha) << "g " << g << " chi2 " << r.statistic << " dof " << r.dof;
  }
  // Two media overlapping (Cycles sums them): the mixture's sampling against its density.
  Medium a, b;
  a.sigma_s = RGB(1.0f, 2.0f, 0.5f);
  a.g = -0.5f;
  b.sigma_s = RGB(3.0f);
  b.g = 0.8f;
  std::vector<MediumChannels> table = {rgb_channels(a), rgb_channels(b)};
  MediumStack stack(0);
  stack.cross(7, 1, true);
  const MediumSegment seg(stack, Ray(), 3, [&](int m) -> const MediumChannels& { return table[m]; });
  const Chi2Result r = phase_chi2([&](float ul, Vec2 u) { return seg.sample_phase(kTravel, ul, u); },
                                  [&](const Vec3& w) { return seg.phase_pdf(dot(kTravel, w)); }, seed++);
  EXPECT_GT(r.p_value, alpha) << "mixture chi2 " << r.statistic << " dof " << r.dof;
}

TEST(HenyeyGreenstein, Chi2RejectsAWrongAnisotropy) {
  // The test has power: samples of g = 0.3 against the density of g = 0.33 are rejected.
  const Chi2Result r = phase_chi2([&](float, Vec2 u) { return sample_henyey_greenstein(kTravel, 0.3f, u); },
                                  [&](const Vec3& w) { return henyey_greenstein(dot(kTravel, w), 0.33f); }, 5);
  EXPECT_LT(r.p_value, 1e-3);
}

// ---- Free flight ----

TEST(MediumSegment, FreeFlightWeightsAreUnbiasedPerChannel) {
  // E[pass weight 1{t_s > t}] = T_c(t) and E[scatter weight 1{t_s < t}] = integral of
  // sigma_s T over [0, t), per channel, with the channel picked uniformly or by throughput.
  Medium m;
  m.sigma_a = RGB(0.2f, 0.0f, 1.0f);
  m.sigma_s = RGB(0.5f, 1.5f, 0.0f);
  const std::vector<MediumChannels> table = {rgb_channels(m)};
  for (const ChannelValues& weights : {ChannelValues{}, ChannelValues{0.2f, 1.0f, 3.0f}}) {
    MediumSegment seg(MediumStack(0), Ray(), 3, [&](int i) -> const MediumChannels& { return table[i]; });
    seg.set_channel_weights(weights);
    const float t_end = 1.3f;
    double pass[3] = {0, 0, 0}, scat[3] = {0, 0, 0};
    const int n = 400000;
    Rng rng = Rng::for_key(3, 0, 1);
    for (int i = 0; i < n; ++i) {
      const float t = seg.sample_distance(rng.uniform(), rng.uniform());
      const ChannelValues w = t < t_end ? seg.scatter_weight(t) : seg.pass_weight(t_end);
      for (int c = 0; c < 3; ++c) (t < t_end ? scat : pass)[c] += w[c];
    }
    // 4e5 samples of weights below 3: standard errors under 2e-3.
    for (int c = 0; c < 3; ++c) {
      const double st = m.sigma_a[c] + m.sigma_s[c];
      EXPECT_NEAR(pass[c] / n, std::exp(-st * t_end), 6e-3) << "channel " << c << " weights " << weights[2];
      const double in_scatter = st > 0 ? m.sigma_s[c] / st * (1 - std::exp(-st * t_end)) : 0.0;
      EXPECT_NEAR(scat[c] / n, in_scatter, 6e-3) << "channel " << c << " weights " << weights[2];
    }
  }
  // Nothing scatters: no sampling, the transmittance itself.
  Medium ink;
  ink.sigma_a = RGB(0.5f, 1.0f, 2.0f);
  const std::vector<MediumChannels> ink_table = {rgb_channels(ink)};
  const MediumSegment seg(MediumStack(0), Ray(), 3, [&](int i) -> const MediumChannels& { return ink_table[i]; });
  EXPECT_EQ(seg.sample_distance(0.5f, 0.999f), kInfinity);
  EXPECT_FLOAT_EQ(seg.pass_weight(2.0f)[2], std::exp(-4.0f));
}

TEST(MediumSegment, SpectralFreeFlightWeightsCannotGrowTheThroughput) {
  // The free flight of a path at C wavelengths in a strongly chromatic medium (scattering at the
  // first wavelength 10x the last): with the channel picked in proportion to the throughput and
  // the distance's density the mixture sum_c q_c sigma_t,c T_c (spectral MIS, the one-sample
  // balance heuristic over the wavelengths), sum_k beta_k w_k <= sum_k beta_k for every sample,
  // scattered or passed. Sampling with the hero's sigma_t alone (q = (1, 0, ...)) carries the
  // others by T_k / T_hero, which grows without bound with the distance: it fails here.
  constexpr int C = 4;
  MediumChannels c;
  const float s_s[C] = {2.0f, 0.9f, 0.45f, 0.2f}, s_a[C] = {0.05f, 0.05f, 0.05f, 0.05f};
  for (int k = 0; k < C; ++k) {
    c.sigma_s[k] = s_s[k];
    c.sigma_a[k] = s_a[k];
    c.sigma_t[k] = s_s[k] + s_a[k];
  }
  const std::vector<MediumChannels> table = {c};
  Rng rng = Rng::for_key(11, 0, 2);
  double worst = 0;
  for (int i = 0; i < 200000; ++i) {
    MediumSegment seg(MediumStack(0), Ray(), C, [&](int m) -> const MediumChannels& { return table[m]; });
    ChannelValues beta{};
    double sum = 0;
    for (int k = 0; k < C; ++k) sum += beta[k] = 0.05f + rng.uniform();
    seg.set_channel_weights(beta);
    const float t_end = 8.0f * rng.uniform();
    const float t = seg.sample_distance(rng.uniform(), rng.uniform());
    const ChannelValues w = t < t_end ? seg.scatter_weight(t) : seg.pass_weight(t_end);
    double after = 0;
    for (int k = 0; k < C; ++k) after += beta[k] * w[k];
    worst = std::max(worst, after / sum);
  }
  // Measured 1.0000 (the bound is exact up to float rounding); hero-only sampling: above 100.
  EXPECT_LE(worst, 1.0 + 1e-4);
}

// ---- Whole paths ----

Film render_pt(const Scene& s, int passes, const std::string& method = "pt", uint64_t seed = 1, int max_depth = 256) {
  Params p;
  p.set("seed", seed);
  p.set("max_depth", max_depth);
  return render(method, s, passes, p);
}

// Camera looking down the z axis at the origin through a narrow field (rays within 1.4 degrees).
const char* kCameraDown = R"("camera": {"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8})";

TEST(MediaPathTracing, BeerLambertThroughASlabOnCameraRays) {
  // An emitter of radiance 1 seen through 0.4 m of a purely absorbing slab: L = exp(-sigma_a d).
  const Scene s = scene_from(std::string("{") + kCameraDown + R"(,
    "media": {"ink": {"sigma_a": [0.5, 1.0, 2.0]}},
    "materials": {"light": {"type": "emission", "emission": 1, "strength": 1},
                  "slab": {"type": "volume", "interior": "ink"}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "light"},
                {"type": "box", "min": [-3, -3, 0.5], "max": [3, 3, 0.9], "material": "slab"}]})");
  ASSERT_TRUE(s.has_media());
  const RGB m = image_mean(render_pt(s, 64));
  const float sigma[3] = {0.5f, 1.0f, 2.0f};
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], std::exp(-sigma[c] * 0.4f), 0.01) << "channel " << c;
}

TEST(MediaPathTracing, BeerLambertOnNextEventShadowRays) {
  // A point light of intensity 8 at height 2 over a diffuse plane of albedo 0.5, a 0.4 m
  // absorbing slab between them, the camera under the slab: L = (a / pi) (I / h^2) exp(-sigma d).
  // Only the shadow ray crosses the slab: a dropped transmittance fails here.
  const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 0.5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8},
    "media": {"ink": {"sigma_a": [0.5, 1.0, 2.0]}},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}, "slab": {"type": "volume", "interior": "ink"}},
    "lights": [{"type": "point", "position": [0, 0, 2], "intensity": 8}],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "grey"},
                {"type": "box", "min": [-3, -3, 1.0], "max": [3, 3, 1.4], "material": "slab"}]})");
  const RGB m = image_mean(render_pt(s, 16, "pt", 1, 2));  // direct light only
  const float sigma[3] = {0.5f, 1.0f, 2.0f};
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(m[c], 0.5 / M_PI * 8.0 / 4.0 * std::exp(-sigma[c] * 0.4f), 2e-3) << "channel " << c;
}

// A sphere of a scattering-only medium (albedo 1, coloured, anisotropic) in a uniform World.
std::string furnace_scene(const char* medium) {
  return std::string("{") + R"("camera": {"position": [0, -4, 0], "look_at": [0, 0, 0], "fov": 30, "width": 16, "height": 16},
    "media": {"cloud": )" + medium + R"(},
    "materials": {"boundary": {"type": "volume", "interior": "cloud"}},
    "environment": {"color": [0.5, 1.0, 2.0], "strength": 1},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "segments": 48, "material": "boundary"}]})";
}

TEST(MediaPathTracing, AlbedoOneMediumInUniformEnvironmentIsInvisible) {
  // Scattering without absorption under a uniform World returns the World's radiance along
  // every ray (the volumetric white furnace). Tests phase NEE with MIS against phase sampling
  // (a missing or wrong phase pdf breaks the balance), shadow-ray transmittance and free flight.
  for (const char* medium : {R"({"sigma_s": [0.5, 2.0, 4.0], "g": 0.6})", R"({"sigma_s": 3, "g": -0.4})"}) {
    const Scene s = scene_from(furnace_scene(medium));
    for (const char* method : {"pt", "spt-hero"}) {
      bool finite = false;
      const RGB m = image_mean(render_pt(s, 48, method), &finite);
      EXPECT_TRUE(finite);
      // 48 spp over 256 pixels: a few per mille of noise; 2 % headroom.
      EXPECT_NEAR(m.r, 0.5, 0.01) << method << " " << medium;
      EXPECT_NEAR(m.g, 1.0, 0.02) << method << " " << medium;
      EXPECT_NEAR(m.b, 2.0, 0.04) << method << " " << medium;
    }
  }
}

TEST(MediaPathTracing, RgbAndHeroWavelengthsAgreeOnAMediumScene) {
  // A grey fog sphere with emission and an absorbing core, a diffuse floor, a point light and a
  // coloured World: pt and spt-hero (grey coefficients upsample exactly) agree within noise.
  const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, -5, 1], "look_at": [0, 0, 0.5], "fov": 35, "width": 16, "height": 12},
    "media": {"fog": {"sigma_a": 0.3, "sigma_s": 1.2, "g": 0.4, "emission": 0.2}, "ink": {"sigma_a": 2}},
    "materials": {"floor": {"type": "diffuse", "color": 0.6}, "fog": {"type": "volume", "interior": "fog"},
                  "core": {"type": "volume", "interior": "ink"}},
    "environment": {"color": [0.2, 0.3, 0.5]},
    "lights": [{"type": "point", "position": [1, -1, 3], "intensity": 30}],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                {"type": "sphere", "center": [0, 0, 1], "radius": 0.9, "segments": 32, "material": "fog"},
                {"type": "sphere", "center": [0, 0, 1], "radius": 0.4, "segments": 24, "material": "core"}]})");
  const RGB a = image_mean(render_pt(s, 96, "pt", 2, 64));
  const RGB b = image_mean(render_pt(s, 96, "spt-hero", 3, 64));
  // Luminance of the means; both at a few per mille of noise here, 2 % headroom.
  EXPECT_NEAR(b.luminance() / a.luminance(), 1.0, 0.02) << a.luminance() << " vs " << b.luminance();
}

TEST(MediaPathTracing, HeroWavelengthsInChromaticFogMatchRgbWithoutFireflies) {
  // A fog box scattering red 10x blue (sigma_s 2.0, 0.6, 0.2) over a diffuse floor and wall under
  // an area light. spt-hero samples its free flights by the one-sample MIS over its 4 wavelengths
  // (MediumSegment: the density sum_c q_c sigma_t,c T_c): its luminance matches pt's, and its
  // noise is that of a grey medium. Measured (spt-hero 512 passes, seeds 4-6, against pt at
  // 1024): luminance 1.0048, 1.0039, 1.0079; relMSE of the luminance 0.0024-0.0028; the brightest
  // pixel 4.4-4.7x the mean. Seen failing with the hero's sigma_t alone for the distance
  // (q = (1, 0, 0, 0)): relMSE 0.032. Per channel spt-hero is spectral, not RGB: its red is 3 %
  // above pt's (a chromatic medium's spectral product differs from the RGB one) and within 1 %
  // of spt's; so luminance is compared here.
  const Scene s = scene_from(R"({"camera": {"position": [0, -4, 1.2], "look_at": [0, 0, 1.0], "fov": 40, "width": 16, "height": 12},
    "media": {"fog": {"sigma_a": 0.05, "sigma_s": [2.0, 0.6, 0.2], "g": 0.3}},
    "materials": {"wall": {"type": "diffuse", "color": 0.6}, "fog": {"type": "volume", "interior": "fog"},
                  "lamp": {"type": "emission", "emission": 1, "strength": 6, "two_sided": true}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [4, 0, 0], "v": [0, 4, 0], "material": "wall"},
                {"type": "quad", "center": [0, 1.5, 1.5], "u": [4, 0, 0], "v": [0, 0, 3], "material": "wall"},
                {"type": "box", "min": [-0.8, -0.8, 0.2], "max": [0.8, 0.8, 1.8], "material": "fog"},
                {"type": "quad", "center": [0.4, -0.3, 2.5], "u": [0.8, 0, 0], "v": [0, 0.8, 0], "material": "lamp"}]})");
  const Film ref = render_pt(s, 1024, "pt", 1, 32);
  const Film hero = render_pt(s, 512, "spt-hero", 4, 32);
  double sum_ref = 0, sum_hero = 0, rel = 0, brightest = 0;
  for (int y = 0; y < ref.height(); ++y)
    for (int x = 0; x < ref.width(); ++x) {
      const double a = ref.rgb(pass::kCombined, x, y).luminance(), b = hero.rgb(pass::kCombined, x, y).luminance();
      sum_ref += a;
      sum_hero += b;
      rel += (b - a) * (b - a) / (a * a + 1e-4);
      brightest = std::max(brightest, double(hero.rgb(pass::kCombined, x, y).max_component()));
    }
  const double n = double(ref.width()) * ref.height();
  rel /= n;
  std::printf("chromatic fog: spt-hero / pt luminance %.4f, relMSE %.5f, brightest pixel %.2f x the mean\n",
              sum_hero / sum_ref, rel, brightest / (sum_ref / n));
  EXPECT_NEAR(sum_hero / sum_ref, 1.0, 0.01);  // the issue's 1 %; measured within 0.8 %
  EXPECT_LT(rel, 0.008);                       // 3x the measured; hero-only sampling 4x above it
  EXPECT_LT(brightest / (sum_ref / n), 7.0);   // measured 4.4-4.7
}

TEST(MediaPathTracing, AMediumInsideGlassIsEnteredThroughTheGlass) {
  // Murky water in glass: a box of clear glass of IOR 1 whose interior absorbs, in front of an
  // emitter; seen straight on, L = exp(-sigma_a d) (no refraction at IOR 1, no reflection).
  const Scene s = scene_from(std::string("{") + kCameraDown + R"(,
    "media": {"water": {"sigma_a": [0.2, 0.5, 1.5]}},
    "materials": {"light": {"type": "emission", "emission": 1, "strength": 1},
                  "glass": {"type": "dielectric", "ior": 1.0, "color": [1, 1, 0.999], "interior": "water"}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "light"},
                {"type": "box", "min": [-3, -3, 0.5], "max": [3, 3, 1.0], "material": "glass"}]})");
  const RGB m = image_mean(render_pt(s, 64));
  const float sigma[3] = {0.2f, 0.5f, 1.5f}, tint[3] = {1, 1, 0.999f * 0.999f};
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], tint[c] * std::exp(-sigma[c] * 0.5f), 0.01) << "channel " << c;
}

TEST(MediaPathTracing, SceneWithoutMediaHasNoMediaAndWorldMediumFillsTheOpen) {
  EXPECT_FALSE(cornell_box(8, 8).has_media());
  // A World medium that only absorbs: the emitter at distance 2 is seen through exp(-sigma 2).
  const Scene s = scene_from(std::string("{") + kCameraDown + R"(,
    "media": {"haze": {"sigma_a": 0.25}}, "world_medium": "haze",
    "materials": {"light": {"type": "emission", "emission": 1, "strength": 1}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "light"}]})");
  EXPECT_NEAR(image_mean(render_pt(s, 32)).g, std::exp(-0.5f), 0.01);
}

// ---- Scene format and front ends ----

TEST(MediaPathTracing, CameraClipStartSkipsTheFogInFrontOfIt) {
  // An emitter of radiance 1 seen 2 m away through absorbing World fog (sigma_a 0.5), a grey
  // quad 0.05 m in front of the camera. Camera rays start on the near clip plane, as Cycles'
  // (camera_sample_perspective: Clip Start): with clip_start 0.3 the quad is not seen and only
  // 1.7 m of fog dims the emitter (exp(-0.85)); a far clip before the emitter sees nothing.
  // (Blender's World fog under a spot light read 2.6 % darker than Cycles without this.)
  auto scene = [](const std::string& clip) {
    return scene_from(std::string(R"({"camera": {"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2,
      "width": 8, "height": 8)") + clip + R"(},
      "media": {"ink": {"sigma_a": 0.5}}, "world_medium": "ink",
      "materials": {"light": {"type": "emission", "emission": 1, "strength": 1}, "grey": {"type": "diffuse", "color": 0.5}},
      "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "light"},
                  {"type": "quad", "center": [0, 0, 1.95], "u": [1, 0, 0], "v": [0, 1, 0], "material": "grey"}]})");
  };
  EXPECT_NEAR(image_mean(render_pt(scene(""), 4)).g, 0.0, 1e-6);  // the grey quad, unlit
  const RGB clipped = image_mean(render_pt(scene(R"(, "clip_start": 0.3)"), 4));
  EXPECT_NEAR(clipped.g, std::exp(-0.5 * 1.7), 2e-3);  // cos of the rays' angles within 1.4 degrees: 3e-4
  EXPECT_NEAR(image_mean(render_pt(scene(R"(, "clip_start": 0.3, "clip_end": 1.5)"), 4)).g, 0.0, 1e-6);
  EXPECT_THROW(scene(R"(, "clip_start": 0.3, "clip_end": 0.2)"), std::exception);
}

// A camera inside a medium starts its paths in it (CameraMedia, Cycles' volume_stack_init at the
// camera ray's origin): an emitter of radiance 1 at z = 0 seen from z = 2 inside an absorbing box
// whose top and bottom are at z = `top` and z = `bottom`: L = exp(-sigma d), d the length of the
// ray from its origin (on the near clip plane) to the emitter inside the box. Without it every
// camera ray started in the World's medium alone and saw the emitter unattenuated.
std::string camera_in_box(float bottom, float top, const std::string& camera_extra, const std::string& sigma = "[0.5, 1.0, 2.0]",
                          const std::string& material = R"({"type": "volume", "interior": "ink"})") {
  return std::string(R"({"camera": {"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8)") +
         camera_extra + R"(},
    "media": {"ink": {"sigma_a": )" + sigma + R"(}},
    "materials": {"light": {"type": "emission", "emission": 1, "strength": 1}, "box": )" + material + R"(},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "light"},
                {"type": "box", "min": [-3, -3, )" + std::to_string(bottom) + R"(], "max": [3, 3, )" + std::to_string(top) +
         R"(], "material": "box"}]})";
}

TEST(MediaPathTracing, ACameraInsideAMediumSeesThroughIt) {
  const float sigma[3] = {0.5f, 1.0f, 2.0f};
  auto expect_beer_lambert = [&](const RGB& m, float d, double tol, const std::string& what) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], std::exp(-sigma[c] * d), tol) << what << ", channel " << c;
  };
  // Inside a Volume box: 1.5 m of ink to the emitter, in pt and in SPPM's eye paths.
  const Scene inside = scene_from(camera_in_box(0.5f, 2.5f, ""));
  expect_beer_lambert(image_mean(render_pt(inside, 16)), 1.5f, 0.01, "pt inside the box");
  Params sppm;
  sppm.set("seed", 1);
  sppm.set("photons", 1000);
  expect_beer_lambert(image_mean(render("sppm", inside, 4, sppm)), 1.5f, 0.01, "sppm inside the box");
  expect_beer_lambert(image_mean(render("msppm", inside, 4, sppm)), 1.5f, 0.01, "msppm inside the box");
  // Under murky water: inside a glass box whose interior is the ink, the emitter in the water.
  const Scene water = scene_from(camera_in_box(-1.0f, 2.5f, "", "[0.5, 1.0, 2.0]",
                                               R"({"type": "dielectric", "ior": 1.33, "roughness": 0, "interior": "ink"})"));
  expect_beer_lambert(image_mean(render_pt(water, 16)), 2.0f, 0.01, "pt under murky water");
  // The clip start as Cycles reads it: the stack at the ray's origin on the near clip plane. The
  // eye above a box whose top is at 1.8, the clip plane at 1.7 inside it: 1.2 m of ink ...
  expect_beer_lambert(image_mean(render_pt(scene_from(camera_in_box(0.5f, 1.8f, R"(, "clip_start": 0.3)")), 16)), 1.2f,
                      0.01, "the clip plane inside the box");
  // ... and the eye inside a box whose bottom is at 1.8, the clip plane at 1.7 below it: none.
  expect_beer_lambert(image_mean(render_pt(scene_from(camera_in_box(1.8f, 2.5f, R"(, "clip_start": 0.3)")), 16)), 0.0f,
                      0.01, "the clip plane below the box");
  // A thin lens: every ray's origin on the lens, inside the box (the stack carried from the eye).
  expect_beer_lambert(
      image_mean(render_pt(scene_from(camera_in_box(0.5f, 2.5f, R"(, "aperture_radius": 0.05, "focus_distance": 2)")), 16)),
      1.5f, 0.01, "a thin lens inside the box");
  // A camera moving inside the box over the shutter (its media found per path at the path's time).
  const Scene moving = scene_from(camera_in_box(
      0.5f, 2.5f, R"(, "motion": [[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 2, 0, 0, 0, 1], [1, 0, 0, 0.3, 0, 1, 0, 0, 0, 0, 1, 2, 0, 0, 0, 1]])"));
  ASSERT_TRUE(moving.camera.motion_blur);
  expect_beer_lambert(image_mean(render_pt(moving, 16)), 1.5f, 0.01, "a moving camera inside the box");
  // Wavelengths: grey ink (its spectrum flat), spt and spt-hero, against the same method's image of
  // the emitter with the clip plane below the box (no ink on the way; a white emitter's sampled
  // wavelengths give its RGB only within their colour noise), the same seed: the ratio per channel.
  const Scene grey = scene_from(camera_in_box(0.5f, 2.5f, "", "1.0"));
  const Scene clear = scene_from(camera_in_box(1.8f, 2.5f, R"(, "clip_start": 0.3)", "1.0"));
  for (const char* method : {"spt", "spt-hero"}) {
    const RGB m = image_mean(render_pt(grey, 16, method)), open = image_mean(render_pt(clear, 16, method));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c] / open[c], std::exp(-1.5), 0.005) << method << ", channel " << c;
  }
}

TEST(MediaPathTracing, ACameraInsideAMediumHiddenFromTheCameraSeesNoFog) {
  // Cycles 3.4 finds the camera's media with a ray of camera visibility
  // (integrator_volume_stack_init: PATH_RAY_CAMERA): a Volume box whose object is hidden from
  // the camera is not around it, and camera rays pass its boundary without entering it, so the
  // emitter is seen through no ink at all (every method's eye paths start in CameraMedia). The
  // World's medium is always around the camera (Cycles' background volume): here, none.
  const std::string hidden = R"({"type": "volume", "interior": "ink", "visible_to_camera": false})";
  const Scene inside = scene_from(camera_in_box(0.5f, 2.5f, "", "[0.5, 1.0, 2.0]", hidden));
  auto expect_clear = [](const RGB& m, const std::string& what) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], 1.0, 1e-3) << what << ", channel " << c;
  };
  expect_clear(image_mean(render_pt(inside, 4)), "pt");
  Params sppm;
  sppm.set("seed", 1);
  sppm.set("photons", 1000);
  expect_clear(image_mean(render("sppm", inside, 2, sppm)), "sppm");
  expect_clear(image_mean(render("msppm", inside, 2, sppm)), "msppm");
  // The stack carried from the eye to a thin lens, and found per path for a moving camera.
  expect_clear(image_mean(render_pt(scene_from(camera_in_box(0.5f, 2.5f, R"(, "aperture_radius": 0.05, "focus_distance": 2)",
                                                             "[0.5, 1.0, 2.0]", hidden)),
                                    4)),
               "a thin lens");
  expect_clear(image_mean(render_pt(scene_from(camera_in_box(0.5f, 2.5f,
                                                             R"(, "motion": [[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 2, 0, 0, 0, 1], [1, 0, 0, 0.3, 0, 1, 0, 0, 0, 0, 1, 2, 0, 0, 0, 1]])",
                                                             "[0.5, 1.0, 2.0]", hidden)),
                                    4)),
               "a moving camera");
}

TEST(MediaSceneFormat, ErrorsNameTheFileAndTheKey) {
  auto error_of = [](const std::string& json) -> std::string {
    try {
      scene_from(json);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of(R"({"materials": {"b": {"type": "volume", "interior": "fgo"}}, "media": {"fog": {}}})")
                .find("test.json: /materials/b/interior: unknown medium 'fgo' (known: fog)"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"materials": {"b": {"type": "volume"}}})").find("/materials/b: missing required key 'interior'"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"media": {"fog": {"sigma_s": -1}}})").find("/media/fog/sigma_s: must not be negative"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"media": {"fog": {"g": 2}}})").find("/media/fog/g: must be in [-1, 1]"), std::string::npos);
  EXPECT_NE(error_of(R"({"world_medium": "fog"})").find("/world_medium: unknown medium 'fog' (known: none defined)"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "clip_start": 2, "clip_end": 1}})")
                .find("/camera/clip_end: must be beyond clip_start"),
            std::string::npos);
}

TEST(MediaMethods, MethodsWithoutMediaSayItOnceNamingThemselves) {
  auto scene = std::make_shared<const Scene>(scene_from(furnace_scene(R"({"sigma_s": 1})")));
  for (const Method& m : methods()) {
    if (m.name == "gdmlt" || m.name == "sgpt" || m.name == "spt") continue;  // need options or a spectral scene
    Params p;
    p.set("seed", 1);
    RenderSession session(scene, m.name, p);
    if (m.supports.media) {
      // Media rendered: nothing to say, unless a Target Error asks an estimate the method
      // cannot make there (ppm, sppm): then only to that stop rule, not to a time or pass one.
      EXPECT_TRUE(session.feature_report().empty()) << m.name;
      EXPECT_TRUE(session.stop_report(StopRule{60, 0, 0}).empty()) << m.name;
      EXPECT_TRUE(session.stop_report(StopRule{0, 16, 0}).empty()) << m.name;
      const auto lines = session.stop_report(StopRule{60, 0, 0.01});
      if (m.error_estimate) {
        ASSERT_EQ(lines.size(), 1u) << m.name;
        EXPECT_NE(lines[0].find("method '" + m.name + "' estimates no error with participating media"),
                  std::string::npos);
      } else {
        EXPECT_TRUE(lines.empty()) << m.name;
      }
    } else {
      ASSERT_EQ(session.feature_report().size(), 1u) << m.name;
      EXPECT_NE(session.feature_report()[0].find("method '" + m.name + "' does not render participating media"),
                std::string::npos);
    }
  }
  EXPECT_TRUE(find_method("pt").supports.media);
  EXPECT_TRUE(find_method("spt-hero").supports.media);
  EXPECT_TRUE(find_method("sppm").supports.media);  // photon methods in media: media_photon_test.cpp
  EXPECT_TRUE(find_method("ppm").supports.media);
  EXPECT_TRUE(find_method("sppm-adaptive").supports.media);  // V(u) sees volume photons (adaptive_photons.h)
  EXPECT_TRUE(find_method("msppm").supports.media);  // msppm_media_test.cpp
  for (const char* m : {"pt", "spt", "spt-hero", "ppm", "sppm", "sppm-adaptive", "msppm"}) EXPECT_TRUE(find_method(m).supports.grid_media) << m;
  EXPECT_FALSE(find_method("gpm").supports.media);
}

}  // namespace
}  // namespace gp
