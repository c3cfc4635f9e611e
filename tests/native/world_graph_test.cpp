// The World's node graph as a light (lights/world_graph.h) and a Sky turned by a Mapping
// (lights/background.h TransformedBackground): per-direction, per-ray evaluation against the
// closed forms of small graphs (a Gradient as a Mix factor, Light Path through Math), the baked
// sampler against its density (chi-square), and renders: a graph of constants is the constant
// World, a camera-only background lights nothing, a turned sky lights a floor as the sky does.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "environment_test_util.h"
#include "lights/sky.h"
#include "lights/world_graph.h"
#include "render_for_tests.h"

namespace gp {
namespace {

const char* kFloor = R"("camera": {"position": [0, -4, 1.5], "look_at": [0, 0, 0.4], "fov": 40, "width": 16, "height": 16},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "grey"}])";

Scene floor_under(const std::string& env) { return scene_from(std::string("{") + kFloor + R"(, "environment": )" + env + "}"); }

const BackgroundTerm& env_map(const Scene& s) { return *s.light_set().lights()[s.light_set().environment()].map; }

// Mix of a blue and an orange Background by a linear Gradient of the direction (Generated =
// the direction: factor x, clamped to [0, 1] by the Mix), camera rays seeing white instead
// through 1 - Is Camera Ray (Math SUBTRACT) on an outer Mix.
const char* kGradientWorld = R"({"type": "graph", "sampling_resolution": 256,
  "surface": {"type": "mix", "factor": {"link": "inv", "output": "Value"},
              "a": {"type": "background", "color": [1, 1, 1], "strength": 2},
              "b": {"type": "mix", "factor": {"link": "grad", "output": "Fac"},
                    "a": {"type": "background", "color": [0.1, 0.2, 0.9], "strength": 1},
                    "b": {"type": "background", "color": [0.9, 0.4, 0.1], "strength": 3}}},
  "nodes": {"grad": {"type": "ShaderNodeTexGradient", "props": {"gradient_type": "LINEAR"}},
            "lp": {"type": "ShaderNodeLightPath"},
            "inv": {"type": "ShaderNodeMath", "props": {"operation": "SUBTRACT"},
                    "inputs": {"Value": 1.0, "Value_001": {"link": "lp", "output": "Is Camera Ray"}}}}})";

RGB gradient_world(const Vec3& d) {
  const float f = std::clamp(d.x, 0.0f, 1.0f);
  return RGB(0.1f, 0.2f, 0.9f) * (1 - f) + RGB(0.9f, 0.4f, 0.1f) * 3.0f * f;
}

TEST(WorldGraph, EvaluatesPerDirectionAndRay) {
  const Scene s = floor_under(kGradientWorld);
  const BackgroundTerm& w = env_map(s);
  Rng rng(3, 0);
  RayState diffuse;
  diffuse.flags = kPathReflection | kPathDiffuse;
  for (int i = 0; i < 200; ++i) {
    const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
    const RGB want = gradient_world(d), light = w.eval(d), bounce = w.eval(d, diffuse);
    const RGB camera = w.eval(d, RayState::camera());
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(light[k], want[k], 1e-5f * (1 + want[k]));
      EXPECT_NEAR(bounce[k], want[k], 1e-5f * (1 + want[k]));
      EXPECT_NEAR(camera[k], 2.0f, 1e-6f);
    }
  }
  // The light's power: the integral of the light samples' World.
  double sum[3] = {0, 0, 0};
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const RGB c = gradient_world(sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform())));
    for (int k = 0; k < 3; ++k) sum[k] += c[k] * 4 * M_PI / n;
  }
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(w.integral()[k] / sum[k], 1.0, 0.01) << k;
}

TEST(WorldGraph, SamplesFollowTheirDensityAndCoverTheWorld) {
  const Scene s = floor_under(kGradientWorld);
  const BackgroundTerm& w = env_map(s);
  const Chi2Result r = chi2_of(w, 200000, 24, 48, 12);
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_GT(r.p_value, 1e-4) << "chi2 " << r.statistic << " dof " << r.dof;
  EXPECT_NEAR(r.pdf_integral, 1.0, 0.01);
  Rng rng(5, 0);
  int brighter = 0, n = 0;
  for (int i = 0; i < 20000; ++i) {
    Vec3 d;
    float pdf;
    ASSERT_TRUE(w.sample(Vec2(rng.uniform(), rng.uniform()), &d, &pdf));
    ASSERT_NEAR(w.pdf(d) / pdf, 1.0f, 2e-3f);
    brighter += d.x > 0;
    ++n;
  }
  EXPECT_GT(double(brighter) / n, 0.7);  // importance: the orange side carries most of the light
  for (int i = 0; i < 20000; ++i) {
    const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
    ASSERT_GT(w.pdf(d), 0.0f);
  }
}

