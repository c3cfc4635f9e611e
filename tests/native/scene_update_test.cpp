// Updates of a finalized scene (scene.h "Updates", builder.h update_description/set_camera) and
// the camera's crop window: each update renders exactly what a fresh build of the updated scene
// renders (path tracing keys every pixel's random stream by its place in the image, so the
// images match bit for bit).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/film.h"
#include "integrators/integrator.h"
#include "render_for_tests.h"
#include "scene/builder.h"
#include "scene/loader.h"

namespace gp {
namespace {

// A room of a floor, a back wall and a ceiling lamp, a box in it (all array meshes, as Blender
// exports them), camera in front.
std::string description(const std::string& box_color = "[0.7, 0.2, 0.1]", float lamp = 10.0f,
                        const std::string& camera = R"({"position": [0, -3, 1], "look_at": [0, 0, 0.6], "fov": 50,
                                                        "width": 24, "height": 18})") {
  return R"({"camera": )" + camera + R"(,
    "materials": {"white": {"type": "diffuse", "color": 0.7},
                  "box": {"type": "diffuse", "color": )" + box_color + R"(},
                  "lamp": {"type": "emission", "emission": 1, "strength": )" + std::to_string(lamp) + R"(}}})";
}

const float kQuad[] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
const uint32_t kQuadIdx[] = {0, 1, 2, 0, 2, 3};
const float kCube[] = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1, -1, -1, 1, 1, -1, 1, 1, 1, 1, -1, 1, 1};
const uint32_t kCubeIdx[] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                             1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};

Transform trs(Vec3 t, float degrees_z, Vec3 s) {
  return Transform::translate(t) * Transform::rotate(degrees_z, Vec3(0, 0, 1)) * Transform::scale(s);
}

const Transform kBoxA = trs({-0.3f, 0.2f, 0.3f}, 20, {0.3f, 0.3f, 0.3f});
const Transform kBoxB = trs({0.35f, -0.1f, 0.45f}, -35, {0.25f, 0.4f, 0.45f});

Scene build(const Transform& box, const std::string& desc = description()) {
  SceneBuilder b("test");
  b.set_description(desc);
  auto add = [&](const char* name, const float* p, size_t nv, const uint32_t* idx, size_t nt, const char* mat,
                 const Transform& t) {
    MeshArrays m;
    m.name = name;
    m.positions = p;
    m.vertex_count = nv;
    m.indices = idx;
    m.triangle_count = nt;
    m.materials = {mat};
    m.instances = {t};
    b.add_mesh(m);
  };
  add("floor", kQuad, 4, kQuadIdx, 2, "white", Transform::scale({3, 3, 1}));
  Transform wall = Transform::translate({0, 1.5f, 1.5f}) * Transform::rotate(90, {1, 0, 0}) * Transform::scale({3, 1.5f, 1});
  add("wall", kQuad, 4, kQuadIdx, 2, "white", wall);
  // Facing down: the lamp emits from its front (the quad's +Z turned to -Z).
  add("lamp", kQuad, 4, kQuadIdx, 2, "lamp", Transform::translate({0, 0, 2}) * Transform::rotate(180, {1, 0, 0}) *
                                                 Transform::scale({0.4f, 0.4f, 1}));
  add("box", kCube, 8, kCubeIdx, 12, "box", box);
  return b.finalize();
}

constexpr size_t kBox = 3;  // index of the box among the meshes

Film pt(const Scene& s, int passes = 4) {
  Params p;
  p.set("seed", 7);
  p.set("threads", 2);
  return render("pt", s, passes, p);
}

void expect_same(const Film& a, const Film& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  const auto& pa = a.pass(pass::kCombined).data;
  const auto& pb = b.pass(pass::kCombined).data;
  ASSERT_EQ(pa.size(), pb.size());
  size_t differ = 0;
  for (size_t i = 0; i < pa.size(); ++i) differ += pa[i] != pb[i];
  EXPECT_EQ(differ, 0u) << "of " << pa.size() << " values";
}

double mean(const Film& f) {
  double m = 0;
  for (float v : f.pass(pass::kCombined).data) m += v;
  return m / f.pass(pass::kCombined).data.size();
}

