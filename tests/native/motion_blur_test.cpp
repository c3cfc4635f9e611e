// Motion blur (issue 33; thesis ch. 7): rays carry a shutter time, meshes move as Embree
// instances (quaternion-decomposed steps) or deform (vertex steps), area lights move with their
// meshes, and every method that declares motion_blur averages over the shutter: per camera path
// (pt, spt, gpt, sgpt), per pass shared by photons and eye paths (SPPM and the photon methods),
// as a chain coordinate (gdmlt).
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <cmath>
#include <string>

#include "render_for_tests.h"
#include "scene/builder.h"
#include "scene/loader.h"
#include "scene/scene.h"

namespace gp {
namespace {

// An emissive quad 4 m wide (radiance 1) moving +8 m along x across a black background, seen by
// an orthographic camera looking down with 1 m pixels: 16 columns x in [-8 + i, -7 + i].
// `extra` goes into the quad object ("motion" or "transform").
std::string sliding_quad(const std::string& motion) {
  return R"({
    "camera": {"type": "orthographic", "position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0],
               "ortho_scale": 16, "width": 16, "height": 16},
    "materials": {"glow": {"type": "emission", "emission": [1, 1, 1], "strength": 1, "two_sided": true}},
    "objects": [{"name": "slider", "type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 10, 0],
                 "material": "glow", )" + motion + R"(}]})";
}
const char* kSlide = R"("motion": [{"translate": [-4, 0, 0]}, {"translate": [4, 0, 0]}])";

// Time-averaged coverage of column i: overlap of [a, a + 1] with [c - 2, c + 2], c = -4 + 8 t,
// t uniform on the shutter (the overlap in closed form, integrated finely).
double column_coverage(int i) {
  const double a = -8.0 + i;
  const int n = 20000;
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    const double c = -4.0 + 8.0 * (k + 0.5) / n;
    sum += std::max(0.0, std::min(a + 1, c + 2) - std::max(a, c - 2));
  }
  return sum / n;
}

std::vector<double> column_means(const Film& f) {
  std::vector<double> m(f.width(), 0.0);
  for (int x = 0; x < f.width(); ++x) {
    for (int y = 0; y < f.height(); ++y) m[x] += f.rgb(pass::kCombined, x, y).g;
    m[x] /= f.height();
  }
  return m;
}

struct MethodCase {
  const char* method;
  int passes;
  double tolerance;  // on every column's mean (coverage in [0, 1])
};

// Each column's mean is its coverage averaged over the shutter. Noise: a column averages 16
// pixels x passes samples of variance <= 1/4; per-path methods draw a time per sample (sigma
// <= 0.5 / sqrt(16 * 256) = 0.008: tolerance 0.05 is 6 sigma), per-pass methods one time per
// pass for all pixels (the time's share of the variance: sigma <= 0.5 / sqrt(256) = 0.031;
// tolerance 0.15, about 5 sigma). A method that ignores time renders the frame's quad (columns
// 6..9 at 1, the rest 0): errors up to 0.75.
class SlidingQuad : public ::testing::TestWithParam<MethodCase> {};

TEST_P(SlidingQuad, ColumnsAverageTheCoverageOverTheShutter) {
  const MethodCase c = GetParam();
  Scene scene = scene_from(sliding_quad(kSlide));
  ASSERT_TRUE(scene.has_motion());
  Params p;
  p.set("seed", 7);
  if (std::string(c.method).find("pm") != std::string::npos || std::string(c.method) == "sppm-adaptive")
    p.set("photons", int64_t{2000});
  if (std::string(c.method) == "spt" || std::string(c.method) == "spt-hero" || std::string(c.method) == "sgpt")
    p.set("spectral", "spectral");
  const Film f = render(c.method, scene, c.passes, p);
  const std::vector<double> m = column_means(f);
  double mean = 0;
  for (int i = 0; i < 16; ++i) {
    EXPECT_NEAR(m[i], column_coverage(i), c.tolerance) << c.method << " column " << i;
    mean += m[i] / 16;
  }
  EXPECT_NEAR(mean, 0.25, 0.03) << c.method;  // the quad is always wholly in view: a quarter
}

INSTANTIATE_TEST_SUITE_P(
    Methods, SlidingQuad,
    ::testing::Values(MethodCase{"pt", 256, 0.05}, MethodCase{"spt", 256, 0.05}, MethodCase{"spt-hero", 256, 0.05},
                      MethodCase{"gpt", 256, 0.08}, MethodCase{"sgpt", 256, 0.08}, MethodCase{"sppm", 256, 0.15},
                      MethodCase{"sppm-adaptive", 256, 0.15}, MethodCase{"msppm", 256, 0.15},
                      MethodCase{"gpm", 256, 0.15}, MethodCase{"gdmlt", 256, 0.15}),
    [](const auto& info) {
      std::string n = info.param.method;
      for (char& ch : n)
        if (ch == '-') ch = '_';
      return n;
    });

