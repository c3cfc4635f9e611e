// Tests for native/scene/shapes (tessellated analytic shapes) and native/scene/loader (the
// JSON scene format of docs/scene-format.md): the bundled scenes, shape geometry, and that
// every kind of bad input fails with a message naming the file and the JSON path.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "core/spectrum.h"
#include "scene/loader.h"
#include "scene/shapes.h"

namespace gp {
namespace {

namespace fs = std::filesystem;

const std::string kScenes = std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/";

Vec3 triangle_normal(const Mesh& m, size_t t) {
  const Vec3 &a = m.positions[m.indices[3 * t]], &b = m.positions[m.indices[3 * t + 1]],
             &c = m.positions[m.indices[3 * t + 2]];
  return cross(b - a, c - a);
}
Vec3 triangle_centroid(const Mesh& m, size_t t) {
  return (m.positions[m.indices[3 * t]] + m.positions[m.indices[3 * t + 1]] + m.positions[m.indices[3 * t + 2]]) / 3.0f;
}

// Closed and consistently oriented: every directed edge appears exactly once and its reverse
// exactly once, so every undirected edge is shared by exactly two triangles.
::testing::AssertionResult closed_and_oriented(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) ++directed[{m.indices[3 * t + k], m.indices[3 * t + (k + 1) % 3]}];
  for (const auto& [e, n] : directed) {
    if (n != 1) return ::testing::AssertionFailure() << "edge " << e.first << "->" << e.second << " used " << n << " times";
    auto rev = directed.find({e.second, e.first});
    if (rev == directed.end())
      return ::testing::AssertionFailure() << "edge " << e.first << "-" << e.second << " has only one triangle";
  }
  return ::testing::AssertionSuccess();
}

size_t area_light_count(const Scene& s) {
  size_t n = 0;
  for (const Light& l : s.light_set().lights()) n += l.type == LightType::Area;
  return n;
}
float total_light_power(const Scene& s) {
  float p = 0;
  for (size_t i = 0; i < s.light_set().lights().size(); ++i) p += s.light_set().power(static_cast<int>(i));
  return p;
}
const Mesh& mesh_named(const Scene& s, const std::string& name) {
  for (const Mesh& m : s.meshes)
    if (m.name == name) return m;
  throw std::runtime_error("no mesh " + name);
}
std::string warnings_text(const Scene& s) {
  std::string out;
  for (const std::string& line : s.warnings.summary()) out += line + "\n";
  return out;
}

// The message of the SceneError thrown by f, or a note that none was thrown.
std::string scene_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const SceneError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("<not a SceneError: ") + e.what() + ">";
  }
  return "<no error>";
}

// A small valid scene around `objects` (a JSON array body) with two materials and a light.
std::string scene_text(const std::string& objects, const std::string& extra = "") {
  return R"({"camera": {"position": [0, -5, 1], "look_at": [0, 0, 1], "width": 16, "height": 16},
    "materials": {"white": {"type": "diffuse", "color": 0.8}, "glass": {"type": "dielectric", "ior": 1.5}},
    "lights": [{"type": "point", "position": [0, 0, 5], "power": 100}],
    "objects": [)" + objects + "]" + extra + "}";
}
Scene from_text(const std::string& text, const std::string& name = "inline.json", const std::string& base = ".") {
  return load_scene_from_string(text, base, name);
}

// A fresh directory per test (tests of this executable may run in parallel under CTest).
class SceneLoaderFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("gradphoton_scene_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  fs::path dir_;
};

// ---- The bundled scenes ----

TEST(Scenes, CornellBoxLoadsWithInwardWallsAndNoWarnings) {
  const Scene s = load_scene(kScenes + "cornell-box.json");
  EXPECT_TRUE(s.finalized());
  EXPECT_TRUE(s.warnings.empty()) << warnings_text(s);
  EXPECT_EQ(s.source, kScenes + "cornell-box.json");
  EXPECT_EQ(s.triangle_count(), 36u);  // 5 walls + light: 12, two boxes: 24
  EXPECT_EQ(s.meshes.size(), 8u);
  EXPECT_EQ(s.materials.size(), 4u);
  EXPECT_TRUE(s.lights.empty());
  EXPECT_EQ(area_light_count(s), 2u);
  EXPECT_EQ(s.light_set().lights().size(), 2u);
  EXPECT_EQ(s.camera.width, 512);
  EXPECT_EQ(s.camera.height, 512);
  EXPECT_FLOAT_EQ(s.camera.fov_degrees, 39.3f);
  EXPECT_NEAR(length(s.camera.position() - Vec3(0, -3.9f, 1)), 0.0f, 1e-6f);
  // Every wall faces into the room; the light faces down from just below the ceiling.
  const Vec3 room_center{0, 0, 1};
  for (const char* wall : {"floor", "ceiling", "back wall", "left wall", "right wall"}) {
    const Mesh& m = mesh_named(s, wall);
    for (size_t t = 0; t < m.triangle_count(); ++t)
      EXPECT_GT(dot(triangle_normal(m, t), room_center - triangle_centroid(m, t)), 0) << wall;
  }
  const Mesh& light = mesh_named(s, "ceiling light");
  for (size_t t = 0; t < light.triangle_count(); ++t) {
    EXPECT_LT(normalize(triangle_normal(light, t)).z, -0.999f);
    EXPECT_FLOAT_EQ(triangle_centroid(light, t).z, 1.98f);
  }
  EXPECT_NEAR(surface_area(light), 0.25, 1e-6);
  EXPECT_EQ(s.material(light.material_ids[0]).name, "light");
  EXPECT_NEAR(s.material(light.material_ids[0]).radiance().r, 12.0f, 1e-5f);
  // Boxes: closed, on the floor, inside the room, white.
  for (const char* box : {"tall box", "short box"}) {
    const Mesh& m = mesh_named(s, box);
    EXPECT_TRUE(closed_and_oriented(m)) << box;
    for (const Vec3& p : m.positions) {
      EXPECT_GE(p.z, 0.0f);
      EXPECT_LT(std::abs(p.x), 1.0f);
      EXPECT_LT(std::abs(p.y), 1.0f);
    }
    EXPECT_EQ(s.material(m.material_ids[0]).name, "white");
  }
  // The accelerator works: the central camera ray hits the back wall at y = 1.
  const auto hit = s.intersect(s.camera.generate_ray(Vec2(256.5f, 200.5f), Vec2(0.5f, 0.5f)));
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->p.y, 1.0f, 1e-4f);
  EXPECT_EQ(s.meshes[hit->mesh].name, "back wall");
}

