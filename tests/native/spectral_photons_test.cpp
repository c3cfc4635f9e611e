// Spectral photons (SPPM with one wavelength set per pass, docs/spectral.md "Spectral photons"):
// agreement with a long spt-hero reference on the prism, the RGB image unchanged in auto mode on
// a scene without dispersion, Cauchy B = 0 in spectral mode close to RGB SPPM, finite output,
// a few passes' means through coloured Transparent panes within a stated spread of spt's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "integrators/photon/sppm.h"
#include "scene/loader.h"
#include "render_for_tests.h"

namespace gp {
namespace {

Scene load(const std::string& name, int w, int h) {
  Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/" + name);
  s.camera.width = w;
  s.camera.height = h;
  return s;
}

TEST(SpectralPhotons, PrismAgreesWithSpectralPathTracer) {
  const Scene s = load("prism.json", 40, 30);
  Params sp;
  sp.set("photons", 50000);
  auto integ = make_integrator("sppm", s, sp);
  ASSERT_TRUE(dynamic_cast<Sppm&>(*integ).spectral());  // auto: the prism is dispersive
  const RGB ref = image_mean(render_with_seed(s, "spt-hero", 8192, Params(nlohmann::json{{"seed", 7}})));
  bool finite = false;
  const RGB m = image_mean(render_with_seed(s, "sppm", 256, sp), &finite);
  EXPECT_TRUE(finite);
  std::printf("prism mean: sppm %.5f %.5f %.5f, spt-hero %.5f %.5f %.5f\n", m[0], m[1], m[2], ref[0], ref[1], ref[2]);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(m[c] / ref[c], 1.0, 0.1) << "channel " << c << ": " << m[c] << " vs " << ref[c];
}

TEST(SpectralPhotons, AutoModeLeavesNonDispersiveScenesInRgb) {
  // No dispersive material: sppm in auto mode is the RGB code path, the same image bit for bit.
  const Scene s = load("cornell-box.json", 24, 24);
  Params p;
  p.set("photons", 20000);
  auto integ = make_integrator("sppm", s, p);
  EXPECT_FALSE(dynamic_cast<Sppm&>(*integ).spectral());
  Params rgb = p;
  rgb.set("spectral", "rgb");
  const Film a = render_with_seed(s, "sppm", 8, p), b = render_with_seed(s, "sppm", 8, rgb);
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const RGB ca = a.rgb(pass::kCombined, x, y), cb = b.rgb(pass::kCombined, x, y);
      for (int c = 0; c < 3; ++c) ASSERT_EQ(ca[c], cb[c]) << x << "," << y;
    }
}

TEST(SpectralPhotons, CauchyBZeroIsCloseToRgbSppm) {
  // The prism with B = 0 (a dispersive-typed dielectric that does not disperse): spectral mode
  // forces spectral photons; its image mean is close to RGB SPPM's (the scene's colours are
  // grey, so only noise and the wavelength sampling differ).
  Scene s = load("prism.json", 40, 30);
  for (Material& m : s.materials)
    if (m.type == MaterialType::Dielectric) m.cauchy_b = 0.0f;
  Params sp;
  sp.set("photons", 50000);
  sp.set("spectral", "spectral");
  Params rgb = sp;
  rgb.set("spectral", "rgb");
  auto integ = make_integrator("sppm", s, sp);
  ASSERT_TRUE(dynamic_cast<Sppm&>(*integ).spectral());
  bool finite = false;
  const RGB m_sp = image_mean(render_with_seed(s, "sppm", 256, sp), &finite);
  const RGB m_rgb = image_mean(render_with_seed(s, "sppm", 256, rgb));
  EXPECT_TRUE(finite);
  std::printf("prism B=0 mean: spectral %.5f %.5f %.5f, rgb %.5f %.5f %.5f\n", m_sp[0], m_sp[1], m_sp[2], m_rgb[0],
              m_rgb[1], m_rgb[2]);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(m_sp[c] / m_rgb[c], 1.0, 0.02) << "channel " << c << ": " << m_sp[c] << " vs " << m_rgb[c];
}

TEST(SpectralPhotons, FewPassesThroughColouredPanesAgreeWithSpt) {
  // A pure red Transparent pane and a leaf (Mix of a diffuse and a green Transparent BSDF)
  // before a bluish World, lit by a sun, over a grey card (issue spsppm: red.json / panes.json).
  // Every pixel of a pass shares its wavelengths, so the image mean of a few passes is the
  // spectrum sampled at those passes' C x passes wavelengths. Before the fix, the first C passes
  // drew the same set (pass_wavelengths): after 4 passes the red mean's ratio to spt spread
  // over [-1.57, 3.65] in 20 seeds (sd 1.68; red.json: 0.13 for 0.34), and this test read
  // RMS 1.91 / 0.53 / 0.77 and negative means for seeds 1, 2 and 7. With 16 interleaved
  // wavelengths the RMS of (ratio - 1) over 40 seeds is 0.069 (R), 0.021 (G), 0.047 (B).
  // Bound: that RMS over 8 seeds below 0.25 per channel (3.6x the measured R), and no seed's
  // channel mean negative (spt's are 0.17, 0.37, 0.14).
  const Scene s = scene_from(R"({
    "camera": {"position": [0, 0, 12], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 32, "height": 24},
    "materials": {"red": {"type": "transparent", "color": [1, 0, 0]},
                  "leafbase": {"type": "diffuse", "color": [0.2, 0.6, 0.1]},
                  "tint": {"type": "transparent", "color": [0.2, 0.9, 0.4]},
                  "leaf": {"type": "mix", "factor": 0.5, "a": "leafbase", "b": "tint"},
                  "card": {"type": "diffuse", "color": 0.5}},
    "environment": {"color": [0.2, 0.5, 1], "strength": 1},
    "lights": [{"type": "sun", "direction": [0.4, 0.5, -0.77], "strength": 3}],
    "objects": [{"type": "quad", "center": [-1.5, 0, 2], "u": [3, 0, 0], "v": [0, 6, 0], "material": "red"},
                {"type": "quad", "center": [1.5, 0, 2], "u": [3, 0, 0], "v": [0, 6, 0], "material": "leaf"},
                {"type": "quad", "center": [0, -1, 0], "u": [4, 0, 0], "v": [0, 2, 0], "material": "card"}]})");
  const RGB ref = image_mean(render_with_seed(s, "spt", 1024, Params(nlohmann::json{{"seed", 7}})));
  Params check = photon_params(20000);
  check.set("spectral", "spectral");
  ASSERT_TRUE(dynamic_cast<Sppm&>(*make_integrator("sppm", s, check)).spectral());
  double sq[3] = {0, 0, 0};
  constexpr int kSeeds = 8;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    Params sp = photon_params(20000, seed);
    sp.set("spectral", "spectral");
    bool finite = false;
    const RGB m = image_mean(render_with_seed(s, "sppm", 4, sp), &finite);
    EXPECT_TRUE(finite);
    for (int c = 0; c < 3; ++c) {
      EXPECT_GE(m[c], 0.0f) << "seed " << seed << " channel " << c;
      sq[c] += (m[c] / ref[c] - 1.0) * (m[c] / ref[c] - 1.0);
    }
  }
  for (int c = 0; c < 3; ++c) {
    const double rms = std::sqrt(sq[c] / kSeeds);
    std::printf("panes, 4 passes: channel %d spt %.4f, RMS of sppm / spt - 1 over %d seeds %.3f\n", c, ref[c], kSeeds,
                rms);
    EXPECT_LT(rms, 0.25) << "channel " << c;
  }
}

}  // namespace
}  // namespace gp
