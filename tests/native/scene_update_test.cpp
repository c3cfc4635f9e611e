// Updates of a finalized scene (scene.h "Updates", builder.h update_description/set_camera) and
// the camera's crop window: each update renders what a fresh build of the updated scene renders
// (path tracing keys every pixel's random stream by its place in the image, so the images match
// bit for bit, except where a moved mesh is involved: see expect_close).
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include "core/film.h"
#include "integrators/integrator.h"
#include "render_for_tests.h"
#include "scene/accel.h"
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
const float kCubeUv[] = {0, 0, 1, 0, 1, 1, 0, 1, 0.2f, 0.1f, 0.9f, 0.3f, 0.7f, 0.8f, 0.1f, 0.6f};  // distinct per vertex
const uint32_t kCubeIdx[] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                             1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};

Transform trs(Vec3 t, float degrees_z, Vec3 s) {
  return Transform::translate(t) * Transform::rotate(degrees_z, Vec3(0, 0, 1)) * Transform::scale(s);
}

const Transform kBoxA = trs({-0.3f, 0.2f, 0.3f}, 20, {0.3f, 0.3f, 0.3f});
const Transform kBoxB = trs({0.35f, -0.1f, 0.45f}, -35, {0.25f, 0.4f, 0.45f});

const Transform kLampUp = Transform::translate({0, 0, 2}) * Transform::rotate(180, {1, 0, 0}) *
                          Transform::scale({0.4f, 0.4f, 1});

Scene build(const Transform& box, const std::string& desc = description(), const Transform& lamp = kLampUp) {
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
    if (p == kCube) m.uvs = kCubeUv;
    m.materials = {mat};
    m.instances = {t};
    b.add_mesh(m);
  };
  add("floor", kQuad, 4, kQuadIdx, 2, "white", Transform::scale({3, 3, 1}));
  Transform wall = Transform::translate({0, 1.5f, 1.5f}) * Transform::rotate(90, {1, 0, 0}) * Transform::scale({3, 1.5f, 1});
  add("wall", kQuad, 4, kQuadIdx, 2, "white", wall);
  // Facing down: the lamp emits from its front (the quad's +Z turned to -Z).
  add("lamp", kQuad, 4, kQuadIdx, 2, "lamp", lamp);
  add("box", kCube, 8, kCubeIdx, 12, "box", box);
  return b.finalize();
}

constexpr size_t kLamp = 2, kBox = 3;  // indices of the lamp and the box among the meshes

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

// A moved mesh is traced in its object space through an Embree instance (Accelerator::move_mesh):
// the ray is transformed into object space, so t and the barycentrics differ from a fresh build's
// (world-space triangles) in the last bits, and so do the pixels that see it, directly or not
// (measured: 13 % of the values of a 96x72 render, by 1e-9 on average, none by 1e-3). With the
// same random numbers the paths are the same, so the images agree far more closely than any
// statistical test could tell: every value within 1e-4 relative, but for a few paths that a
// last-bit difference sends another way (a ray grazing an edge, a Russian roulette at the
// threshold), at most 1 % of the values.
void expect_close(const Film& a, const Film& b, size_t per_cent = 1) {
  const auto& pa = a.pass(pass::kCombined).data;
  const auto& pb = b.pass(pass::kCombined).data;
  ASSERT_EQ(pa.size(), pb.size());
  size_t off = 0;
  for (size_t i = 0; i < pa.size(); ++i) off += !(std::abs(pa[i] - pb[i]) <= 1e-4f * std::abs(pb[i]) + 1e-7f);
  EXPECT_LE(off, pa.size() * per_cent / 100) << "of " << pa.size() << " values";
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
  expect_close(after, pt(build(kBoxB)));
  EXPECT_NE(mean(before), mean(after));  // the test can tell the two places apart
  // (and expect_close can: the unmoved render is far from the moved one)
  EXPECT_NONFATAL_FAILURE(expect_close(before, after), "values");
}