TEST(Scenes, CornellGlassHasTwoSpheresAndTheSameLightPower) {
  const Scene s = load_scene(kScenes + "cornell-glass.json");
  EXPECT_TRUE(s.warnings.empty()) << warnings_text(s);
  EXPECT_EQ(s.triangle_count(), 12u + 2u * 3968u);  // walls + light, two 64-segment spheres
  EXPECT_EQ(s.materials.size(), 6u);
  EXPECT_EQ(area_light_count(s), 2u);
  EXPECT_NEAR(surface_area(mesh_named(s, "ceiling light")), 0.04, 1e-6);
  const Material& glass = s.material(mesh_named(s, "glass sphere").material_ids[0]);
  EXPECT_EQ(glass.type, MaterialType::Dielectric);
  EXPECT_FLOAT_EQ(glass.ior, 1.5f);
  EXPECT_EQ(glass.roughness, 0.0f);
  const Material& mirror = s.material(mesh_named(s, "mirror sphere").material_ids[0]);
  EXPECT_EQ(mirror.type, MaterialType::Conductor);
  EXPECT_EQ(mirror.roughness, 0.0f);
  EXPECT_FLOAT_EQ(mirror.color.g, 0.95f);
  for (const char* name : {"glass sphere", "mirror sphere"}) {
    const Mesh& m = mesh_named(s, name);
    EXPECT_TRUE(closed_and_oriented(m)) << name;
    EXPECT_NEAR(surface_area(m), 4 * kPi * 0.35 * 0.35, 0.01 * 4 * kPi * 0.35 * 0.35) << name;
  }
  const Scene box = load_scene(kScenes + "cornell-box.json");
  EXPECT_NEAR(total_light_power(s), total_light_power(box), 0.01f * total_light_power(box));
}

TEST(Scenes, TorusGlassHasTheTorusInsideAClosedGlassCube) {
  const Scene s = load_scene(kScenes + "torus-glass.json");
  EXPECT_TRUE(s.warnings.empty()) << warnings_text(s);
  EXPECT_EQ(s.triangle_count(), 2u + 2u + 2u + 12u + 2u * 48u * 24u);
  EXPECT_EQ(s.materials.size(), 5u);
  EXPECT_EQ(area_light_count(s), 2u);
  EXPECT_TRUE(s.lights.empty());  // black environment: no environment light
  EXPECT_EQ(s.light_set().environment(), -1);
  EXPECT_EQ(s.camera.width, 512);
  EXPECT_EQ(s.camera.height, 384);
  const Mesh& cube = mesh_named(s, "glass cube");
  EXPECT_TRUE(closed_and_oriented(cube));
  EXPECT_NEAR(surface_area(cube), 6.0, 1e-4);
  EXPECT_EQ(s.material(cube.material_ids[0]).type, MaterialType::Dielectric);
  Bounds3 cube_bounds;
  for (const Vec3& p : cube.positions) cube_bounds.extend(p);
  EXPECT_GT(cube_bounds.lo.z, 0.0f) << "no face coplanar with the floor";
  const Mesh& torus = mesh_named(s, "torus");
  EXPECT_TRUE(closed_and_oriented(torus));
  for (const Vec3& p : torus.positions)
    for (int k = 0; k < 3; ++k) {
      EXPECT_GT(p[k], cube_bounds.lo[k] + 0.05f);
      EXPECT_LT(p[k], cube_bounds.hi[k] - 0.05f);
    }
  // Tilted about X by 30 degrees: vertical extent 2 (R sin 30 + r) = 0.5 around z = 0.5.
  Bounds3 tb;
  for (const Vec3& p : torus.positions) tb.extend(p);
  EXPECT_NEAR(tb.hi.z - tb.lo.z, 0.5f, 0.01f);
  const Mesh& light = mesh_named(s, "area light");
  EXPECT_NEAR(triangle_centroid(light, 0).z, 3.0f, 1e-5f);
  EXPECT_LT(normalize(triangle_normal(light, 0)).z, -0.999f);
  EXPECT_NEAR(s.material(light.material_ids[0]).radiance().g, 500.0f, 1e-3f);
}

// ---- Shapes ----

TEST(Shapes, SphereAreaApproachesFourPiRSquared) {
  const float r = 0.7f;
  const double exact = 4 * M_PI * r * r;
  const double coarse = surface_area(make_sphere({1, 2, 3}, r, 16));
  const double fine = surface_area(make_sphere({1, 2, 3}, r, 96));
  EXPECT_LT(fine, exact);  // inscribed polyhedron
  EXPECT_NEAR(fine, exact, 0.002 * exact);
  EXPECT_LT(std::abs(fine - exact), std::abs(coarse - exact));
}

TEST(Shapes, SphereIsClosedOutwardAndHasNoDegenerateTriangles) {
  const Vec3 c{1, -2, 0.5f};
  const Mesh m = make_sphere(c, 2.0f, 24, 3);
  EXPECT_EQ(m.triangle_count(), 2u * 24u * 11u);
  EXPECT_TRUE(closed_and_oriented(m));
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (size_t v = 0; v < m.positions.size(); ++v) {
    EXPECT_NEAR(length(m.positions[v] - c), 2.0f, 1e-5f);
    EXPECT_NEAR(length(m.normals[v] - (m.positions[v] - c) / 2.0f), 0.0f, 1e-5f);
  }
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const Vec3 n = triangle_normal(m, t);
    EXPECT_GT(length(n), 1e-4f) << "degenerate triangle " << t;
    EXPECT_GT(dot(n, triangle_centroid(m, t) - c), 0) << "inward triangle " << t;
    EXPECT_EQ(m.material_ids[t], 3u);
  }
}

TEST(Shapes, BoxIsClosedWithOutwardFlatFaces) {
  const Vec3 lo{-1, 0, 2}, hi{1, 3, 2.5f};
  const Mesh m = make_box(lo, hi, 1);
  EXPECT_EQ(m.triangle_count(), 12u);
  EXPECT_EQ(m.positions.size(), 8u);
  EXPECT_TRUE(m.normals.empty());
  EXPECT_TRUE(closed_and_oriented(m));
  EXPECT_NEAR(surface_area(m), 2 * (2 * 3 + 2 * 0.5 + 3 * 0.5), 1e-5);
  const Vec3 center = (lo + hi) * 0.5f;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const Vec3 n = normalize(triangle_normal(m, t));
    EXPECT_NEAR(max_component(Vec3(std::abs(n.x), std::abs(n.y), std::abs(n.z))), 1.0f, 1e-6f);  // axis-aligned
    EXPECT_GT(dot(n, triangle_centroid(m, t) - center), 0);
  }
}

TEST(Shapes, TorusIsClosedWithOutwardNormalsAroundZ) {
  const Vec3 c{0, 0, 1};
  const float R = 0.5f, r = 0.2f;
  const Mesh m = make_torus(c, R, r, 40, 20);
  EXPECT_EQ(m.triangle_count(), 2u * 40u * 20u);
  EXPECT_TRUE(closed_and_oriented(m));
  EXPECT_NEAR(surface_area(m), 4 * M_PI * M_PI * R * r, 0.01 * 4 * M_PI * M_PI * R * r);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const Vec3 p = triangle_centroid(m, t) - c;
    const Vec3 core = normalize(Vec3(p.x, p.y, 0)) * R;  // nearest point on the core circle
    EXPECT_GT(dot(triangle_normal(m, t), p - core), 0) << "triangle " << t;
  }
  for (size_t v = 0; v < m.positions.size(); ++v) {
    const Vec3 p = m.positions[v] - c;
    const Vec3 core = normalize(Vec3(p.x, p.y, 0)) * R;
    EXPECT_NEAR(length(p - core), r, 1e-5f);
    EXPECT_NEAR(length(m.normals[v] - (p - core) / r), 0.0f, 1e-4f);
  }
}

