// Image-based lighting (lights/environment_map): Cycles' projections, the sampling density
// against its samples (chi-square), the map through the light set in every kind of method
// (constant map = constant World, a tiny bright sun converging with MIS, SPPM and GPM against
// pt), rotation by Mapping, the shared cache, and a missing HDRI.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "environment_test_util.h"
#include "core/rng.h"
#include "lights/environment_map.h"
#include "render_for_tests.h"
#include "scene/builder.h"
#include "scene/loader.h"
#include "textures/texture_store.h"

namespace gp {
namespace {

// A sky brighter towards +Z with a warm blob towards `sun` (not axis-aligned: the test is not
// symmetric under a wrong sign).
std::shared_ptr<TextureImage> sky_image(int w, int h, Vec3 sun = normalize(Vec3(0.5f, -0.3f, 0.6f))) {
  return map_image(w, h, [&](const Vec3& d, int, int) {
    const float c = dot(d, sun);
    const float blob = c > 0.9f ? 40.0f * (c - 0.9f) / 0.1f : 0.0f;
    return RGB(0.2f + 0.3f * std::max(0.0f, d.z) + blob, 0.25f + 0.3f * std::max(0.0f, d.z) + 0.6f * blob,
               0.4f + 0.2f * std::max(0.0f, d.z) + 0.3f * blob);
  });
}

EnvironmentMapOptions rotated(float deg_x, float deg_y, float deg_z) {
  EnvironmentMapOptions o;
  const Transform r = Transform::rotate(deg_z, Vec3(0, 0, 1)) * Transform::rotate(deg_y, Vec3(0, 1, 0)) *
                      Transform::rotate(deg_x, Vec3(1, 0, 0));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) o.to_map[i][j] = r.m[i][j];
  return o;
}

// ---- Projections ----

TEST(EnvironmentMap, EquirectangularIsCyclesOrientation) {
  // Cycles' direction_to_equirectangular: +X at the image's centre, +Y a quarter to the left,
  // +Z the top row (v = 1).
  auto uv = EnvironmentMap::equirectangular_uv;
  EXPECT_NEAR(uv(Vec3(1, 0, 0)).x, 0.5f, 1e-6f);
  EXPECT_NEAR(uv(Vec3(1, 0, 0)).y, 0.5f, 1e-6f);
  EXPECT_NEAR(uv(Vec3(0, 1, 0)).x, 0.25f, 1e-6f);
  EXPECT_NEAR(uv(Vec3(0, -1, 0)).x, 0.75f, 1e-6f);
  EXPECT_NEAR(uv(Vec3(0, 0, 1)).y, 1.0f, 1e-6f);
  EXPECT_NEAR(uv(Vec3(0, 0, -1)).y, 0.0f, 1e-6f);
  Rng rng(7, 0);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
    const Vec3 back = EnvironmentMap::equirectangular_direction(uv(d));
    EXPECT_LT(length(back - d), 1e-4f);
    const Vec3 mb = EnvironmentMap::mirror_ball_direction(EnvironmentMap::mirror_ball_uv(d));
    if (d.y < 0.99f) EXPECT_LT(length(mb - d), 2e-3f) << d.x << " " << d.y << " " << d.z;
  }
  // The mirror ball seen from -Y: its centre reflects -Y, its rim +Y.
  EXPECT_LT(length(EnvironmentMap::mirror_ball_direction(Vec2(0.5f, 0.5f)) - Vec3(0, -1, 0)), 1e-6f);
}