TEST(SceneUpdate, MovedMeshRendersAsAFreshBuild) {
  Scene moved = build(kBoxA);
  const Film before = pt(moved);
  const uint64_t g = moved.generation();
  moved.set_mesh_transform(kBox, kBoxB);
  moved.commit();
  EXPECT_GT(moved.generation(), g);
  const Film after = pt(moved);
  expect_same(after, pt(build(kBoxB)));
  EXPECT_NE(mean(before), mean(after));  // the test can tell the two places apart
}

TEST(SceneUpdate, MirroredAndBackKeepsWindingAndNormals) {
  const Transform mirrored = kBoxB * Transform::scale({-1, 1, 1});
  Scene s = build(kBoxA);
  s.set_mesh_transform(kBox, mirrored);
  s.commit();
  expect_same(pt(s), pt(build(mirrored)));
  s.set_mesh_transform(kBox, kBoxA);
  s.commit();
  expect_same(pt(s), pt(build(kBoxA)));
}

TEST(SceneUpdate, MovedLampMovesTheLight) {
  Scene s = build(kBoxA);
  const double before = mean(pt(s));
  const Transform lower = Transform::translate({0.5f, 0, 1.2f}) * Transform::rotate(180, {1, 0, 0}) *
                          Transform::scale({0.4f, 0.4f, 1});
  s.set_mesh_transform(2, lower);
  s.commit();
  // Area lights come from the emissive triangles where they are now.
  ASSERT_EQ(s.light_set().lights().size(), 2u);
  for (const Light& l : s.light_set().lights()) EXPECT_NEAR(l.p0.z, 1.2f, 1e-5f);
  EXPECT_GT(mean(pt(s)), before);  // closer to the floor and the box: brighter
}

TEST(SceneUpdate, BadMovesAreErrors) {
  Scene s = build(kBoxA);
  EXPECT_THROW(s.set_mesh_transform(99, kBoxB), std::invalid_argument);
  EXPECT_THROW(s.set_mesh_transform(kBox, Transform::scale({0, 1, 1})), std::invalid_argument);
  Transform nan = kBoxB;
  nan.m[0][3] = std::nanf("");
  EXPECT_THROW(s.set_mesh_transform(kBox, nan), std::invalid_argument);
  Scene file = cornell_box(8, 8);  // meshes from a file have no object-space source
  EXPECT_THROW(file.set_mesh_transform(0, kBoxB), std::invalid_argument);
}

TEST(SceneUpdate, DescriptionUpdateRendersAsAFreshBuild) {
  Scene s = build(kBoxA);
  const std::string desc = description("[0.1, 0.3, 0.8]", 25.0f);
  update_description(s, desc);
  expect_same(pt(s), pt(build(kBoxA, desc)));
  // A material an object uses must stay; the failed update says which.
  try {
    update_description(s, R"({"materials": {"white": {"type": "diffuse", "color": 0.5}}})");
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("'box'"), std::string::npos) << e.what();
  }
}

TEST(SceneUpdate, SetCameraRendersAsAFreshBuild) {
  const std::string other = R"({"position": [1.5, -2.5, 1.4], "look_at": [0, 0.3, 0.4], "fov": 40,
                                "width": 20, "height": 20})";
  Scene s = build(kBoxA);
  set_camera(s, other);
  expect_same(pt(s), pt(build(kBoxA, description("[0.7, 0.2, 0.1]", 10.0f, other))));
  EXPECT_THROW(set_camera(s, R"({"position": [0, 0, 0], "look_at": [0, 0, 0]})"), SceneError);
  EXPECT_THROW(set_camera(s, "{"), SceneError);
}

TEST(SceneUpdate, UpdatesWaitForRendersToEnd) {
  Scene s = build(kBoxA);
  {
    Scene::RenderGuard render(s);
    EXPECT_THROW(s.set_mesh_transform(kBox, kBoxB), std::logic_error);
    EXPECT_THROW(s.commit(), std::logic_error);
    EXPECT_THROW(Scene::UpdateGuard update(s), std::logic_error);
  }
  {
    Scene::UpdateGuard update(s);
    EXPECT_THROW(Scene::RenderGuard render(s), std::logic_error);
    s.set_mesh_transform(kBox, kBoxB);  // the update's own calls go through
    s.commit();
  }
  Scene::RenderGuard render(s);  // both released
}

// ---- Crop window (border render) ----