TEST(Shapes, QuadFacesCrossOfItsEdgesAndDiskFacesUp) {
  const Mesh q = make_quad({0, 0, 1}, {0, 0.5f, 0}, {2, 0, 0});
  EXPECT_EQ(q.triangle_count(), 2u);
  EXPECT_NEAR(surface_area(q), 4.0, 1e-6);
  for (size_t t = 0; t < 2; ++t) EXPECT_LT(normalize(triangle_normal(q, t)).z, -0.9999f);  // cross(y, x) = -z
  const Mesh corners = make_quad_corners({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0});
  for (size_t t = 0; t < 2; ++t) EXPECT_GT(normalize(triangle_normal(corners, t)).z, 0.9999f);
  const Mesh d = make_disk({1, 1, 1}, 0.5f, 64);
  EXPECT_EQ(d.triangle_count(), 64u);
  EXPECT_NEAR(surface_area(d), M_PI * 0.25, 0.005 * M_PI * 0.25);
  for (size_t t = 0; t < d.triangle_count(); ++t) EXPECT_GT(normalize(triangle_normal(d, t)).z, 0.9999f);
  EXPECT_THROW(make_quad({0, 0, 0}, {1, 0, 0}, {2, 0, 0}), std::invalid_argument);
  EXPECT_THROW(make_sphere({0, 0, 0}, -1.0f), std::invalid_argument);
  EXPECT_THROW(make_box({0, 0, 0}, {1, -1, 1}), std::invalid_argument);
  EXPECT_THROW(make_torus({0, 0, 0}, 0.2f, 0.3f), std::invalid_argument);
}

TEST(Shapes, ApplyTransformMovesPointsRotatesNormalsAndKeepsMirroredMeshesOutward) {
  Mesh s = make_sphere({0, 0, 0}, 1.0f, 12);
  apply_transform(s, Transform::translate({0, 0, 5}) * Transform::rotate(90, {1, 0, 0}) * Transform::scale({2, 1, 1}));
  EXPECT_NEAR(length(s.positions[0] - Vec3(0, -1, 5)), 0.0f, 1e-5f);  // north pole (0,0,1) -> (0,-1,0) + 5z
  EXPECT_NEAR(length(s.normals[0] - Vec3(0, -1, 0)), 0.0f, 1e-5f);
  for (const Vec3& n : s.normals) EXPECT_NEAR(length(n), 1.0f, 1e-5f);
  // Normals of a non-uniformly scaled sphere are the gradient of the ellipsoid, not scaled vectors.
  for (size_t v = 0; v < s.positions.size(); ++v) {
    const Vec3 q = s.positions[v] - Vec3(0, 0, 5);
    const Vec3 grad = normalize(Vec3(q.x / 4, q.y, q.z));  // ellipsoid (x/2)^2 + y^2 + z^2 = 1
    EXPECT_NEAR(length(s.normals[v] - grad), 0.0f, 1e-4f);
  }
  Mesh b = make_box({0, 0, 0}, {1, 1, 1});
  apply_transform(b, Transform::scale({-1, 1, 1}));
  EXPECT_LT(linear_determinant(Transform::scale({-1, 1, 1})), 0);
  EXPECT_TRUE(closed_and_oriented(b));
  for (size_t t = 0; t < b.triangle_count(); ++t)
    EXPECT_GT(dot(triangle_normal(b, t), triangle_centroid(b, t) - Vec3(-0.5f, 0.5f, 0.5f)), 0) << "triangle " << t;
}

// ---- Loader: values ----

TEST(SceneLoader, ReadsCamerasMaterialsLightsAndEnvironment) {
  const Scene s = from_text(R"({
    "camera": {"matrix": [1,0,0,1, 0,1,0,2, 0,0,1,3, 0,0,0,1], "fov": 50, "sensor_fit": "vertical",
               "width": 40, "height": 20, "aperture_radius": 0.01, "focus_distance": 2},
    "materials": {"z": {"type": "diffuse", "color": [0.1, 0.2, 0.3]},
                  "a": {"type": "dielectric", "ior": 1.5, "abbe": 40, "roughness": 0.1},
                  "lamp": {"type": "emission", "emission": 2, "strength": 3, "two_sided": true},
                  "metal": {"type": "conductor", "color": 0.9, "roughness": 0.2, "emission": [1, 0, 0], "strength": 0.5}},
    "objects": [{"type": "disk", "radius": 1, "material": "lamp"}],
    "lights": [{"type": "point", "position": [1, 2, 3], "power": 100, "color": [1, 0.5, 0]},
               {"type": "spot", "name": "spot", "position": [0, 0, 2], "look_at": [0, 0, 0], "spot_size": 60, "spot_blend": 0.5, "intensity": 7},
               {"type": "sun", "direction": [0, 0, -2], "strength": 3, "color": [1, 1, 0.5]}],
    "environment": {"color": [0.1, 0.2, 0.4], "strength": 2}})");
  EXPECT_TRUE(s.warnings.empty()) << warnings_text(s);
  EXPECT_NEAR(length(s.camera.position() - Vec3(1, 2, 3)), 0.0f, 1e-6f);
  EXPECT_EQ(s.camera.sensor_fit, SensorFit::Vertical);
  EXPECT_EQ(s.camera.width, 40);
  EXPECT_FLOAT_EQ(s.camera.aperture_radius, 0.01f);
  EXPECT_FLOAT_EQ(s.camera.focus_distance, 2.0f);
  // Materials keep the file's order.
  ASSERT_EQ(s.materials.size(), 4u);
  EXPECT_EQ(s.materials[0].name, "z");
  EXPECT_EQ(s.materials[1].name, "a");
  EXPECT_FLOAT_EQ(s.materials[0].color.b, 0.3f);
  EXPECT_FALSE(s.materials[0].is_emissive());
  // Abbe 40 at n_d 1.5: B = 0.5 / 40 / (1/0.4861^2 - 1/0.6563^2) um^2.
  EXPECT_NEAR(s.materials[1].cauchy_b, 0.5 / 40 / (1 / (0.4861 * 0.4861) - 1 / (0.6563 * 0.6563)), 1e-7);
  EXPECT_FLOAT_EQ(s.materials[1].roughness, 0.1f);
  EXPECT_EQ(s.materials[1].color.g, 1.0f);  // clear glass by default
  EXPECT_EQ(s.materials[2].type, MaterialType::Emission);
  EXPECT_FLOAT_EQ(s.materials[2].radiance().g, 6.0f);
  EXPECT_TRUE(s.materials[2].two_sided);
  EXPECT_FLOAT_EQ(s.materials[3].radiance().r, 0.5f);
  EXPECT_EQ(s.materials[3].radiance().g, 0.0f);
  // Lights: point power / 4 pi, spot cone from Blender's size and blend, unit sun direction.
  ASSERT_EQ(s.lights.size(), 4u);
  EXPECT_EQ(s.lights[0].type, LightType::Point);
  EXPECT_NEAR(s.lights[0].emit.r, 100 / (4 * M_PI), 1e-4);
  EXPECT_NEAR(s.lights[0].emit.g, 50 / (4 * M_PI), 1e-4);
  EXPECT_EQ(s.lights[0].name, "/lights/0");
  EXPECT_EQ(s.lights[1].type, LightType::Spot);
  EXPECT_EQ(s.lights[1].name, "spot");
  EXPECT_NEAR(length(s.lights[1].direction - Vec3(0, 0, -1)), 0.0f, 1e-6f);
  EXPECT_NEAR(s.lights[1].spot_cos_half, std::cos(M_PI / 6), 1e-6);
  EXPECT_NEAR(s.lights[1].spot_smooth, (1 - std::cos(M_PI / 6)) * 0.5, 1e-6);
  EXPECT_FLOAT_EQ(s.lights[1].emit.b, 7.0f);
  EXPECT_EQ(s.lights[2].type, LightType::Directional);
  EXPECT_NEAR(length(s.lights[2].direction - Vec3(0, 0, -1)), 0.0f, 1e-6f);
  EXPECT_FLOAT_EQ(s.lights[2].emit.b, 1.5f);
  EXPECT_EQ(s.lights[3].type, LightType::Environment);
  EXPECT_FLOAT_EQ(s.lights[3].emit.b, 0.8f);
  EXPECT_GE(s.light_set().environment(), 0);
  EXPECT_EQ(area_light_count(s), 48u);  // the emissive disk
}