// Every method declares what it renders; ppm alone keeps one instant (its measurement points are
// traced once) and says so.
TEST(MotionBlur, DeclarationsAndTheWarning) {
  for (const Method& m : methods())
    if (m.name.rfind("test-", 0) != 0) EXPECT_EQ(m.supports.motion_blur, m.name != "ppm") << m.name;
}

// A cube turning 90 degrees about z over the shutter is at 45 degrees mid-shutter and keeps its
// size (decomposed interpolation, as Cycles): its half-diagonal 0.707 reaches x = 0.6, where a
// linearly interpolated matrix (a cube shrunk by cos 45) would be missed. The hit is on the
// turned cube's face x + |y| = 0.707 and where the ray met it (hits and Embree agree).
TEST(MotionBlur, ARotatingCubeDoesNotShrink) {
  Scene scene = scene_from(R"({
    "camera": {"position": [0, -5, 0], "look_at": [0, 0, 0], "width": 8, "height": 8},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}},
    "lights": [{"type": "point", "position": [0, -3, 3], "power": 100}],
    "objects": [{"name": "cube", "type": "box", "min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5], "material": "grey",
                 "motion": [{"rotate": [0, 0, 0, 1]}, {"rotate": [90, 0, 0, 1]}]}]})");
  Ray ray(Vec3(0.6f, -5, 0.1f), Vec3(0, 1, 0));
  ray.time = 0.5f;
  const auto hit = scene.intersect(ray);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->p.x, 0.6f, 1e-4f);
  EXPECT_NEAR(hit->p.y, -(std::sqrt(0.5f) - 0.6f), 1e-4f);
  EXPECT_NEAR(length(hit->p - ray.at(hit->t)), 0.0f, 1e-4f);
  EXPECT_NEAR(std::abs(hit->ng.x), std::sqrt(0.5f), 1e-4f);  // the face turned 45 degrees
  ray.time = 0.0f;  // at shutter open it is the unturned cube: x = 0.6 passes by
  EXPECT_FALSE(scene.intersect(ray).has_value());
  // A point light's shadow test along the same line takes the ray's time as well.
  EXPECT_TRUE(scene.occluded(Ray(Vec3(0.6f, -5, 0.1f), Vec3(0, 1, 0), 0, 10)) == false);
  {
    const ShutterTime mid(0.5f);
    EXPECT_TRUE(scene.occluded(Ray(Vec3(0.6f, -5, 0.1f), Vec3(0, 1, 0), 0, 10)));
  }
}

// Deformation: vertices per step, interpolated linearly (Embree's vertex time steps).
TEST(MotionBlur, DeformingMeshHitsItsInterpolatedVertices) {
  Scene scene = scene_from(R"({
    "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "width": 4, "height": 4},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}},
    "lights": [{"type": "point", "position": [0, 0, 3], "power": 100}],
    "objects": [{"name": "sheet", "type": "mesh", "material": "grey",
                 "positions": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], "indices": [[0, 1, 2], [0, 2, 3]],
                 "motion_positions": [[-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0],
                                      [[-1, -1, 2], [1, -1, 2], [1, 1, 2], [-1, 1, 2]]]}]})");
  for (float t : {0.0f, 0.25f, 1.0f}) {
    Ray ray(Vec3(0.2f, 0.1f, 5), Vec3(0, 0, -1));
    ray.time = t;
    const auto hit = scene.intersect(ray);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->p.z, 2.0f * t, 1e-4f) << t;
  }
}

// Bad motion input is a SceneError naming the object, never a crash.
TEST(MotionBlur, BadMotionInputIsAClearError) {
  const auto error_of = [](const std::string& motion) {
    try {
      scene_from(sliding_quad(motion));
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of(R"("motion": [{"translate": [0, 0, 0]}])").find("at least 2"), std::string::npos);
  EXPECT_NE(error_of(R"("transform": {"translate": [1, 0, 0]}, "motion": [{"translate": [0, 0, 0]}, {"translate": [1, 0, 0]}])")
                .find("both 'transform' and 'motion'"),
            std::string::npos);
  EXPECT_NE(error_of(R"("motion": [{"scale": [1, 1, 1]}, {"matrix": [1,0,0,0, 0,0,0,0, 0,0,1,0, 0,0,0,1]}])").find("/objects/0/motion/1"),
            std::string::npos);
  try {
    scene_from(R"({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0]},
      "materials": {"grey": {"type": "diffuse", "color": 0.5}},
      "objects": [{"name": "sheet", "type": "mesh", "material": "grey",
                   "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "indices": [[0, 1, 2]],
                   "motion_positions": [[0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 0, 0, 1, 0, 0]]}]})");
    ADD_FAILURE() << "mismatched vertex counts accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("has 2 vertices but 'positions' has 3"), std::string::npos) << e.what();
  }
  // The builder (Python's SceneBuilder.add_mesh): one motion step, mismatched counts, NaN.
  SceneBuilder b("test");
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint32_t idx[3] = {0, 1, 2};
  MeshArrays in;
  in.name = "tri";
  in.positions = pos;
  in.vertex_count = 3;
  in.indices = idx;
  in.triangle_count = 1;
  in.materials = {"m"};
  in.motion = {{Transform()}};
  EXPECT_THROW(b.add_mesh(in), SceneError);
  in.motion = {{Transform(), Transform::translate(Vec3(std::nanf(""), 0, 0))}};
  EXPECT_THROW(b.add_mesh(in), SceneError);
}

