// Auxiliary passes (integrators/aov): depth, normal and albedo at the first surface, through
// light objects (pass-through) and, for normal and albedo, through smooth mirrors and glass.
#include "integrators/aov.h"

#include <gtest/gtest.h>

#include "scene/loader.h"

namespace gp {
namespace {

RGB centre(const Film& f, std::string_view pass) {
  const Pass& p = f.pass(pass);
  const size_t i = (size_t(f.height() / 2) * f.width() + f.width() / 2) * p.channels;
  return p.channels == 3 ? RGB(p.data[i], p.data[i + 1], p.data[i + 2]) : RGB(p.data[i]);
}

TEST(Aov, FirstSurfaceThroughLightsAndMirrors) {
  // Camera 2 m above a grey floor (albedo 0.5) with a light object (pass-through, hidden from the
  // camera) 1 m above it: depth 2, normal +z, albedo 0.5.
  const Scene s = load_scene_from_string(R"({
    "camera": {"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 10, "width": 9, "height": 9},
    "materials": {"grey": {"type": "diffuse", "color": 0.5},
                  "lamp": {"type": "dielectric", "ior": 1, "emission": 1, "visible_to_camera": false, "casts_shadow": false},
                  "mirror": {"type": "conductor", "color": [0.9, 0.5, 0.2]}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "grey"},
                {"type": "quad", "center": [0, 0, 1], "u": [1, 0, 0], "v": [0, 1, 0], "material": "lamp"}]})",
                                         ".", "aov.json");
  AovEstimator aov(s, 1, 1);
  for (int i = 0; i < 4; ++i) aov.add_pass();
  Film film(9, 9);
  aov.develop(film);
  EXPECT_NEAR(centre(film, pass::kDepth).r, 2.0f, 1e-3f);
  EXPECT_NEAR(centre(film, pass::kNormal).b, 1.0f, 1e-4f);
  EXPECT_NEAR(centre(film, pass::kAlbedo).g, 0.5f, 1e-4f);
}

TEST(Aov, MirrorPassesNormalAndAlbedoOnWeightedByItsReflectance) {
  // A 45-degree smooth mirror in front of the camera shows a grey wall: depth is the mirror's,
  // normal and albedo the wall's, the albedo times the mirror's reflectance at 45 degrees.
  const Scene s = load_scene_from_string(R"({
    "camera": {"position": [0, -2, 0], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 5, "width": 9, "height": 9},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}, "mirror": {"type": "conductor", "color": 1}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [0.5, 0, 0], "v": [0, 0.3536, 0.3536], "material": "mirror"},
                {"type": "quad", "center": [0, 0, 3], "u": [5, 0, 0], "v": [0, -5, 0], "material": "grey"}]})",
                                         ".", "aov.json");
  AovEstimator aov(s, 1, 1);
  aov.add_pass();
  Film film(9, 9);
  aov.develop(film);
  EXPECT_NEAR(centre(film, pass::kDepth).r, 2.0f, 1e-2f);
  EXPECT_NEAR(centre(film, pass::kNormal).b, -1.0f, 1e-3f);
  EXPECT_NEAR(centre(film, pass::kAlbedo).g, 0.5f, 1e-3f);  // white mirror: F = 1
}

TEST(Aov, AlbedoOfANodeGraphIsEvaluatedAtTheHit) {
  // A floor whose Diffuse colour is the Geometry node's Position: the albedo pass at the centre
  // pixel is the point the camera sees there, (0.3, 0.6, 0), as in the image. (The albedo was
  // once re-evaluated from the hit's uv alone: position, normals and object coordinates read 0.)
  const Scene s = load_scene_from_string(R"({
    "camera": {"position": [0.3, 0.6, 2], "look_at": [0.3, 0.6, 0], "up": [0, 1, 0], "fov": 1, "width": 9, "height": 9},
    "materials": {"positional": {"type": "diffuse", "color": {"link": "geo", "output": "Position"},
                                 "nodes": {"geo": {"type": "ShaderNodeNewGeometry"}}}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "positional"}]})",
                                         ".", "aov.json");
  AovEstimator aov(s, 1, 1);
  aov.add_pass();
  Film film(9, 9);
  aov.develop(film);
  const RGB a = centre(film, pass::kAlbedo);
  EXPECT_NEAR(a.r, 0.3f, 2e-3f);
  EXPECT_NEAR(a.g, 0.6f, 2e-3f);
  EXPECT_NEAR(a.b, 0.0f, 1e-4f);
}

}  // namespace
}  // namespace gp
