// Light emission sampling and photon tracing (flat-shaded enclosures, so that every bounce
// multiplies the power by exactly the albedo): the power a photon pass deposits must equal the
// lights' emitted power times the albedo series of the scene, for every light type.
#include <gtest/gtest.h>

#include <string>

#include "integrators/photon/photon_tracer.h"
#include "scene/loader.h"

namespace gp {
namespace {

Scene scene_from(const std::string& json) { return load_scene_from_string(json, ".", "test.json"); }

// Sum of deposited power over the photons of one pass, divided by the photons emitted.
RGB deposited_power(const Scene& s, int64_t photons, int max_depth = 64, int min_bounce = 0, int threads = 0) {
  PhotonTracer tracer(s, max_depth, kDefaultSpecularThreshold, 7, threads);
  std::vector<Photon> out;
  const PhotonPassStats st = tracer.trace(photons, 0, min_bounce, out);
  EXPECT_EQ(st.emitted, photons);
  EXPECT_EQ(st.stored, static_cast<int64_t>(out.size()));
  double sum[3] = {0, 0, 0};
  for (const Photon& p : out)
    for (int c = 0; c < 3; ++c) sum[c] += p.power[c];
  return RGB(float(sum[0] / photons), float(sum[1] / photons), float(sum[2] / photons));
}

const char* kSphere = R"("camera": {"position": [0, 0, 0], "look_at": [1, 0, 0], "width": 8, "height": 8},
  "materials": {"wall": {"type": "diffuse", "color": 0.5}},
  "objects": [{"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "wall"})";

TEST(PhotonTracer, PointLightInClosedDiffuseBoxDepositsPowerOverOneMinusAlbedo) {
  // Every deposit absorbs 1 - a of what arrives: total deposited = P (1 + a + a^2 + ...) = P / (1 - a).
  const Scene s = scene_from(std::string("{") + kSphere + R"(],
    "lights": [{"type": "point", "position": [0.1, 0, 0], "intensity": 2}]})");
  const RGB d = deposited_power(s, 200000);
  const double expected = 4 * M_PI * 2 / (1 - 0.5);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(d[c], expected, 0.01 * expected) << "channel " << c;
}

TEST(PhotonTracer, SpotLightPowerFollowsTheCyclesFalloff) {
  // Falloff = cos to the axis inside the cone (no blend): power = I * pi * (1 - cos_half^2).
  const Scene s = scene_from(std::string("{") + kSphere + R"(],
    "lights": [{"type": "spot", "position": [0, 0, 0], "direction": [0, 0, -1], "spot_size": 60, "spot_blend": 0, "intensity": 3}]})");
  const double ch = std::cos(30.0 * M_PI / 180.0);
  const double expected = 3 * M_PI * (1 - ch * ch) / (1 - 0.5);
  EXPECT_NEAR(deposited_power(s, 200000).g, expected, 0.01 * expected);
}

TEST(PhotonTracer, AreaLightsOneAndTwoSided) {
  // An emissive diffuse quad (albedo a) inside the box: P = Le pi A per emitting side.
  for (bool two_sided : {false, true}) {
    const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 0], "look_at": [1, 0, 0], "width": 8, "height": 8},
      "materials": {"wall": {"type": "diffuse", "color": 0.5},
                    "lamp": {"type": "diffuse", "color": 0.5, "emission": 1, "strength": 2, "two_sided": )" +
                               std::string(two_sided ? "true" : "false") + R"(}},
      "objects": [{"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "wall"},
                  {"type": "quad", "center": [0, 0, 0.5], "u": [0.1, 0, 0], "v": [0, 0.1, 0], "material": "lamp"}]})");
    const double expected = 2 * M_PI * 0.04 * (two_sided ? 2 : 1) / (1 - 0.5);
    EXPECT_NEAR(deposited_power(s, 200000).g, expected, 0.01 * expected) << "two_sided " << two_sided;
  }
}

TEST(PhotonTracer, SunAndEnvironmentCoverTheScene) {
  // First hits only (max_depth 1). Sun at 60 degrees on a 2 x 2 m plane: E A cos 60.
  const std::string plane = R"("camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "width": 8, "height": 8},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "grey"}])";
  const Scene sun = scene_from("{" + plane + R"(, "lights": [{"type": "sun", "direction": [0.8660254, 0, -0.5], "irradiance": 3}]})");
  EXPECT_NEAR(deposited_power(sun, 400000, 1).g, 3 * 4 * 0.5, 0.01 * 6);
  // Constant environment L: each face of the plane receives pi L A.
  const Scene env = scene_from("{" + plane + R"(, "environment": {"color": 2}})");
  const double expected = 2 * M_PI * 2 * 4;
  EXPECT_NEAR(deposited_power(env, 400000, 1).g, expected, 0.015 * expected);
}

TEST(PhotonTracer, SkippingDirectDepositsRemovesTheFirstTerm) {
  // min_deposit_bounce 1: P (a + a^2 + ...) = P a / (1 - a).
  const Scene s = scene_from(std::string("{") + kSphere + R"(],
    "lights": [{"type": "point", "position": [0, 0, 0], "intensity": 2}]})");
  const double expected = 4 * M_PI * 2 * 0.5 / (1 - 0.5);
  EXPECT_NEAR(deposited_power(s, 200000, 64, 1).g, expected, 0.015 * expected);
}

TEST(PhotonTracer, SamePhotonsWhateverTheThreadCount) {
  Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-glass.json");
  std::vector<Photon> a, b;
  PhotonTracer(s, 32, kDefaultSpecularThreshold, 3, 1).trace(20000, 5, 0, a);
  PhotonTracer(s, 32, kDefaultSpecularThreshold, 3, 2).trace(20000, 5, 0, b);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 10000u);
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].p.x, b[i].p.x);
    ASSERT_EQ(a[i].power.g, b[i].power.g);
  }
}

TEST(PhotonTracer, NoLightsNoPhotons) {
  const Scene s = scene_from(std::string("{") + kSphere + "]}");
  std::vector<Photon> out(5);
  PhotonTracer tracer(s, 8, kDefaultSpecularThreshold, 0, 0);
  EXPECT_EQ(tracer.trace(1000, 0, 0, out).stored, 0);
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace gp