TEST(SceneLoader, LookAtCameraLooksDownMinusZWithYUp) {
  const Scene s = from_text(R"({"camera": {"position": [1, -4, 2], "look_at": [1, 0, 2]},
    "materials": {"m": {"type": "diffuse"}}, "lights": [{"type": "sun", "direction": [0, 0, -1], "irradiance": 1}]})");
  const Transform& m = s.camera.camera_to_world;
  EXPECT_NEAR(length(m.vector({0, 0, -1}) - Vec3(0, 1, 0)), 0.0f, 1e-6f);
  EXPECT_NEAR(length(m.vector({0, 1, 0}) - Vec3(0, 0, 1)), 0.0f, 1e-6f);
  EXPECT_NEAR(length(m.vector({1, 0, 0}) - Vec3(1, 0, 0)), 0.0f, 1e-6f);
  EXPECT_EQ(s.camera.width, 256);  // defaults
  EXPECT_TRUE(s.meshes.empty());
}

TEST(SceneLoader, InlineMeshWithPerTriangleMaterialsNormalsUvsAndTransform) {
  const Scene s = from_text(scene_text(R"({"name": "two", "type": "mesh",
      "positions": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "indices": [[0,1,2], [0,2,3]],
      "normals": [[0,0,2], [0,0,1], [0,0,1], [0,0,1]], "uvs": [[0,0], [1,0], [1,1], [0,1]],
      "materials": ["glass", "white"], "material_indices": [1, 0],
      "transform": {"scale": 2, "rotate": [[90, 0, 0, 1], [90, 1, 0, 0]], "translate": [0, 0, 1]}})"));
  EXPECT_TRUE(s.warnings.empty()) << warnings_text(s);
  const Mesh& m = s.meshes.at(0);
  EXPECT_EQ(m.name, "two");
  EXPECT_EQ(s.material(m.material_ids[0]).name, "white");
  EXPECT_EQ(s.material(m.material_ids[1]).name, "glass");
  // (1,0,0): scale -> (2,0,0), about Z -> (0,2,0), about X -> (0,0,2), translate -> (0,0,3).
  EXPECT_NEAR(length(m.positions[1] - Vec3(0, 0, 3)), 0.0f, 1e-5f);
  // Normal +Z: about Z stays, about X -> -Y; unit length.
  EXPECT_NEAR(length(m.normals[0] - Vec3(0, -1, 0)), 0.0f, 1e-5f);
  EXPECT_FLOAT_EQ(m.uvs[2].x, 1.0f);
}