TEST(EnvironmentMap, EvalReadsTheTexelOfTheDirectionAndRotationTurnsIt) {
  // One bright texel; Closest filtering: eval is that texel in its direction, nothing beside it.
  const int w = 16, h = 8;
  auto img = map_image(w, h, [](const Vec3&, int x, int y) { return x == 10 && y == 5 ? RGB(7.0f) : RGB(0.0f); });
  const Vec3 centre = EnvironmentMap::equirectangular_direction(Vec2(10.5f / w, 5.5f / h));
  EnvironmentMapOptions o;
  o.filter = TextureFilter::Closest;
  o.scale = RGB(2.0f);
  const EnvironmentMap plain(img, o);
  EXPECT_FLOAT_EQ(plain.eval(centre).g, 14.0f);
  // Mapping rotation Z 90 degrees: the texture vector is Rz d, so the texel is now seen along
  // Rz^-1 centre (the World turns by -90 degrees about Z, as Blender's Mapping node does).
  EnvironmentMapOptions r = rotated(0, 0, 90);
  r.filter = TextureFilter::Closest;
  const EnvironmentMap turned(img, r);
  const Vec3 seen(centre.y, -centre.x, centre.z);  // Rz(-90) centre
  EXPECT_FLOAT_EQ(turned.eval(seen).g, 7.0f);
  EXPECT_FLOAT_EQ(turned.eval(centre).g, 0.0f);
  // Same image, projection, filter and resolution: one sampling structure for both.
  EXPECT_EQ(plain.sampling_bytes(), turned.sampling_bytes());
}

TEST(EnvironmentMap, CubicIsCyclesBSpline) {
  // A unit impulse under Cycles' cubic B-spline: 2/3 at its centre, 1/6 one texel away, 1/48 half
  // way between (weights of t = 1/2: 1/48, 23/48, 23/48, 1/48).
  TextureImage img;
  img.width = 8;
  img.height = 8;
  img.rgba.assign(8 * 8 * 4, 0.0f);
  img.rgba[4 * (4 * 8 + 4)] = 1.0f;
  auto at = [&](float x, float y) { return img.lookup(Vec2(x / 8, y / 8), TextureWrap::Repeat, TextureFilter::Cubic).rgb.r; };
  EXPECT_NEAR(at(4.5f, 4.5f), (2.0f / 3) * (2.0f / 3), 1e-6f);
  EXPECT_NEAR(at(5.5f, 4.5f), (1.0f / 6) * (2.0f / 3), 1e-6f);
  EXPECT_NEAR(at(5.0f, 4.5f), (23.0f / 48) * (2.0f / 3), 1e-6f);
}

// ---- Sampling: the density against its samples ----

// Pearson's chi-square of `n` samples of `map` over nt x np cells equal in (cos theta, phi) of
// the world's directions (not the map's cells, so a wrong Jacobian or rotation shows), expected
// counts from the pdf integrated over each cell on a sub x sub grid.
TEST(EnvironmentMap, SamplesFollowTheirDensity) {
  // 100 000 samples; the p-value threshold 1e-4 (after pbrt's chi2 tests) leaves headroom for the
  // expected counts' quadrature (the density is piecewise constant in the map's cells).
  auto img = sky_image(32, 16);
  struct Case {
    const char* name;
    EnvironmentMapOptions o;
  };
  std::vector<Case> cases;
  cases.push_back({"linear", EnvironmentMapOptions()});
  EnvironmentMapOptions closest;
  closest.filter = TextureFilter::Closest;
  cases.push_back({"closest", closest});
  EnvironmentMapOptions cubic = rotated(20, -35, 110);  // rotated: the world's cells are not the map's
  cubic.filter = TextureFilter::Cubic;
  cases.push_back({"cubic rotated", cubic});
  EnvironmentMapOptions manual = rotated(0, 0, 45);
  manual.sampling_width = 12;  // Cycles' Manual map resolution, coarser than the image
  manual.sampling_height = 6;
  cases.push_back({"manual resolution", manual});
  EnvironmentMapOptions sheared;  // a general Mapping (scale): the Jacobian |det A| / |A d|^3
  sheared.to_map[0][0] = 2.0f;
  sheared.to_map[0][1] = 0.5f;
  sheared.to_map[2][2] = 0.7f;
  cases.push_back({"scaled", sheared});
  EnvironmentMapOptions ball;
  ball.projection = EnvProjection::MirrorBall;
  cases.push_back({"mirror ball", ball});
  for (const Case& c : cases) {
    const EnvironmentMap map(img, c.o);
    const Chi2Result r = chi2_of(map, 100000);
    ASSERT_TRUE(r.error.empty()) << c.name << ": " << r.error;
    EXPECT_GT(r.p_value, 1e-4) << c.name << ": chi2 " << r.statistic << " dof " << r.dof;
    EXPECT_EQ(r.zero_expected_hits, 0u) << c.name;
    EXPECT_NEAR(r.pdf_integral, r.accepted_fraction, 0.01) << c.name;
  }
}

