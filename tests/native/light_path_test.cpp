// Light Path fields filled by the integrators (core/math.h RayState, Cycles' path_state_next):
// the state's rules, and renders where a material reads them: an emitter seen only by camera
// rays (the common "Is Camera Ray" trick), and Ray Depth seen directly and through a mirror.
#include <gtest/gtest.h>

#include "render_for_tests.h"
#include "scene/loader.h"

namespace gp {
namespace {

TEST(LightPath, RayStateFollowsCyclesPathStateNext) {
  const RayState cam = RayState::camera();
  EXPECT_EQ(cam.flags, kPathCamera);
  // A diffuse reflection: one bounce, a diffuse reflection ray, no longer a camera ray.
  const RayState d = next_ray_state(cam, kRayDiffuse, false, false, 1.0f);
  EXPECT_EQ(d.flags, kPathDiffuse | kPathReflection);
  EXPECT_EQ(d.depth, 1);
  EXPECT_EQ(d.diffuse, 1);
  // Then a smooth refraction: glossy + singular + transmission, a transmission bounce.
  const RayState t = next_ray_state(d, kRayTransmission, true, true, 1.5f);
  EXPECT_EQ(t.flags, kPathGlossy | kPathSingular | kPathTransmission);
  EXPECT_EQ(t.depth, 2);
  EXPECT_EQ(t.transmission, 1);
  EXPECT_EQ(t.diffuse, 1);
  // A rough reflection: glossy.
  EXPECT_EQ(next_ray_state(t, kRayGlossy, false, false, 1.0f).glossy, 1);
  // A Transparent BSDF's pass (smooth, IOR 1): flags kept, a transparent bounce, depth kept.
  const RayState p = next_ray_state(cam, kRayTransmission, true, true, 1.0f);
  EXPECT_EQ(p.flags, kPathCamera);
  EXPECT_EQ(p.depth, 0);
  EXPECT_EQ(p.transparent, 1);
}

// A diffuse floor (the furnace quad) under a two-sided emitter at z = 0.5 whose strength is the
// Light Path output `output` times 2; a black World.
Scene emitter_scene(const std::string& strength) {
  const std::string emitter = R"({"type": "emission", "emission": [1, 1, 1], "two_sided": true,
    "strength": )" + strength + R"(, "nodes": {"lp": {"type": "ShaderNodeLightPath"},
      "m": {"type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
            "inputs": {"Value": {"link": "lp", "output": "Is Camera Ray"}, "Value_001": 2.0}}}})";
  std::string json = furnace_scene(R"({"type": "diffuse", "color": 0.8})",
                                   R"(, {"type": "mesh", "positions": [[-0.15, -0.15, 0.5], [0.15, -0.15, 0.5],
      [0.15, 0.15, 0.5], [-0.15, 0.15, 0.5]], "indices": [[0, 1, 2], [0, 2, 3]], "material": "e"})");
  const std::string size = R"("width": 16, "height": 16)";
  json.replace(json.find(size), size.size(), R"("width": 64, "height": 64)");
  const std::string white = R"("color": [1, 1, 1], "strength": 1)";
  json.replace(json.find(white), white.size(), R"("color": [0, 0, 0], "strength": 0)");
  json.replace(json.find(R"("materials": {)"), 14, R"("materials": {"e": )" + emitter + ", ");
  return load_scene_from_string(json, ".", "camera-only.json");
}

// Mean green over pixels [x0, x1) x [y0, y1).
float region(const Film& f, int x0, int x1, int y0, int y1) {
  double s = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) s += f.rgb(pass::kCombined, x, y).g;
  return static_cast<float>(s / ((x1 - x0) * (y1 - y0)));
}
float centre(const Film& f) { return region(f, f.width() / 2 - 3, f.width() / 2 + 3, f.height() / 2 - 3, f.height() / 2 + 3); }

TEST(LightPath, EmitterSeenOnlyByCameraRaysLightsNothing) {
  for (const char* method : {"pt", "spt"}) {
    const Film camera_only = render(method, emitter_scene(R"({"link": "m", "output": "Value"})"), 16, Params());
    const Film constant = render(method, emitter_scene("2.0"), 16, Params());
    // The camera sees the emitter at the centre either way: radiance 2 in RGB (the spectral
    // path's white differs from RGB white by its upsampling: compared with the constant).
    if (std::string(method) == "pt") EXPECT_NEAR(centre(camera_only), 2.0f, 0.02f);
    EXPECT_GT(centre(constant), 1.0f) << method;
    EXPECT_NEAR(centre(camera_only), centre(constant), 0.02f * centre(constant)) << method;
    // The floor's corner: lit by the constant emitter, black under the camera-only one (neither
    // next-event estimation, which evaluates the emission with no path flags, nor diffuse rays
    // that meet it see it). Measured: ~0.1 lit.
    EXPECT_GT(region(constant, 2, 12, 2, 12), 0.01f) << method;
    EXPECT_LT(region(camera_only, 2, 12, 2, 12), 1e-5f) << method;
  }
}

TEST(LightPath, RayDepthThroughAMirror) {
  // An emitter whose strength is Ray Depth + 1 (seen directly: 1), and its image in a smooth
  // mirror (the ray that meets it has depth 1: 2) -- camera above the mirror quad at z = 0,
  // the emitter a ring-free plate at z = 1.5 facing down, seen only in the mirror.
  const std::string emitter = R"({"type": "emission", "emission": [1, 1, 1], "two_sided": true,
    "strength": {"link": "m", "output": "Value"},
    "nodes": {"lp": {"type": "ShaderNodeLightPath"},
      "m": {"type": "ShaderNodeMath", "props": {"operation": "ADD"},
            "inputs": {"Value": {"link": "lp", "output": "Ray Depth"}, "Value_001": 1.0}}}})";
  std::string json = furnace_scene(R"({"type": "conductor", "color": [1, 1, 1], "fresnel": "none", "roughness": 0})",
                                   R"(, {"type": "mesh", "positions": [[-4, -4, 3.5], [4, -4, 3.5],
      [4, 4, 3.5], [-4, 4, 3.5]], "indices": [[0, 1, 2], [0, 2, 3]], "material": "e"})");
  const std::string white = R"("color": [1, 1, 1], "strength": 1)";
  json.replace(json.find(white), white.size(), R"("color": [0, 0, 0], "strength": 0)");
  json.replace(json.find(R"("materials": {)"), 14, R"("materials": {"e": )" + emitter + ", ");
  // The camera (z = 3) is below the emitter plate (z = 3.5) and looks down at the mirror.
  const Film f = render("pt", load_scene_from_string(json, ".", "depth.json"), 4, Params());
  EXPECT_NEAR(centre(f), 2.0f, 0.02f);
}

}  // namespace
}  // namespace gp