TEST(SceneUpdate, OnlyMovedMeshesAreInstanced) {
  Scene s = build(kBoxA);
  update_description(s, description("[0.1, 0.3, 0.8]"));
  s.set_mesh_transform(kBox, kBoxA);  // the place it has: not a move
  s.commit();
  for (size_t i = 0; i < s.meshes.size(); ++i) EXPECT_FALSE(s.accelerator().instanced(i)) << i;
  s.set_mesh_transform(kBox, kBoxB);
  s.commit();
  for (size_t i = 0; i < s.meshes.size(); ++i) EXPECT_EQ(s.accelerator().instanced(i), i == kBox) << i;
}

// Moved twice (the second move only sets the instance's matrix) renders bit for bit as moved
// once to the same place (the same object-space triangles under the same matrix), and as a
// fresh build up to expect_close.
TEST(SceneUpdate, MovedTwiceRendersAsMovedOnce) {
  const Transform kBoxC = trs({0.1f, 0.3f, 0.5f}, 77, {0.2f, 0.5f, 0.3f});
  Scene twice = build(kBoxA), once = build(kBoxA);
  twice.set_mesh_transform(kBox, kBoxB);
  twice.commit();
  const Film at_b = pt(twice);
  twice.set_mesh_transform(kBox, kBoxC);
  twice.commit();
  once.set_mesh_transform(kBox, kBoxC);
  once.commit();
  const Film at_c = pt(twice);
  expect_same(at_c, pt(once));
  expect_close(at_c, pt(build(kBoxC)));
  EXPECT_NE(mean(at_b), mean(at_c));
}

TEST(SceneUpdate, MirroredAndBackKeepsWindingAndNormals) {
  const Transform mirrored = kBoxB * Transform::scale({-1, 1, 1});
  Scene s = build(kBoxA);
  s.set_mesh_transform(kBox, mirrored);
  s.commit();
  expect_close(pt(s), pt(build(mirrored)));
  s.set_mesh_transform(kBox, kBoxA);
  s.commit();
  expect_close(pt(s), pt(build(kBoxA)));
}

// The rays of the integrators' batches (intersect_stream, occluded_stream) see a moved mesh as the
// single-ray calls do, and hits name the mesh (geom = mesh index, not Embree's instance).
TEST(SceneUpdate, MovedMeshInRayStreams) {
  Scene s = build(kBoxA);
  s.set_mesh_transform(kBox, kBoxB);
  s.commit();
  const Scene fresh = build(kBoxB);
  Rng rng(11, 0);
  std::vector<Ray> rays;
  for (int i = 0; i < 2000; ++i) {  // from around the room towards the box's region
    const Vec3 o(3 * rng.uniform() - 1.5f, -2.5f + rng.uniform(), 2 * rng.uniform());
    const Vec3 target(0.35f + 0.8f * (rng.uniform() - 0.5f), -0.1f + 0.8f * (rng.uniform() - 0.5f), rng.uniform());
    rays.emplace_back(o, normalize(target - o));
    rays.back().tmax = 0.5f + 4 * rng.uniform();  // some end short (occlusion both ways)
  }
  std::vector<RawHit> hits(rays.size());
  std::unique_ptr<bool[]> found(new bool[rays.size()]), blocked(new bool[rays.size()]);
  const Accelerator& acc = s.accelerator();
  acc.intersect_stream(rays.data(), rays.size(), hits.data(), found.get());
  acc.occluded_stream(rays.data(), rays.size(), blocked.get());
  size_t on_box = 0, other_triangle = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    RawHit one, flat;
    const bool f = acc.intersect(rays[i], one);
    ASSERT_EQ(f, found[i]) << i;
    EXPECT_EQ(blocked[i], acc.occluded(rays[i])) << i;
    const bool ff = fresh.accelerator().intersect(rays[i], flat);
    if (!f) continue;
    EXPECT_EQ(one.geom, hits[i].geom);
    EXPECT_EQ(one.prim, hits[i].prim);
    EXPECT_EQ(one.t, hits[i].t);
    on_box += one.geom == static_cast<int>(kBox);
    if (!ff || flat.geom != one.geom || flat.prim != one.prim) {
      ++other_triangle;  // a ray through an edge, by the last bits
      continue;
    }
    EXPECT_NEAR(one.t, flat.t, 1e-5f * flat.t);
    EXPECT_NEAR(one.u, flat.u, 1e-4f);
    EXPECT_NEAR(one.v, flat.v, 1e-4f);
  }
  EXPECT_GT(on_box, rays.size() / 5);
  EXPECT_LE(other_triangle, rays.size() / 200);
}