TEST(EnvironmentMap, SampledDensityIsPdfAndCoversTheMap) {
  // sample()'s density equals pdf() of its direction, and the density is non-zero wherever the
  // filtered map is (so MIS and photons see every radiance): a one-texel sun in bilinear filtering.
  auto img = map_image(64, 32, [](const Vec3&, int x, int y) { return x == 40 && y == 20 ? RGB(1000.0f) : RGB(0.0f); });
  const EnvironmentMap map(img, rotated(10, 20, 30));
  EnvironmentMapOptions shear = rotated(10, 20, 30);  // a Mapping with scale: |det A| / |A d|^3
  shear.to_map[0][1] += 0.6f;
  shear.to_map[2][2] *= 0.5f;
  const EnvironmentMap sheared(img, shear);
  Rng rng(3, 0);
  for (const EnvironmentMap* m : {&map, &sheared})
    for (int i = 0; i < 20000; ++i) {
      Vec3 d;
      float pdf;
      ASSERT_TRUE(m->sample(Vec2(rng.uniform(), rng.uniform()), &d, &pdf));
      ASSERT_NEAR(m->pdf(d) / pdf, 1.0f, 2e-3f) << (m == &map ? "rotated" : "sheared");
    }
  int missed = 0;
  for (int i = 0; i < 200000; ++i) {
    const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
    missed += map.eval(d).max_component() > 0 && !(map.pdf(d) > 0);
  }
  EXPECT_EQ(missed, 0);
}

TEST(EnvironmentMap, JointQueriesEqualTheSeparateOnes) {
  // eval_pdf (a BSDF ray that left the scene) is eval and pdf bit for bit, from one projection;
  // sample_eval's radiance is eval of the direction drawn (looked up at the drawn image point:
  // the same up to the float rounding of projecting the direction back), in every filter and
  // both projections, under a rotation and a shear.
  auto img = sky_image(64, 32);
  EnvironmentMapOptions shear = rotated(10, 20, 30);
  shear.to_map[0][1] += 0.6f;
  shear.to_map[2][2] *= 0.5f;
  Rng rng(5, 0);
  int compared = 0;
  for (EnvProjection proj : {EnvProjection::Equirectangular, EnvProjection::MirrorBall})
    for (TextureFilter filter : {TextureFilter::Closest, TextureFilter::Linear, TextureFilter::Cubic})
      for (const EnvironmentMapOptions& base : {rotated(10, 20, 30), shear}) {
        EnvironmentMapOptions o = base;
        o.projection = proj;
        o.filter = filter;
        o.scale = RGB(1.5f, 1.0f, 0.5f);
        const EnvironmentMap map(img, o);
        for (int i = 0; i < 4000; ++i) {
          const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
          float pdf = -1;
          const RGB c = map.eval_pdf(d, RayState{}, &pdf);
          const RGB e = map.eval(d);
          ASSERT_EQ(pdf, map.pdf(d));
          ASSERT_TRUE(c.r == e.r && c.g == e.g && c.b == e.b);
          Vec3 ds;
          float pdf_s, pdf_s2;
          RGB Ls;
          const Vec2 u(rng.uniform(), rng.uniform());
          const bool ok = map.sample_eval(u, &ds, &pdf_s, &Ls);
          Vec3 ds2;
          ASSERT_EQ(ok, map.sample(u, &ds2, &pdf_s2));
          if (!ok) continue;
          ASSERT_TRUE(ds.x == ds2.x && ds.y == ds2.y && ds.z == ds2.z && pdf_s == pdf_s2);
          if (filter == TextureFilter::Closest) continue;  // a texel edge may fall either way
          const RGB Le = map.eval(ds);
          for (int k = 0; k < 3; ++k) ASSERT_NEAR(Ls[k], Le[k], 1e-3f * (1.0f + Le[k]));
          ++compared;
        }
      }
  EXPECT_GT(compared, 10000);
}

