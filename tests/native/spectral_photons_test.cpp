// Spectral photons (SPPM with one wavelength set per pass, docs/spectral.md "Spectral photons"):
// agreement with a long spt-hero reference on the prism, the RGB image unchanged in auto mode on
// a scene without dispersion, Cauchy B = 0 in spectral mode close to RGB SPPM, finite output.
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

}  // namespace
}  // namespace gp