TEST(CameraCrop, PathTracingCropIsTheFullImagesWindow) {
  Scene s = build(kBoxA);
  const Film full = pt(s);
  Camera c = s.camera;
  c.crop_x = 5, c.crop_y = 3, c.crop_width = 11, c.crop_height = 9;
  s.set_camera(c);
  const Film crop = pt(s);
  ASSERT_EQ(crop.width(), 11);
  ASSERT_EQ(crop.height(), 9);
  const auto& pf = full.pass(pass::kCombined).data;
  const auto& pc = crop.pass(pass::kCombined).data;
  size_t differ = 0;
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 11; ++x)
      for (int k = 0; k < 3; ++k)
        differ += pc[3 * (y * 11 + x) + k] != pf[3 * ((y + 3) * full.width() + x + 5) + k];
  EXPECT_EQ(differ, 0u);
}

TEST(CameraCrop, PhotonMappingCropMatchesTheFullImagesWindow) {
  Scene s = build(kBoxA);
  Params p = photon_params(20000, 3, 2);
  const Film full = render("sppm", s, 3, p);
  Camera c = s.camera;
  c.crop_x = 8, c.crop_y = 4, c.crop_width = 10, c.crop_height = 8;
  s.set_camera(c);
  const Film crop = render("sppm", s, 3, p);
  ASSERT_EQ(crop.width(), 10);
  const auto& pf = full.pass(pass::kCombined).data;
  const auto& pc = crop.pass(pass::kCombined).data;
  double worst = 0;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 10; ++x)
      for (int k = 0; k < 3; ++k) {
        const float a = pc[3 * (y * 10 + x) + k], b = pf[3 * ((y + 4) * full.width() + x + 8) + k];
        worst = std::max(worst, std::abs(double(a) - b) / (std::abs(double(b)) + 1e-3));
      }
  // Same eye paths and photons: only the order of floating-point sums may differ.
  EXPECT_LT(worst, 1e-3);
}

TEST(CameraCrop, LoaderReadsAndChecksTheCrop) {
  const std::string base = R"({"camera": {"position": [0, -3, 1], "look_at": [0, 0, 0], "width": 40, "height": 30, )";
  Scene s = load_scene_from_string(base + R"("crop": [10, 5, 20, 10]}})", ".", "crop.json");
  EXPECT_EQ(s.camera.film_width(), 20);
  EXPECT_EQ(s.camera.film_height(), 10);
  EXPECT_EQ(s.camera.pixel_key(0, 0), size_t(5 * 40 + 10));
  EXPECT_THROW(load_scene_from_string(base + R"("crop": [30, 5, 20, 10]}})", ".", "crop.json"), SceneError);
  EXPECT_THROW(load_scene_from_string(base + R"("crop": [1, 2, 3]}})", ".", "crop.json"), SceneError);
}

// ---- Orthographic projection and shift (the viewport's views, Blender's camera shift) ----

TEST(CameraProjection, OrthographicRaysAreParallelAndSpanTheScale) {
  Camera c;
  c.projection = Projection::Orthographic;
  c.ortho_scale = 4;
  c.width = 40, c.height = 20;
  const Ray left = c.generate_ray({0, 10}, {0.5f, 0.5f}), right = c.generate_ray({40, 10}, {0.5f, 0.5f});
  EXPECT_NEAR(left.o.x, -2, 1e-5);
  EXPECT_NEAR(right.o.x, 2, 1e-5);
  EXPECT_NEAR(left.d.z, -1, 1e-6);
  EXPECT_NEAR(right.d.z, -1, 1e-6);
  EXPECT_NEAR(c.pixel_footprint(1.0f), c.pixel_footprint(7.0f), 1e-7);  // metres, not an angle
  EXPECT_EQ(c.check(), "");
}

TEST(CameraProjection, ShiftMovesThePlaneByTheLargerExtent) {
  Camera c;
  c.fov_degrees = 90;  // half extent 1 at distance 1 on the fitted (wider) axis
  c.width = 40, c.height = 20;
  const Ray centre = c.generate_ray({20, 10}, {0.5f, 0.5f});
  c.shift = Vec2(0.25f, 0.5f);
  const Ray shifted = c.generate_ray({20, 10}, {0.5f, 0.5f});
  EXPECT_NEAR(centre.d.x, 0, 1e-6);
  // Blender: a shift of 1 moves the image by its larger dimension (2 here): (0.5, 1) at z = -1.
  EXPECT_NEAR(shifted.d.x / -shifted.d.z, 0.5f, 1e-5);
  EXPECT_NEAR(shifted.d.y / -shifted.d.z, 1.0f, 1e-5);
}

}  // namespace
}  // namespace gp