// ---- In the renderer ----

const char* kBallOnFloor = R"("camera": {"position": [0, -4, 1.5], "look_at": [0, 0, 0.4], "fov": 40, "width": 24, "height": 24},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}, "white": {"type": "diffuse", "color": 0.8}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "grey"},
                {"type": "sphere", "center": [0, 0, 0.6], "radius": 0.6, "segments": 24, "material": "white"}])";

TEST(EnvironmentMap, ConstantMapRendersAsTheConstantWorld) {
  // A map of one colour is the constant World of that colour: same image means (pt, and the
  // light set's power and mean radiance agree with it).
  auto img = map_image(16, 8, [](const Vec3&, int, int) { return RGB(0.5f, 1.0f, 2.0f); });
  const std::string file = write_pfm("constant.pfm", *img);
  const Scene with_map = scene_from(std::string("{") + kBallOnFloor + R"(, "environment": {"type": "map", "image": ")" +
                                    file + R"(", "strength": 1.5}})");
  const Scene constant =
      scene_from(std::string("{") + kBallOnFloor + R"(, "environment": {"color": [0.75, 1.5, 3.0]}})");
  const int env = with_map.light_set().environment();
  ASSERT_GE(env, 0);
  EXPECT_NEAR(with_map.light_set().power(env) / constant.light_set().power(env), 1.0, 1e-3);
  Params p;
  p.set("seed", 5);
  const RGB a = image_mean(render("pt", with_map, 64, p)), b = image_mean(render("pt", constant, 64, p));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c] / b[c], 1.0, 0.01) << "channel " << c;
}

// Radiance of a diffuse plane of albedo `a` facing +Z under an unrotated equirectangular `map`:
// a / pi * the integral of L cos(theta) over the upper hemisphere, by the midpoint rule on a grid
// aligned with the texels (sub x sub points each), so a one-texel sun is integrated exactly
// up to the smooth cos(theta) sin(theta) factor.
double plane_radiance(const EnvironmentMap& map, double a, int sub = 8) {
  const int w = map.image().width * sub, h = map.image().height * sub;
  double s = 0;
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      const Vec2 uv((i + 0.5f) / w, (j + 0.5f) / h);
      const Vec3 d = EnvironmentMap::equirectangular_direction(uv);
      if (d.z <= 0) continue;
      // dw = 2 pi^2 sin(theta) du dv
      s += map.eval(d).g * d.z * 2 * M_PI * M_PI * std::sin(M_PI * (1 - uv.y)) / (double(w) * h);
    }
  return a / M_PI * s;
}

TEST(EnvironmentMap, TinyBrightSunConvergesWithMis) {
  // A one-texel sun 50 000 times the sky (it gives 95 % of the light): next-event estimation
  // from the map's distribution finds it. pt's plane radiance matches the quadrature within 1 %
  // at 64 samples per pixel, and no pixel is a firefly: with closest filtering (the density
  // follows the radiance texel for texel) every pixel is within 25 % of the mean (one light
  // sample per path has a relative deviation of 0.32 here, mostly the sky's samples below the
  // horizon: 4 % per pixel, the worst of 256 pixels about 3 of those).
  auto img = map_image(128, 64, [](const Vec3&, int x, int y) { return x == 70 && y == 50 ? RGB(5000.0f) : RGB(0.1f); });
  const std::string file = write_pfm("sun.pfm", *img);
  for (const char* filter : {"closest", "linear"}) {
    const bool closest = std::string(filter) == "closest";
    const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 16, "height": 16},
      "materials": {"grey": {"type": "diffuse", "color": 0.5}},
      "objects": [{"type": "quad", "center": [0, 0, 0], "u": [1000, 0, 0], "v": [0, 1000, 0], "material": "grey"}],
      "environment": {"type": "map", "image": ")" + file + R"(", "interpolation": ")" + filter + R"("}})");
    const auto& map = dynamic_cast<const EnvironmentMap&>(*s.light_set().lights()[s.light_set().environment()].map);
    const double expect = plane_radiance(map, 0.5);
    Params p;
    p.set("seed", 9);
    p.set("max_depth", 2);
    const Film f = render("pt", s, 64, p);
    const RGB m = image_mean(f);
    EXPECT_NEAR(m.g / expect, 1.0, 0.01) << filter << ": expected " << expect;
    float worst = 0;
    for (int y = 0; y < f.height(); ++y)
      for (int x = 0; x < f.width(); ++x) worst = std::max(worst, std::abs(f.rgb(pass::kCombined, x, y).g / m.g - 1.0f));
    if (closest) EXPECT_LT(worst, 0.25f);
  }
}

