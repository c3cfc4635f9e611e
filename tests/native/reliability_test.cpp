// Extreme but valid inputs (docs/reliability.md, "Long runs and resources"): every method ends
// in a finite image or the loader in a clear error. Emission up to the float range, IOR 1 and 10,
// roughness 0 and 1, zero-area and zero-power lights, degenerate cameras, and a 100 M-triangle
// request that does not fit. Non-finite contributions are discarded and counted
// (Stats::invalid_samples), never written to a pass.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include <fmt/format.h>

#include "integrators/methods.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// A closed grey box (inward walls) with a lamp quad under the ceiling, a sphere of `material`
// in the middle; `camera` and `extra` objects/lights spliced in as JSON.
std::string box_scene(const std::string& material, const std::string& lamp = R"({"type": "emission", "strength": 10})",
                      const std::string& camera = R"("position": [0, -2.5, 0], "look_at": [0, 0, 0], "fov": 50)",
                      const std::string& extra_objects = "", const std::string& lights = "[]") {
  return fmt::format(R"({{
    "camera": {{{camera}, "width": 12, "height": 9}},
    "materials": {{"grey": {{"type": "diffuse", "color": 0.6}}, "lamp": {lamp}, "subject": {material}}},
    "objects": [
      {{"type": "box", "min": [-3, -3, -3], "max": [3, 3, 3], "material": "grey"}},
      {{"type": "quad", "center": [0, 0, 2.9], "u": [0.5, 0, 0], "v": [0, -0.5, 0], "material": "lamp"}},
      {{"type": "sphere", "center": [0, 0, -0.5], "radius": 0.8, "segments": 12, "material": "subject"}}{extra_objects}],
    "lights": {lights}}})",
                     fmt::arg("camera", camera), fmt::arg("lamp", lamp), fmt::arg("material", material),
                     fmt::arg("extra_objects", extra_objects), fmt::arg("lights", lights));
}

// Every method, two passes: the image must be finite (NaN/Inf discarded and counted). A method
// may refuse the scene instead, with an error that contains `refusal` (empty: none may).
void expect_finite_for_every_method(const std::string& json, const std::string& what, const std::string& refusal = "") {
  Scene scene = load_scene_from_string(json, ".", what);
  for (const std::string& method : integrator_names()) {
    Stats stats;
    Film film;
    try {
      film = render(method, scene, 2, photon_params(3000, 1, 2), &stats);
    } catch (const std::exception& e) {
      EXPECT_FALSE(refusal.empty()) << what << ", method " << method << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(refusal), std::string::npos) << what << ", method " << method << ": " << e.what();
      continue;
    }
    const Pass& c = film.pass(pass::kCombined);
    size_t bad = 0;
    for (float v : c.data) bad += !std::isfinite(v);
    EXPECT_EQ(bad, 0u) << what << ", method " << method << ": " << bad << " non-finite values ("
                       << stats.invalid_samples << " invalid samples counted)";
    EXPECT_GE(stats.invalid_samples, 0) << method;
  }
}

TEST(ExtremeInputs, EmissionAtTheTopOfTheFloatRangeGivesFiniteImages) {
  expect_finite_for_every_method(box_scene(R"({"type": "diffuse", "color": 0.8})",
                                           R"({"type": "emission", "emission": 1, "strength": 1e30})"),
                                 "emission 1e30");
  expect_finite_for_every_method(box_scene(R"({"type": "dielectric", "ior": 1.5})",
                                           R"({"type": "emission", "emission": [3e38, 3e38, 3e38]})"),
                                 "emission 3e38");
}

TEST(ExtremeInputs, NonFiniteSamplesAreDiscardedAndCountedByEveryMethod) {
  // Inside a sphere emitting near FLT_MAX that also reflects: emission plus reflection
  // overflows to Inf. Every method must count such samples and keep them out of its passes.
  const Scene scene = load_scene_from_string(R"({
    "camera": {"position": [0, 0, 0], "look_at": [1, 0, 0], "fov": 60, "width": 8, "height": 8},
    "materials": {"hot": {"type": "diffuse", "color": 0.9, "emission": 1, "strength": 3e38, "two_sided": true}},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "segments": 12, "material": "hot"}]})",
                                             ".", "hot.json");
  for (const std::string& method : integrator_names()) {
    Stats stats;
    const Film film = render(method, scene, 2, photon_params(3000, 1, 2), &stats);
    EXPECT_GT(stats.invalid_samples, 0) << method << " counted no invalid sample";
    for (const auto& [name, pass] : film.passes()) {
      size_t bad = 0;
      for (float v : pass.data) bad += !std::isfinite(v);
      EXPECT_EQ(bad, 0u) << method << ", pass " << name;
    }
  }
}

TEST(ExtremeInputs, IorOneAndTenGiveFiniteImages) {
  expect_finite_for_every_method(box_scene(R"({"type": "dielectric", "ior": 1})"), "ior 1");
  expect_finite_for_every_method(box_scene(R"({"type": "dielectric", "ior": 10})"), "ior 10");
  expect_finite_for_every_method(box_scene(R"({"type": "dielectric", "ior": 10, "roughness": 1})"), "rough ior 10");
}

TEST(ExtremeInputs, RoughnessZeroAndOneGiveFiniteImages) {
  for (const char* m : {R"({"type": "conductor", "roughness": 0})", R"({"type": "conductor", "roughness": 1})",
                        R"({"type": "dielectric", "ior": 1.5, "roughness": 0})",
                        R"({"type": "dielectric", "ior": 1.5, "roughness": 1})"})
    expect_finite_for_every_method(box_scene(m), m);
}

