// Failure cases named by the thesis (ch. 5-7) and the gradient-domain photon paper for photon
// density estimation, each a small scene: the output must stay finite and the error estimate
// sane. Plus: no lights at all, and memory that stays flat over hundreds of passes.
#include <gtest/gtest.h>

#include <malloc.h>

#include <cmath>
#include <string>

#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "scene/loader.h"

namespace gp {
namespace {

Scene scene_from(const std::string& json) { return load_scene_from_string(json, ".", "test.json"); }

struct Result {
  Film film;
  double error;
  double mean;
  Stats stats;
};

Result run(const Scene& s, const std::string& method, int passes, int64_t photons = 5000) {
  Params p;
  p.set("photons", photons);
  p.set("seed", 3);
  auto integ = make_integrator(method, s, p);
  run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  Result r;
  integ->develop(r.film);
  r.error = integ->estimated_error();
  r.stats = integ->stats();
  double sum = 0;
  for (float v : r.film.pass(pass::kCombined).data) sum += v;
  r.mean = sum / r.film.pass(pass::kCombined).data.size();
  return r;
}

void expect_finite_and_sane(const Result& r) {
  for (const auto& [name, p] : r.film.passes())
    for (float v : p.data) {
      ASSERT_TRUE(std::isfinite(v)) << "pass " << name;
      ASSERT_GE(v, 0.0f) << "pass " << name;
    }
  EXPECT_TRUE(std::isfinite(r.error)) << r.error;
  EXPECT_GT(r.error, 0.0);
  EXPECT_LT(r.error, 100.0);
}

const std::string kCamera = R"("camera": {"position": [0, -3.5, 1], "look_at": [0, 0, 0.8], "up": [0, 0, 1], "fov": 45, "width": 24, "height": 24})";

TEST(PhotonFailureCases, PhotonsGatheredOnGlossySurfaces) {
  // Conductor and dielectric just above the specular threshold: photons land on them and
  // are gathered through a spiky BSDF.
  const Scene s = scene_from("{" + kCamera + R"(,
    "materials": {"white": {"type": "diffuse", "color": 0.7},
                  "glossy": {"type": "conductor", "color": 0.9, "roughness": 0.06},
                  "frosted": {"type": "dielectric", "ior": 1.5, "roughness": 0.07},
                  "lamp": {"type": "emission", "emission": 1, "strength": 30}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "glossy"},
                {"type": "quad", "center": [0, 1, 1], "u": [2, 0, 0], "v": [0, 0, 1], "material": "white"},
                {"type": "sphere", "center": [0.3, 0, 0.4], "radius": 0.35, "segments": 24, "material": "frosted"},
                {"type": "quad", "center": [0, 0, 2], "u": [0, 0.2, 0], "v": [0.2, 0, 0], "material": "lamp"}]})");
  for (const char* method : {"sppm", "ppm"}) {
    const Result r = run(s, method, 12);
    SCOPED_TRACE(method);
    expect_finite_and_sane(r);
    EXPECT_GT(r.mean, 0.0);
  }
}

TEST(PhotonFailureCases, LightBehindAnAlmostClosedDoor) {
  // The lamp sits in a closed 1 m box whose front face leaves a 2 cm slit (the door): only
  // photons through the slit light the room the camera sees.
  const Scene s = scene_from("{" + kCamera + R"(,
    "materials": {"white": {"type": "diffuse", "color": 0.7},
                  "lamp": {"type": "emission", "emission": 1, "strength": 200}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "white"},
                {"type": "quad", "center": [0, 2, 1.5], "u": [3, 0, 0], "v": [0, 0, 1.5], "material": "white"},
                {"type": "quad", "center": [2, 1.5, 0.5], "u": [0, 0.5, 0], "v": [0, 0, 0.5], "material": "white"},
                {"type": "quad", "center": [1, 1.5, 0.5], "u": [0, 0.5, 0], "v": [0, 0, 0.5], "material": "white"},
                {"type": "quad", "center": [1.5, 1.5, 1.0], "u": [0.5, 0, 0], "v": [0, 0.5, 0], "material": "white"},
                {"type": "quad", "center": [1.5, 2.0, 0.5], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "material": "white"},
                {"type": "quad", "center": [1.5, 1.0, 0.51], "u": [0.5, 0, 0], "v": [0, 0, 0.49], "material": "white"},
                {"type": "quad", "center": [1.5, 1.5, 0.98], "u": [0, 0.1, 0], "v": [0.1, 0, 0], "material": "lamp"}]})");
  const Result r = run(s, "sppm", 16, 20000);
  expect_finite_and_sane(r);
  EXPECT_GT(r.mean, 0.0) << "light through the slit must arrive";
}

TEST(PhotonFailureCases, PointLightInsideAGlassSphere) {
  // Next-event estimation is blocked by the glass: all light on the floor is a caustic path.
  const Scene s = scene_from("{" + kCamera + R"(,
    "materials": {"white": {"type": "diffuse", "color": 0.7}, "glass": {"type": "dielectric", "ior": 1.5}},
    "lights": [{"type": "point", "position": [0, 0, 1], "intensity": 20}],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"},
                {"type": "sphere", "center": [0, 0, 1], "radius": 0.3, "segments": 24, "material": "glass"}]})");
  const Result r = run(s, "sppm", 16, 10000);
  expect_finite_and_sane(r);
  EXPECT_GT(r.mean, 0.0);
}

TEST(PhotonFailureCases, NoLightsGivesABlackImageAWarningAndNoHang) {
  for (const std::string objects : {"", R"(, "materials": {"white": {"type": "diffuse"}},
        "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"}])"}) {
    const Scene s = scene_from("{" + kCamera + objects + "}");
    Params p;
    auto integ = make_integrator("sppm", s, p);
    // A target error alone must stop: black is the exact answer, so the estimate is 0.
    run_progressive(*integ, StopRule{0, 0, 0.01}, nullptr);
    EXPECT_EQ(integ->stats().passes, 1);
    EXPECT_EQ(integ->estimated_error(), 0.0);
    EXPECT_EQ(integ->stats().extra.count("warning: no lights"), 1u);
    Film f;
    integ->develop(f);
    for (float v : f.pass(pass::kCombined).data) EXPECT_EQ(v, 0.0f);
  }
}

// Bytes the program holds through malloc, over all arenas (glibc). Resident size would also
// count the allocator's and the thread pool's caches, which vary from run to run.
long heap_kib() { return static_cast<long>(mallinfo2().uordblks / 1024); }

TEST(PhotonMemory, StaysFlatOverHundredsOfPasses) {
  // Photons of a pass are discarded (capacity reused): the heap after 300 passes is what it
  // was after 30.
  Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-glass.json");
  s.camera.width = s.camera.height = 16;
  Params p;
  p.set("photons", 4000);
  auto integ = make_integrator("sppm", s, p);
  run_progressive(*integ, StopRule{0, 30, 0}, nullptr);
  const long after30 = heap_kib();
  run_progressive(*integ, StopRule{0, 300, 0}, nullptr);
  const long after300 = heap_kib();
  EXPECT_EQ(integ->stats().passes, 300);
  EXPECT_LT(after300 - after30, 1024) << "KiB grew from " << after30 << " to " << after300;
}

}  // namespace
}  // namespace gp