TEST(EnvironmentMap, PhotonMethodsAgreeWithPathTracingUnderAMap) {
  // SPPM and GPM (photons emitted from the map's distribution, eye vertices with MIS) against pt
  // on a ball on a floor under a sky with a sun blob: image means within 1 %.
  const std::string file = write_pfm("sky.pfm", *sky_image(64, 32));
  const Scene s = scene_from(std::string("{") + kBallOnFloor + R"(, "environment": {"type": "map", "image": ")" + file +
                             R"(", "rotation": [0, 0, 30]}})");
  Params pt;
  pt.set("seed", 2);
  const RGB ref = image_mean(render("pt", s, 256, pt));
  const RGB sppm = image_mean(render("sppm", s, 32, photon_params(40000, 3)));
  const RGB gpm = image_mean(render("gpm", s, 32, photon_params(40000, 4)));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(sppm[c] / ref[c], 1.0, 0.01) << "sppm channel " << c;
    EXPECT_NEAR(gpm[c] / ref[c], 1.0, 0.01) << "gpm channel " << c;
  }
}

TEST(EnvironmentMap, SpectralMethodsUpsampleEachTexel) {
  // A map half red, half blue seen directly: spectral pt shows each half's colour (a spectrum
  // per texel, not the map's mean purple).
  auto img = map_image(16, 8, [](const Vec3&, int x, int) { return x < 8 ? RGB(1.0f, 0.05f, 0.05f) : RGB(0.05f, 0.05f, 1.0f); });
  const std::string file = write_pfm("halves.pfm", *img);
  // Looking along +Y: the image's left quarter (u = 0.25, red); along -Y its right (blue).
  auto looking = [&](const char* at) {
    return scene_from(std::string(R"({"camera": {"position": [0, 0, 0], "look_at": )") + at +
                      R"(, "fov": 10, "width": 8, "height": 8}, "materials": {}, "objects": [],
      "environment": {"type": "map", "image": ")" + file + R"(", "interpolation": "closest"}})");
  };
  Params p;
  p.set("seed", 1);
  p.set("spectral", std::string("spectral"));
  const RGB red = image_mean(render("spt", looking("[0, 1, 0]"), 64, p));
  const RGB blue = image_mean(render("spt", looking("[0, -1, 0]"), 64, p));
  EXPECT_NEAR(red.r, 1.0, 0.05);
  EXPECT_LT(red.b, 0.15);
  EXPECT_NEAR(blue.b, 1.0, 0.05);
  EXPECT_LT(blue.r, 0.15);
}

TEST(EnvironmentMap, CameraRaysSeeTheirOwnBackground) {
  // Light Path "Is Camera Ray": camera rays see the "camera" background, the floor is lit by
  // the map.
  auto img = map_image(16, 8, [](const Vec3&, int, int) { return RGB(1.0f); });
  const std::string file = write_pfm("white.pfm", *img);
  const Scene s = scene_from(std::string(R"({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 2], "up": [0, 1, 0], "fov": 10, "width": 4, "height": 4},
    "materials": {}, "objects": [],
    "environment": {"type": "map", "image": ")") + file + R"(", "camera": {"color": [0, 1, 0]}}})");
  Params p;
  p.set("seed", 1);
  const RGB m = image_mean(render("pt", s, 4, p));
  EXPECT_NEAR(m.r, 0.0, 1e-6);
  EXPECT_NEAR(m.g, 1.0, 1e-6);
}