TEST(ExtremeInputs, ZeroAreaAndZeroPowerLightsGiveFiniteImages) {
  // An emissive triangle of zero area (three collinear vertices), a point light of zero power,
  // a spot of the smallest size, a sun of zero strength.
  const std::string degenerate = R"(,
      {"type": "mesh", "name": "sliver", "positions": [[0, 0, 1], [1, 0, 1], [2, 0, 1]], "indices": [[0, 1, 2]],
       "material": "lamp"},
      {"type": "mesh", "name": "point", "positions": [[0, 1, 1], [0, 1, 1], [0, 1, 1]], "indices": [[0, 1, 2]],
       "material": "lamp"})";
  const std::string lights = R"([{"type": "point", "position": [0, 0, 1], "power": 0},
      {"type": "spot", "position": [0, 0, 2], "direction": [0, 0, -1], "power": 100, "spot_size": 1e-6, "spot_blend": 0},
      {"type": "sun", "direction": [0, 0, -1], "strength": 0}])";
  expect_finite_for_every_method(box_scene(R"({"type": "diffuse"})", R"({"type": "emission", "strength": 10})",
                                           R"("position": [0, -2.5, 0], "look_at": [0, 0, 0], "fov": 50)", degenerate, lights),
                                 "zero-area lights", "cannot reach point, spot or sun light '/lights/0'");
  // A scene whose only light has zero power: black but finite.
  expect_finite_for_every_method(box_scene(R"({"type": "diffuse"})", R"({"type": "emission", "strength": 0})"),
                                 "no light");
}

TEST(ExtremeInputs, DegenerateCamerasGiveFiniteImagesOrClearErrors) {
  for (const char* cam : {
           R"("position": [0, -2.5, 0], "look_at": [0, 0, 0], "fov": 1e-4)",
           R"("position": [0, -2.5, 0], "look_at": [0, 0, 0], "fov": 179.999)",
           R"("position": [0, -2.5, 0], "look_at": [0, 0, 0], "fov": 50, "aperture_radius": 1e6, "focus_distance": 1e-30)",
           R"("position": [0, 0, -0.5], "look_at": [0, 1, -0.5], "fov": 50)",  // inside the sphere (glass)
           R"("position": [0, -2.5, 0], "look_at": [0, -2.5, 1e-6], "up": [0, 1, 0])"})
    expect_finite_for_every_method(box_scene(R"({"type": "dielectric", "ior": 1.5})", R"({"type": "emission", "strength": 10})", cam),
                                   cam);
  // Cameras that cannot be built are clear errors naming the key.
  auto error_of = [](const std::string& cam) {
    try {
      load_scene_from_string(box_scene(R"({"type": "diffuse"})", R"({"type": "emission"})", cam), ".", "cam.json");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of(R"("position": [0, 0, 0], "look_at": [0, 0, 0])").find("cam.json: /camera/look_at"), std::string::npos);
  // A distance that underflows in single precision is the same as none.
  EXPECT_NE(error_of(R"("position": [0, -2.5, 0], "look_at": [0, -2.5, 1e-30])").find("/camera/look_at: look_at equals position"),
            std::string::npos);
  EXPECT_NE(error_of(R"("position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, 0, 1])").find("/camera/up"), std::string::npos);
  EXPECT_NE(error_of(R"("position": [0, 0, 0], "look_at": [0, 1, 0], "fov": 0)").find("/camera/fov"), std::string::npos);
  EXPECT_NE(error_of(R"("matrix": [1,0,0,0, 0,1,0,0, 0,0,0,0, 0,0,0,1])").find("/camera/matrix: the matrix is singular"),
            std::string::npos);
}

TEST(ExtremeInputs, HundredMillionTrianglesThatDoNotFitAreAClearError) {
  // Three tori of 4096 x 4096 segments: 100.7 M triangles, about 16 GB once built; with 1 GB
  // allowed the loader refuses before tessellating, naming the object and the numbers.
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "1024", 1);
  std::string objects;
  for (int i = 0; i < 3; ++i)
    objects += fmt::format(R"({}{{"type": "torus", "name": "t{}", "major_radius": 1, "minor_radius": 0.5,
        "segments_major": 4096, "segments_minor": 4096, "material": "m"}})", i ? "," : "", i);
  const std::string json = R"({"materials": {"m": {"type": "diffuse"}}, "objects": [)" + objects + "]}";
  std::string message = "no error";
  try {
    load_scene_from_string(json, ".", "big.json");
  } catch (const SceneError& e) {
    message = e.what();
  }
  unsetenv("GRADPHOTON_MEMORY_LIMIT_MB");
  EXPECT_NE(message.find("big.json: /objects/0: 't0' brings the scene's shapes to 33554432 triangles"), std::string::npos)
      << message;
  EXPECT_NE(message.find("GRADPHOTON_MEMORY_LIMIT_MB"), std::string::npos) << message;
  // Within the limit the same kind of request loads.
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "1024", 1);
  EXPECT_NO_THROW(load_scene_from_string(
      R"({"materials": {"m": {"type": "diffuse"}}, "objects": [{"type": "torus", "major_radius": 1, "minor_radius": 0.5,
          "segments_major": 256, "segments_minor": 256, "material": "m"}]})",
      ".", "small.json"));
  unsetenv("GRADPHOTON_MEMORY_LIMIT_MB");
}

TEST(ExtremeInputs, ObjFileThatIsNotARegularFileIsAClearError) {
  std::string message = "no error";
  try {
    load_scene_from_string(R"({"materials": {"m": {"type": "diffuse"}}, "objects": [{"type": "obj", "file": "/dev/zero",
        "material": "m"}]})", ".", "dev.json");
  } catch (const SceneError& e) {
    message = e.what();
  }
  EXPECT_EQ(message, "dev.json: /objects/0/file: OBJ file '/dev/zero' is not a regular file");
}

}  // namespace
}  // namespace gp