// Object Info's Random: an object's own "random_id" (an instanced copy's, from Blender), else the
// hash of its name as Cycles hashes it (hash_string, h * 37 + c: "Plane" -> 0.13576, measured).
TEST(SceneLoader, ObjectInfoRandomFromRandomIdOrTheName) {
  Scene s = from_text(scene_text(R"({"name": "Plane", "type": "quad", "u": [1, 0, 0], "v": [0, 1, 0], "material": "white"},
      {"name": "Copy", "type": "quad", "u": [1, 0, 0], "v": [0, 1, 0], "material": "white", "random_id": 3221225472})"));
  s.finalize();
  ASSERT_EQ(s.shading_objects().size(), 2u);
  EXPECT_NEAR(s.shading_objects()[0].random, 0.13576f, 1e-5f);
  EXPECT_NEAR(s.shading_objects()[1].random, 0.75f, 1e-6f);
  const std::string bad = scene_error([] {
    from_text(scene_text(R"({"type": "quad", "u": [1, 0, 0], "v": [0, 1, 0], "material": "white", "random_id": -1})"));
  });
  EXPECT_NE(bad.find("/objects/0/random_id: must be an integer"), std::string::npos) << bad;
}

// ---- Loader: errors name the file and the JSON path ----

TEST(SceneLoader, MissingSceneFileNamesTheFile) {
  const std::string msg = scene_error([] { load_scene("/nonexistent/gradphoton/missing-scene.json"); });
  EXPECT_NE(msg.find("missing-scene.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("cannot open"), std::string::npos) << msg;
}

TEST(SceneLoader, JsonSyntaxErrorNamesFileAndBytePosition) {
  const std::string msg = scene_error([] { from_text("{\"objects\": [1, 2,]}", "broken.json"); });
  EXPECT_NE(msg.find("broken.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("syntax error at byte 19"), std::string::npos) << msg;
  // 1e999 overflows a double: nlohmann reports it as out_of_range, still with a position.
  const std::string inf = scene_error([] { from_text("{\"camera\": {\"fov\": 1e999}}", "inf.json"); });
  EXPECT_NE(inf.find("inf.json: JSON error at byte"), std::string::npos) << inf;
  EXPECT_NE(inf.find("1e999"), std::string::npos) << inf;
}

TEST(SceneLoader, WrongTypesAndLengthsNameTheJsonPath) {
  const std::string radius = scene_error([] {
    from_text(scene_text(R"({"type": "box", "min": [0,0,0], "max": [1,1,1], "material": "white"},
                           {"type": "sphere", "radius": "big", "material": "white"})"), "types.json");
  });
  EXPECT_NE(radius.find("types.json: /objects/1/radius: expected a number, got string \"big\""), std::string::npos) << radius;
  const std::string center = scene_error([] {
    from_text(scene_text(R"({"type": "sphere", "center": [0, 0], "radius": 1, "material": "white"})"));
  });
  EXPECT_NE(center.find("inline.json: /objects/0/center: expected a vector [x, y, z]"), std::string::npos) << center;
  const std::string element = scene_error([] {
    from_text(scene_text(R"({"type": "quad", "u": [1, 0, 0], "v": [0, true, 0], "material": "white"})"));
  });
  EXPECT_NE(element.find("/objects/0/v/1: expected a number"), std::string::npos) << element;
  const std::string width = scene_error([] { from_text(R"({"camera": {"position": [0,0,0], "look_at": [0,1,0], "width": 10.5}})"); });
  EXPECT_NE(width.find("/camera/width: expected an integer"), std::string::npos) << width;
  const std::string root = scene_error([] { from_text("[1, 2]", "array.json"); });
  EXPECT_NE(root.find("array.json: /: the scene must be a JSON object"), std::string::npos) << root;
}

TEST(SceneLoader, NegativeAndNonFiniteSizesAreErrors) {
  auto err = [](const std::string& objects) { return scene_error([&] { from_text(scene_text(objects)); }); };
  EXPECT_NE(err(R"({"type": "sphere", "radius": -1, "material": "white"})").find("/objects/0/radius: must be positive"),
            std::string::npos);
  EXPECT_NE(err(R"({"type": "box", "min": [0, 0, 0], "max": [1, -1, 1], "material": "white"})")
                .find("/objects/0: 'min' must be below 'max'"),
            std::string::npos);
  EXPECT_NE(err(R"({"type": "torus", "major_radius": 0.1, "minor_radius": 0.2, "material": "white"})")
                .find("/objects/0/minor_radius"),
            std::string::npos);
  EXPECT_NE(err(R"({"type": "disk", "radius": 1, "segments": 2, "material": "white"})").find("/objects/0/segments"),
            std::string::npos);
  // Finite as a double, infinite as the float the renderer stores.
  const std::string big = err(R"({"name": "huge", "type": "mesh", "positions": [[0,0,0], [1e300,0,0], [0,1,0]],
                                  "indices": [[0,1,2]], "material": "white"})");
  EXPECT_NE(big.find("inline.json: /objects/0/positions/1/0: number 1e+300 is not finite"), std::string::npos) << big;
  // Finite input, infinite after the transform.
  const std::string scaled = err(R"({"name": "blown", "type": "sphere", "radius": 1e30, "material": "white",
                                     "transform": {"scale": 1e30}})");
  EXPECT_NE(scaled.find("/objects/0/transform: transformed vertex"), std::string::npos) << scaled;
  EXPECT_NE(scaled.find("'blown'"), std::string::npos) << scaled;
  const std::string material = scene_error([] {
    from_text(R"({"materials": {"bad": {"type": "diffuse", "color": [0.5, -0.1, 0.5]}}})");
  });
  EXPECT_NE(material.find("/materials/bad/color/1: must not be negative"), std::string::npos) << material;
  const std::string sun = scene_error([] { from_text(R"({"lights": [{"type": "sun", "direction": [0, 0, 0], "irradiance": 1}]})"); });
  EXPECT_NE(sun.find("/lights/0/direction: direction must be a non-zero vector"), std::string::npos) << sun;
}

TEST(SceneLoader, NonFiniteVertexInAMeshBuiltInCodeFailsInFinalize) {
  // JSON cannot carry NaN; meshes built in code (the Blender export) are checked by finalize.
  Scene s;
  s.source = "code";
  s.materials.push_back(Material{});
  Mesh m = make_quad({0, 0, 0}, {1, 0, 0}, {0, 1, 0});
  m.name = "nan quad";
  m.positions[2].y = std::nanf("");
  s.meshes.push_back(m);
  try {
    s.finalize();
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("mesh 'nan quad': vertex 2 is not finite"), std::string::npos) << e.what();
  }
}

TEST(SceneLoader, UnknownMaterialListsTheKnownOnes) {
  const std::string msg = scene_error([] {
    from_text(scene_text(R"({"type": "sphere", "radius": 1, "material": "white"},
                           {"type": "sphere", "radius": 1, "material": "glas"})"), "scenes/x.json");
  });
  EXPECT_NE(msg.find("scenes/x.json: /objects/1/material: unknown material 'glas' (known: glass, white)"),
            std::string::npos) << msg;
  const std::string type = scene_error([] { from_text(R"({"materials": {"m": {"type": "toon"}}})"); });
  EXPECT_NE(type.find("/materials/m/type: unknown material type 'toon'"), std::string::npos) << type;
}

TEST(SceneLoader, MixMaterialsResolveTheirPartsInAnyOrderAndRejectCycles) {
  const Scene s = from_text(R"({"materials": {
      "outer": {"type": "mix", "a": "inner", "b": "coat", "factor": 0.25},
      "inner": {"type": "add", "a": "d", "b": "g"},
      "d": {"type": "diffuse", "color": 0.5}, "g": {"type": "conductor", "roughness": 0.3, "fresnel": false},
      "coat": {"type": "plastic", "color": 0.2, "roughness": 0.1, "ior": 1.6}}})");
  EXPECT_EQ(s.warnings.count("unknown key"), 0u);
  const Material& outer = s.materials[0];
  ASSERT_EQ(outer.type, MaterialType::Mix);
  ASSERT_TRUE(outer.mix_a && outer.mix_b);
  EXPECT_EQ(outer.mix_a->type, MaterialType::Mix);
  EXPECT_TRUE(outer.mix_a->mix_add);
  ASSERT_TRUE(outer.mix_a->mix_a && outer.mix_a->mix_b) << "the inner mix is resolved before it is copied";
  EXPECT_EQ(outer.mix_a->mix_b->conductor_fresnel, ConductorFresnel::None);
  EXPECT_EQ(outer.mix_b->type, MaterialType::Plastic);
  EXPECT_TRUE(outer.mix_b->coat_albedo) << "plastics get their coat table when loaded";
  EXPECT_FLOAT_EQ(outer.mix_factor, 0.25f);
  const std::string missing = scene_error([] { from_text(R"({"materials": {"m": {"type": "mix", "a": "m2", "b": "x"}, "m2": {"type": "diffuse"}}})"); });
  EXPECT_NE(missing.find("/materials/m/b: unknown material 'x'"), std::string::npos) << missing;
  const std::string cycle = scene_error([] { from_text(R"({"materials": {"p": {"type": "mix", "a": "q", "b": "q"}, "q": {"type": "add", "a": "p", "b": "p"}}})"); });
  EXPECT_NE(cycle.find("cycle"), std::string::npos) << cycle;
}

TEST(SceneLoader, OutOfRangeIndexNamesObjectAndTriangle) {
  const std::string msg = scene_error([] {
    from_text(scene_text(R"({"name": "tri", "type": "mesh", "positions": [[0,0,0], [1,0,0], [0,1,0]],
                             "indices": [[0,1,2], [0,2,3]], "material": "white"})"));
  });
  EXPECT_NE(msg.find("inline.json: /objects/0/indices/1: triangle 1 of 'tri' uses vertex 3 but the mesh has 3 vertices"),
            std::string::npos) << msg;
  const std::string negative = scene_error([] {
    from_text(scene_text(R"({"type": "mesh", "positions": [[0,0,0], [1,0,0], [0,1,0]], "indices": [[0,-1,2]], "material": "white"})"));
  });
  EXPECT_NE(negative.find("/objects/0/indices/0/1: must be in [0,"), std::string::npos) << negative;
  const std::string mat_index = scene_error([] {
    from_text(scene_text(R"({"type": "mesh", "positions": [[0,0,0], [1,0,0], [0,1,0]], "indices": [[0,1,2]],
                             "materials": ["white"], "material_indices": [1]})"));
  });
  EXPECT_NE(mat_index.find("/objects/0/material_indices/0: must be in [0, 0]"), std::string::npos) << mat_index;
}

TEST(SceneLoader, ZeroAreaTriangleIsACountedWarning) {
  const Scene s = from_text(scene_text(R"({"name": "sliver", "type": "mesh",
      "positions": [[0,0,0], [1,0,0], [0,1,0], [2,0,0]], "indices": [[0,1,2], [0,1,3], [1,3,0]], "material": "white"})"), "zero.json");
  EXPECT_EQ(s.warnings.count("zero-area triangle"), 2u);
  EXPECT_EQ(s.warnings.total(), 2u);
  EXPECT_NE(warnings_text(s).find("zero.json: mesh 'sliver' triangle 1"), std::string::npos) << warnings_text(s);
  EXPECT_EQ(s.triangle_count(), 3u);
}

TEST(SceneLoader, UnknownKeysAreCountedWarnings) {
  const Scene s = from_text(scene_text(R"({"type": "sphere", "radius": 1, "segmnts": 8, "material": "white"},
                                          {"type": "box", "min": [0,0,0], "max": [1,1,1], "material": "white", "colour": 1})"),
                            "keys.json");
  EXPECT_EQ(s.warnings.count("unknown key"), 2u);
  EXPECT_EQ(s.warnings.total(), 2u);
  EXPECT_NE(warnings_text(s).find("keys.json: /objects/0/segmnts"), std::string::npos) << warnings_text(s);
  EXPECT_EQ(s.meshes[0].triangle_count(), 2u * 48u * 23u) << "the misspelt key is not used";
  const Scene root = from_text(scene_text("", R"(, "camera2": {})"), "root.json");
  EXPECT_EQ(root.warnings.count("unknown key"), 1u);
  EXPECT_NE(warnings_text(root).find("root.json: /camera2"), std::string::npos) << warnings_text(root);
  const Scene m = from_text(R"({"materials": {"d": {"type": "diffuse", "fresnel": "schlick"}}})");
  EXPECT_EQ(m.warnings.count("unknown key"), 1u) << "fresnel means nothing to a diffuse material";
  const Scene l = from_text(R"({"lights": [{"type": "point", "position": [0,0,1], "intensity": 1, "radus": 0.1}]})");
  EXPECT_EQ(l.warnings.count("unknown key"), 1u);
  EXPECT_NE(warnings_text(l).find("/lights/0/radus"), std::string::npos) << warnings_text(l);
}

TEST_F(SceneLoaderFiles, ObjFileWithUsemtlMappingAndFallback) {
  write("mesh.obj", R"(# two faces named after scene materials, one unknown, one quad without usemtl
mtllib nonexistent.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
vn 0 0 1
f 4//1 1//1 2//1 3//1
usemtl glass
f 1//1 2//1 5//1
usemtl chrome
f 2//1 3//1 5//1
usemtl white
f 3//1 4//1 5//1
)");
  const std::string path = write("scene.json", scene_text(R"({"name": "imported", "type": "obj", "file": "mesh.obj", "material": "white",
                                                              "transform": {"translate": [0, 0, 1]}})"));
  const Scene s = load_scene(path);
  const Mesh& m = s.meshes.at(0);
  ASSERT_EQ(m.triangle_count(), 5u);  // the quad is split in two
  std::vector<std::string> names;
  for (uint32_t id : m.material_ids) names.push_back(s.material(id).name);
  EXPECT_EQ(names, (std::vector<std::string>{"white", "white", "glass", "white", "white"}));
  EXPECT_EQ(s.warnings.count("obj material not in scene"), 1u) << warnings_text(s);
  EXPECT_NE(warnings_text(s).find("usemtl 'chrome'"), std::string::npos) << warnings_text(s);
  EXPECT_EQ(s.warnings.total(), 1u) << warnings_text(s);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (const Vec3& p : m.positions) EXPECT_GE(p.z, 1.0f);  // transformed

  // Without a fallback, faces without usemtl and unknown usemtl names are errors naming both files.
  const std::string strict = write("strict.json", scene_text(R"({"type": "obj", "file": "mesh.obj"})"));
  const std::string msg = scene_error([&] { load_scene(strict); });
  EXPECT_NE(msg.find("strict.json: /objects/0: OBJ file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("mesh.obj' has faces without usemtl"), std::string::npos) << msg;
  write("named.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glass\nf 1 2 3\nusemtl chrome\nf 1 3 2\n");
  const std::string named = write("named.json", scene_text(R"({"type": "obj", "file": "named.obj"})"));
  const std::string unknown = scene_error([&] { load_scene(named); });
  EXPECT_NE(unknown.find("named.json: /objects/0/file: OBJ file"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("named.obj': usemtl 'chrome' is not a scene material (known: glass, white)"), std::string::npos)
      << unknown;
}

TEST_F(SceneLoaderFiles, MissingAndBrokenObjFilesNameBothFiles) {
  const std::string path = write("scene.json", scene_text(R"({"type": "obj", "file": "sub/missing.obj", "material": "white"})"));
  const std::string msg = scene_error([&] { load_scene(path); });
  EXPECT_NE(msg.find("scene.json: /objects/0/file: cannot open OBJ file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("sub/missing.obj"), std::string::npos) << msg;

  write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  const std::string bad = write("bad.json", scene_text(R"({"name": "broken", "type": "obj", "file": "bad.obj", "material": "white"})"));
  const std::string range = scene_error([&] { load_scene(bad); });
  EXPECT_NE(range.find("bad.json: /objects/0/file"), std::string::npos) << range;
  EXPECT_NE(range.find("face 0 of 'broken' uses vertex 7 but the file has 3 vertices"), std::string::npos) << range;
}


TEST(SceneLoader, LineSpectra) {
  // Emissive materials and lights take a line spectrum: a preset or [nm, weight] lines with a
  // FWHM. `emission` becomes the lines' colour at luminance 1 (clipped to the Rec.709 gamut),
  // so strength is the luminance; the lights carry the lines for spectral rendering.
  const Scene s = from_text(R"({"camera": {"position": [0, -5, 1], "look_at": [0, 0, 1], "width": 8, "height": 8},
    "materials": {"na": {"type": "emission", "spectrum": "sodium", "strength": 20},
                  "hg": {"type": "emission", "spectrum": {"preset": "mercury", "fwhm": 2}},
                  "pair": {"type": "emission", "spectrum": {"lines": [[532, 1], [633, 0.5]], "fwhm": 1}}},
    "lights": [{"type": "point", "position": [0, 0, 5], "power": 100, "spectrum": "sodium"}],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "na"},
                {"type": "quad", "center": [3, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "hg"},
                {"type": "quad", "center": [6, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "pair"}]})");
  const Material& na = s.materials[0];
  ASSERT_EQ(na.emission_lines.size(), 2u);
  EXPECT_NEAR(na.emission_lines[0].nm, 589.0f, 0.1f);
  EXPECT_EQ(na.emission.b, 0.0f) << "sodium's blue is outside Rec.709: clipped";
  EXPECT_GT(na.emission.r, na.emission.g);
  EXPECT_EQ(na.emission_strength, 20.0f);
  EXPECT_EQ(s.materials[1].emission_lines.size(), 5u);
  EXPECT_EQ(s.materials[1].emission_fwhm, 2.0f);
  EXPECT_EQ(s.materials[2].emission_lines.size(), 2u);
  bool point = false, area = false;
  for (const Light& l : s.light_set().lights()) {
    if (l.type == LightType::Point) point = l.lines.size() == 2;
    if (l.type == LightType::Area && l.lines.size() == 5) area = l.line_fwhm == 2.0f;
  }
  EXPECT_TRUE(point);
  EXPECT_TRUE(area);
  // The spectrum has luminance = scale: Y of the lines, integrated finely, over Y of 1.
  const RgbSpectrum sp = RgbSpectrum::lines(*spectral_line_preset("sodium"), 1.0f, 3.0f);
  double y = 0;
  for (double l = 570; l < 610; l += 0.01) y += cie_xyz_bar(float(l)).y * sp(float(l)) * 0.01;
  EXPECT_NEAR(y / cie_y_integral(), 3.0, 0.01);

  const auto mat = [](const std::string& body) {
    return scene_error([&] {
      from_text(R"({"materials": {"m": )" + body + R"(}, "objects": [{"type": "quad", "center": [0, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "m"}]})");
    });
  };
  EXPECT_NE(mat(R"({"type": "emission", "spectrum": "neon"})").find("unknown spectrum 'neon'"), std::string::npos);
  EXPECT_NE(mat(R"({"type": "emission", "emission": 1, "spectrum": "sodium"})").find("not both"), std::string::npos);
  EXPECT_NE(mat(R"({"type": "emission", "spectrum": {"lines": [[900, 1]]}})").find("/materials/m/spectrum/lines[0]"),
            std::string::npos);
  EXPECT_NE(mat(R"({"type": "emission", "spectrum": {"fwhm": 2}})").find("needs 'preset' or 'lines'"), std::string::npos);
}

TEST(SceneLoader, CyclesClosureTypesAndDiffuseRoughness) {
  const Scene s = from_text(R"({"camera": {"position": [0, -5, 1], "look_at": [0, 0, 1], "width": 8, "height": 8},
    "materials": {
      "rough": {"type": "diffuse", "color": 0.5, "roughness": 0.7},
      "tint": {"type": "transparent", "color": [1, 0, 0], "ior": 1.5},
      "refr": {"type": "refraction", "ior": 1.33, "roughness": 0.1},
      "leaf": {"type": "translucent", "color": [0.2, 0.6, 0.1]},
      "cloth": {"type": "velvet", "color": 0.4, "sigma": 0.35},
      "cloth1": {"type": "velvet"}},
    "objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1, "material": "rough"}]})");
  auto m = [&](const std::string& name) -> const Material& {
    for (const Material& x : s.materials)
      if (x.name == name) return x;
    throw std::runtime_error("no material " + name);
  };
  EXPECT_EQ(m("rough").type, MaterialType::Diffuse);
  EXPECT_FLOAT_EQ(m("rough").roughness, 0.7f);
  EXPECT_EQ(m("tint").type, MaterialType::Dielectric);
  EXPECT_EQ(m("tint").ior, 1.0f);  // a transparent surface does not bend light, whatever "ior" says
  EXPECT_EQ(m("tint").color.g, 0.0f);
  EXPECT_TRUE(m("refr").refraction_only);
  EXPECT_FLOAT_EQ(m("refr").ior, 1.33f);
  EXPECT_EQ(m("leaf").type, MaterialType::Translucent);
  EXPECT_EQ(m("cloth").type, MaterialType::Velvet);
  EXPECT_FLOAT_EQ(m("cloth").roughness, 0.35f);
  EXPECT_FLOAT_EQ(m("cloth1").roughness, 1.0f);  // Blender's default Sigma
  EXPECT_EQ(s.warnings.count("unknown key"), 1u);  // the transparent's "ior"
  const std::string err = scene_error([] { from_text(R"({"materials": {"x": {"type": "velvet", "sigma": 2}}})"); });
  EXPECT_NE(err.find("sigma"), std::string::npos) << err;
  const std::string unknown = scene_error([] {
    from_text(R"({"materials": {"x": {"type": "sheen"}}})");
  });
  EXPECT_NE(unknown.find("translucent"), std::string::npos) << unknown;
}

TEST(SceneLoader, DistributionsAsEachBlenderClosureHasThem) {
  // Glossy: GGX, Beckmann, Ashikhmin-Shirley, Multiscatter GGX; Glass: GGX, Beckmann,
  // Multiscatter GGX; Refraction: GGX, Beckmann; Principled: GGX, Multiscatter GGX.
  const Scene s = from_text(R"({"camera": {"position": [0, -5, 1], "look_at": [0, 0, 1], "width": 8, "height": 8},
    "materials": {
      "metal": {"type": "conductor", "roughness": 0.3, "distribution": "multi_ggx"},
      "glass": {"type": "dielectric", "roughness": 0.3, "distribution": "multi_ggx"},
      "frosted": {"type": "dielectric", "roughness": 0.3, "distribution": "beckmann"},
      "refr": {"type": "refraction", "roughness": 0.3, "distribution": "beckmann"},
      "p": {"type": "principled", "roughness": 0.3, "distribution": "multi_ggx"}},
    "objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1, "material": "metal"}]})");
  auto m = [&](const std::string& name) -> const Material& {
    for (const Material& x : s.materials)
      if (x.name == name) return x;
    throw std::runtime_error("no material " + name);
  };
  EXPECT_EQ(m("metal").distribution, Microfacet::MultiGGX);
  EXPECT_EQ(m("glass").distribution, Microfacet::MultiGGX);
  EXPECT_EQ(m("frosted").distribution, Microfacet::Beckmann);
  EXPECT_EQ(m("refr").distribution, Microfacet::Beckmann);
  EXPECT_EQ(m("p").distribution, Microfacet::MultiGGX);
  EXPECT_EQ(s.warnings.count("unknown key"), 0u);
  const std::string refr = scene_error([] {
    from_text(R"({"materials": {"r": {"type": "refraction", "distribution": "multi_ggx"}}})");
  });
  EXPECT_NE(refr.find("/materials/r/distribution: unknown distribution 'multi_ggx' for a refraction (known: ggx, sharp, beckmann)"),
            std::string::npos) << refr;
  const std::string glass = scene_error([] {
    from_text(R"({"materials": {"g": {"type": "dielectric", "distribution": "ashikhmin_shirley"}}})");
  });
  EXPECT_NE(glass.find("known: ggx, sharp, beckmann, multi_ggx"), std::string::npos) << glass;
}

TEST(SceneLoader, DielectricFresnelIsMicrofacetUnlessCyclesSplitAsked) {
  const Scene s = from_text(R"({"materials": {
      "walter": {"type": "dielectric", "roughness": 0.3},
      "micro": {"type": "dielectric", "roughness": 0.3, "fresnel": "microfacet"},
      "cycles": {"type": "dielectric", "roughness": 0.3, "fresnel": "normal"}},
    "objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1, "material": "walter"}]})");
  for (const Material& m : s.materials) EXPECT_EQ(m.fresnel_at_normal, m.name == "cycles") << m.name;
  EXPECT_EQ(s.warnings.count("unknown key"), 0u);
  const std::string bad = scene_error([] {
    from_text(R"({"materials": {"g": {"type": "dielectric", "fresnel": "schlick"}}})");
  });
  EXPECT_NE(bad.find("/materials/g/fresnel: unknown dielectric Fresnel 'schlick'"), std::string::npos) << bad;
  const std::string not_string = scene_error([] {
    from_text(R"({"materials": {"g": {"type": "dielectric", "fresnel": true}}})");
  });
  EXPECT_NE(not_string.find("/materials/g/fresnel"), std::string::npos) << not_string;
}

TEST(SceneLoader, PrincipledGlassAndSeparableMaskingAreAskedFor) {
  const Scene s = from_text(R"({"materials": {
      "glass": {"type": "dielectric", "roughness": 0.3, "color": [0.8, 0.1, 0.1]},
      "pglass": {"type": "dielectric", "roughness": 0.3, "color": [0.8, 0.1, 0.1], "specular_tint": 0.25},
      "metal": {"type": "conductor", "roughness": 0.3},
      "cmetal": {"type": "conductor", "roughness": 0.3, "masking": "correlated"},
      "smetal": {"type": "conductor", "roughness": 0.3, "masking": "separable"},
      "splastic": {"type": "principled", "roughness": 0.3, "masking": "separable"}},
    "objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1, "material": "glass"}]})");
  for (const Material& m : s.materials) {
    EXPECT_EQ(m.principled_glass, m.name == "pglass") << m.name;
    EXPECT_EQ(m.separable_masking, m.name == "smetal" || m.name == "splastic") << m.name;
    if (m.name == "pglass") EXPECT_FLOAT_EQ(m.specular_tint, 0.25f);
  }
  EXPECT_EQ(s.warnings.count("unknown key"), 0u);
  const std::string bad = scene_error([] {
    from_text(R"({"materials": {"g": {"type": "conductor", "masking": "smith"}}})");
  });
  EXPECT_NE(bad.find("/materials/g/masking: unknown masking 'smith'"), std::string::npos) << bad;
  const std::string range = scene_error([] {
    from_text(R"({"materials": {"g": {"type": "dielectric", "specular_tint": 2}}})");
  });
  EXPECT_NE(range.find("/materials/g/specular_tint"), std::string::npos) << range;
  // Not a key of glass: masking (its own G follows "fresnel").
  const Scene w = from_text(R"({"materials": {"g": {"type": "dielectric", "masking": "separable"}},
    "objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1, "material": "g"}]})");
  EXPECT_EQ(w.warnings.count("unknown key"), 1u);
}

TEST(SceneLoader, PrincipledLobesAndClearcoat) {
  const Scene s = from_text(R"({"camera": {"position": [0, -5, 1], "look_at": [0, 0, 1], "width": 8, "height": 8},
    "materials": {
      "p": {"type": "principled", "color": [0.6, 0.3, 0.1], "specular_tint": 0.5, "sheen": 2, "sheen_tint": 0.25},
      "p0": {"type": "principled"},
      "cc": {"type": "clearcoat", "clearcoat": 0.7, "roughness": 0.01},
      "cc0": {"type": "clearcoat"},
      "linked": {"type": "clearcoat", "clearcoat": {"link": "v", "output": "Value"},
                 "nodes": {"v": {"type": "ShaderNodeValue", "inputs": {"Value": 0.3}}}},
      "coated": {"type": "add", "a": "p", "b": "cc"}},
    "objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1, "material": "coated"}]})");
  auto m = [&](const std::string& name) -> const Material& {
    for (const Material& x : s.materials)
      if (x.name == name) return x;
    throw std::runtime_error("no material " + name);
  };
  EXPECT_FLOAT_EQ(m("p").specular_tint, 0.5f);
  EXPECT_FLOAT_EQ(m("p").sheen, 2.0f);
  EXPECT_FLOAT_EQ(m("p").sheen_tint, 0.25f);
  EXPECT_EQ(m("p0").sheen, 0.0f);  // Blender's defaults: no sheen, Sheen Tint 0.5, no tint
  EXPECT_EQ(m("p0").sheen_tint, 0.5f);
  EXPECT_EQ(m("p0").specular_tint, 0.0f);
  EXPECT_EQ(m("cc").type, MaterialType::Clearcoat);
  EXPECT_FLOAT_EQ(m("cc").clearcoat, 0.7f);
  EXPECT_FLOAT_EQ(m("cc").roughness, 0.01f);
  EXPECT_FLOAT_EQ(m("cc0").clearcoat, 1.0f);
  EXPECT_FLOAT_EQ(bsdf_params(m("linked"), Vec2()).clearcoat, 0.3f);  // from its node graph
  EXPECT_EQ(s.warnings.count("unknown key"), 0u);
  const std::string err = scene_error([] {
    from_text(R"({"materials": {"x": {"type": "principled", "specular_tint": 2}}})");
  });
  EXPECT_NE(err.find("specular_tint"), std::string::npos) << err;
}

}  // namespace
}  // namespace gp