TEST(EnvironmentMap, MissingImageIsMagentaWithOneWarning) {
  const Scene s = scene_from(R"({"camera": {"position": [0, 0, 0], "look_at": [0, 1, 0], "fov": 10, "width": 4, "height": 4},
    "materials": {}, "objects": [], "environment": {"type": "map", "image": "no-such-hdri.exr", "strength": 1}})");
  EXPECT_EQ(s.warnings.count("missing image texture (magenta)"), 1u);
  EXPECT_EQ(s.warnings.total(), 1u);
  Params p;
  p.set("seed", 1);
  const RGB m = image_mean(render("pt", s, 2, p));
  EXPECT_NEAR(m.r, 1.0, 1e-5);
  EXPECT_NEAR(m.g, 0.0, 1e-5);
  EXPECT_NEAR(m.b, 1.0, 1e-5);
}

TEST(EnvironmentMap, BadDescriptionsAreClearErrors) {
  auto error_of = [](const std::string& env) {
    try {
      scene_from(R"({"materials": {}, "objects": [], "environment": )" + env + "}");
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of(R"({"type": "map"})").find("image"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "map", "image": "x.exr", "transform": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]})").find("singular"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"type": "map", "image": "x.exr", "projection": "cube"})").find("mirror_ball"), std::string::npos);
  EXPECT_NE(error_of(R"({"type": "sky2"})").find("unknown environment type"), std::string::npos);
  EXPECT_NE(error_of(R"({"color": 1, "image": "x.exr"})").find("map"), std::string::npos);
}

TEST(EnvironmentMap, WorldEditsReuseTheImageAndItsDistribution) {
  // The rendered viewport's World edit (rotation, strength): update_description builds a new
  // map over the same shared image and sampling structure; nothing is read or built again.
  const std::string file = write_pfm("edit.pfm", *sky_image(32, 16));
  auto env = [&](float rot, float strength) {
    return R"({"materials": {"grey": {"type": "diffuse", "color": 0.5}, "white": {"type": "diffuse", "color": 0.8}},
      "environment": {"type": "map", "image": ")" + file + R"(", "rotation": [0, 0, )" +
           std::to_string(rot) + R"(], "strength": )" + std::to_string(strength) + "}}";
  };
  Scene s = scene_from(std::string("{") + kBallOnFloor + R"(, "environment": {"type": "map", "image": ")" + file + R"("}})");
  const size_t images = texture_store_size(), samplings = environment_sampling_cache_size();
  auto env_map = [](const Scene& sc) {
    return dynamic_cast<const EnvironmentMap*>(sc.light_set().lights()[sc.light_set().environment()].map.get());
  };
  ASSERT_TRUE(env_map(s));
  const TextureImage* before = &env_map(s)->image();
  update_description(s, env(90, 2));
  ASSERT_TRUE(env_map(s));
  EXPECT_EQ(&env_map(s)->image(), before);
  EXPECT_EQ(texture_store_size(), images);
  EXPECT_EQ(environment_sampling_cache_size(), samplings);
  EXPECT_FLOAT_EQ(env_map(s)->options().scale.g, 2.0f);
}

}  // namespace
}  // namespace gp

namespace gp {
namespace {

// Not a test: the build time of a 4096 x 2048 map's sampling structure and the memory of an
// 8192 x 4096 one (docs/benchmarks.md, "Environment maps"). Run with
// --gtest_also_run_disabled_tests --gtest_filter='*EnvironmentMapCost*'.
TEST(EnvironmentMap, DISABLED_EnvironmentMapCost) {
  for (auto [w, h] : {std::pair{4096, 2048}, std::pair{8192, 4096}}) {
    auto img = sky_image(w, h);
    for (TextureFilter f : {TextureFilter::Linear, TextureFilter::Closest}) {
      const auto t0 = std::chrono::steady_clock::now();
      const EnvironmentMap map(img, [&] {
        EnvironmentMapOptions o;
        o.filter = f;
        return o;
      }());
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%d x %d %s: build %.3f s, image %.0f MiB, sampling %.0f MiB\n", w, h,
                  f == TextureFilter::Linear ? "linear" : "closest", s, img->bytes() / 1048576.0,
                  map.sampling_bytes() / 1048576.0);
    }
  }
}

}  // namespace
}  // namespace gp