// A scene without motion draws no time: its images are bit for bit what they were
// (scripts/image_check.py checks every method on every scene); here the flag and the camera.
TEST(MotionBlur, AStillSceneDrawsNoTime) {
  Scene scene = scene_from(sliding_quad(R"("transform": {"translate": [1, 0, 0]})"));
  EXPECT_FALSE(scene.has_motion());
  const PixelStart a = start_pixel(scene.camera, 3, 5, 2, 2);
  const PixelStart b = start_pixel(3, scene.camera.pixel_key(2, 2), 5, 2, 2, &scene.camera.filter);
  EXPECT_EQ(a.time, 0.0f);
  EXPECT_EQ(Rng(a.rng).uniform(), Rng(b.rng).uniform());
  // "Motion" whose steps are all equal is no motion.
  Scene still = scene_from(sliding_quad(R"("motion": [{"translate": [1, 0, 0]}, {"translate": [1, 0, 0]}])"));
  EXPECT_FALSE(still.has_motion());
}

// A light moving with its mesh, lighting a still floor only indirectly: a 1 m emissive quad
// facing up slides from x = -1 to x = +1 at 0.5 m, under a white ceiling at 1 m hidden from the
// camera; the floor sees the ceiling's bright patch. Averaged over the shutter the floor's light
// is symmetric. In SPPM that light is photons' (its eye paths' next-event estimation finds only
// the lamp's back): they must leave the lamp where it is at their pass's time, the same as its
// eye paths'; pt samples it at each path's time. pt's halves within 10 % of each other (noise
// of the indirect light, about 2 %); SPPM's within 15 % (one time per pass: the lamp's mean place
// over 512 passes deviates by 0.026 m); the totals within 10 %. Photons left at t = 0 make the
// left half far brighter.
TEST(MotionBlur, AMovingLightLightsTheFloorOverTheShutter) {
  Scene scene = scene_from(R"({
    "camera": {"type": "orthographic", "position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0],
               "ortho_scale": 4, "width": 16, "height": 16},
    "materials": {"white": {"type": "diffuse", "color": 0.8},
                  "ceiling": {"type": "diffuse", "color": 0.8, "visible_to_camera": false},
                  "lamp": {"type": "emission", "emission": [1, 1, 1], "strength": 10, "visible_to_camera": false}},
    "objects": [{"name": "floor", "type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"},
                {"name": "ceiling", "type": "quad", "center": [0, 0, 1], "u": [0, 2, 0], "v": [2, 0, 0], "material": "ceiling"},
                {"name": "lamp", "type": "quad", "center": [0, 0, 0.5], "u": [0.5, 0, 0], "v": [0, 0.5, 0], "material": "lamp",
                 "motion": [{"translate": [-1, 0, 0]}, {"translate": [1, 0, 0]}]}]})");
  const auto halves = [](const Film& f) {
    double l = 0, r = 0;
    for (int y = 0; y < f.height(); ++y)
      for (int x = 0; x < f.width(); ++x) (x < f.width() / 2 ? l : r) += f.rgb(pass::kCombined, x, y).g;
    return std::pair<double, double>(l, r);
  };
  Params pp;
  pp.set("seed", 3);
  const auto [pl, pr] = halves(render("pt", scene, 256, pp));
  Params sp = photon_params(4000, 3);
  const auto [sl, sr] = halves(render("sppm", scene, 512, sp));
  EXPECT_GT(pl + pr, 0.0);
  EXPECT_NEAR(pl / pr, 1.0, 0.1);
  EXPECT_NEAR(sl / sr, 1.0, 0.15);
  EXPECT_NEAR((sl + sr) / (pl + pr), 1.0, 0.1);
}

}  // namespace
}  // namespace gp