TEST(WorldGraph, ConstantGraphRendersAsTheConstantWorld) {
  Params p;
  p.set("seed", 2);
  const RGB graph = image_mean(render("pt", floor_under(R"({"type": "graph", "nodes": {},
      "surface": {"type": "add", "a": {"type": "background", "color": [0.2, 0.3, 0.4], "strength": 2},
                                 "b": {"type": "background", "color": [0.1, 0.1, 0.1]}}})"), 64, p));
  const RGB constant = image_mean(render("pt", floor_under(R"({"color": [0.5, 0.7, 0.9]})"), 64, p));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(graph[k] / constant[k], 1.0, 0.01) << k;
  // A World that only camera rays see lights nothing: the floor is black, the sky white.
  const Scene cam = floor_under(R"({"type": "graph", "surface": {"type": "background", "color": [1, 1, 1],
      "strength": {"link": "lp", "output": "Is Camera Ray"}}, "nodes": {"lp": {"type": "ShaderNodeLightPath"}}})");
  const Film f = render("pt", cam, 8, p);
  const RGB m = image_mean(f);
  EXPECT_GT(m.g, 0.05);
  EXPECT_LT(m.g, 0.95);  // the floor (most of the frame) is black, the sky above it white
}

TEST(WorldGraph, BadGraphsAreClearErrors) {
  auto error_of = [](const std::string& env) {
    try {
      floor_under(env);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of(R"({"type": "graph", "nodes": {}})").find("surface"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "graph", "nodes": {}, "surface": {"type": "emission"}})").find("unknown World closure"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"type": "graph", "nodes": {}, "surface": {"type": "mix", "a": {"type": "background"}}})").find("missing required key 'b'"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"type": "graph", "nodes": {}, "surface": {"type": "background",
      "color": {"link": "nope", "output": "Color"}}})").find("nope"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "graph", "nodes": {}, "color": 1, "surface": {"type": "background"}})").find("surface"),
            std::string::npos);
  std::string deep = R"({"type": "background"})";
  for (int i = 0; i < 70; ++i) deep = R"({"type": "add", "a": {"type": "background"}, "b": )" + deep + "}";
  EXPECT_NE(error_of(R"({"type": "graph", "nodes": {}, "surface": )" + deep + "}").find("deeper"), std::string::npos);
}

// ---- A Sky Texture turned by a Mapping (its Vector through Texture Coordinate -> Mapping) ----

TEST(TransformedSky, LooksUpTheTurnedDirectionAndSamplesItsDensity) {
  SkyOptions o;
  o.sun_elevation = 30 * kPi / 180;
  o.sun_size = 3 * kPi / 180;
  const auto sky = std::make_shared<SkyTexture>(o);
  // Rz(50 degrees) Rx(10 degrees) scaled by (1, 1.5, 1) (Mapping Point: R S v).
  const float cz = std::cos(0.8727f), sz = std::sin(0.8727f), cx = std::cos(0.1745f), sx = std::sin(0.1745f);
  const float m[3][3] = {{cz, -sz * cx * 1.5f, sz * sx}, {sz, cz * cx * 1.5f, -cz * sx}, {0, sx * 1.5f, cx}};
  const TransformedBackground t(sky, m);
  Rng rng(7, 0);
  for (int i = 0; i < 100; ++i) {
    const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
    const Vec3 v = normalize(Vec3(m[0][0] * d.x + m[0][1] * d.y + m[0][2] * d.z, m[1][0] * d.x + m[1][1] * d.y + m[1][2] * d.z,
                                  m[2][0] * d.x + m[2][1] * d.y + m[2][2] * d.z));
    EXPECT_NEAR(t.eval(d).g, sky->eval(v).g, 1e-6f * (1 + sky->eval(v).g));
  }
  const Chi2Result r = chi2_of(t, 200000, 24, 48, 40);
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_GT(r.p_value, 1e-4) << "chi2 " << r.statistic << " dof " << r.dof;
  EXPECT_NEAR(r.pdf_integral, r.accepted_fraction, 0.01);
  for (int i = 0; i < 20000; ++i) {
    Vec3 d;
    float pdf;
    if (!t.sample(Vec2(rng.uniform(), rng.uniform()), &d, &pdf)) continue;
    ASSERT_NEAR(t.pdf(d) / pdf, 1.0f, 2e-3f);
  }
}

TEST(TransformedSky, ARotatedSkyLightsTheFloorAsTheSkyDoes) {
  // A rotation about Z leaves a floor's irradiance unchanged: means within 1 % (pt, 64 passes),
  // the sun's cone sampled through the transform.
  Params p;
  p.set("seed", 4);
  p.set("max_depth", 2);
  // (The sky itself hidden from the camera: only the floor's light is compared.)
  const RGB plain = image_mean(render("pt", floor_under(R"({"type": "sky", "sun_elevation": 40, "strength": 1e-4,
      "visible_to_camera": false})"), 64, p));
  const RGB turned = image_mean(render("pt", floor_under(R"({"type": "sky", "sun_elevation": 40, "strength": 1e-4,
      "visible_to_camera": false, "transform": [[0.5, -0.8660254, 0], [0.8660254, 0.5, 0], [0, 0, 1]]})"), 64, p));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(turned[k] / plain[k], 1.0, 0.01) << k;
}

}  // namespace
}  // namespace gp