const Transform kLampLower = Transform::translate({0.5f, 0, 1.2f}) * Transform::rotate(180, {1, 0, 0}) *
                             Transform::scale({0.4f, 0.4f, 1});

// An emissive mesh moved: the area lights come from its world-space arrays (the lights, next-event
// estimation) and camera rays find it through its instance; both must agree with a fresh build.
TEST(SceneUpdate, MovedLampRendersAsAFreshBuild) {
  Scene s = build(kBoxA);
  s.set_mesh_transform(kLamp, kLampLower);
  s.commit();
  ASSERT_TRUE(s.accelerator().instanced(kLamp));
  const Film moved = pt(s);
  expect_close(moved, pt(build(kBoxA, description(), kLampLower)));
  EXPECT_NONFATAL_FAILURE(expect_close(moved, pt(build(kBoxA))), "values");
}

// A cut-out box (alpha: a Mix with a Transparent BSDF, whose factor is looked up at the hit; shadow
// rays pass by Embree's filter functions on the instanced triangles). Alpha from a texture of one
// black and one white texel cuts each face in two where u = 0.5: the alpha (0 or 1) is looked up
// at the hit's uv, from the barycentrics in the mesh's index order, so the moved box must cut
// exactly where the fresh one does, mirrored too.
TEST(SceneUpdate, MovedCutOutMeshRendersAsAFreshBuild) {
  const std::string tex = testing::TempDir() + "gp_scene_update_alpha.ppm";
  {
    std::ofstream f(tex, std::ios::binary);
    f << "P6\n2 1\n255\n";
    const unsigned char px[] = {0, 0, 0, 255, 255, 255};
    f.write(reinterpret_cast<const char*>(px), sizeof px);
  }
  const std::string desc = description(R"([0.7, 0.2, 0.1], "alpha": {"texture": ")" + tex +
                                       R"(", "channel": "r", "interpolation": "closest"})");
  const Transform mirrored = kBoxB * Transform::scale({-1, 1, 1});
  for (const Transform& to : {kBoxB, mirrored}) {
    Scene s = build(kBoxA, desc);
    s.set_mesh_transform(kBox, to);
    s.commit();
    const Film moved = pt(s);
    // 3 %: a path through the cut half now goes on from the hit (a transparent pass, a new ray
    // from a point that differs in its last bits) where Embree's cut-out filter let the same ray
    // through, so more paths diverge (measured: 24 of 1296 values); the opaque box differs in
    // hundreds.
    expect_close(moved, pt(build(to, desc)), 3);
    EXPECT_NONFATAL_FAILURE(expect_close(moved, pt(build(to)), 3), "values");  // the cut shows
  }
}

// Constant alpha 0.5 (a Mix with a Transparent BSDF: paths pick it by weight; it was a cut-out
// decided by a hash of the ray, which for an instanced mesh is the ray in object space): the
// images agree statistically. Means over the image of 64 passes at 12x9: the fresh
// and the moved render within 1.5 % (their difference measured 0.5 %), while the opaque box's
// render is 8 % off (measured), so the test can tell a box that lost its alpha.
TEST(SceneUpdate, MovedHalfTransparentMeshRendersAsAFreshBuildOnAverage) {
  const std::string cam = R"({"position": [0, -3, 1], "look_at": [0, 0, 0.6], "fov": 50, "width": 12, "height": 9})";
  const std::string desc = description(R"([0.7, 0.2, 0.1], "alpha": 0.5)", 10.0f, cam);
  Scene s = build(kBoxA, desc);
  s.set_mesh_transform(kBox, kBoxB);
  s.commit();
  const double moved = mean(pt(s, 64)), fresh = mean(pt(build(kBoxB, desc), 64));
  const double opaque = mean(pt(build(kBoxB, description("[0.7, 0.2, 0.1]", 10.0f, cam)), 64));
  EXPECT_NEAR(moved / fresh, 1.0, 0.015);
  EXPECT_GT(std::abs(opaque / fresh - 1.0), 0.03);
}

TEST(SceneUpdate, MovedLampMovesTheLight) {
  Scene s = build(kBoxA);
  const double before = mean(pt(s));
  s.set_mesh_transform(kLamp, kLampLower);
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
