// Image textures (native/textures, materials' textured inputs, normal/bump maps, alpha): the
// lookup against hand-computed values, colour-space conversion, the shared store, and scenes
// whose renders have known answers (a textured quad under a constant environment shows its
// texels; a white normal-mapped quad stays energy-bounded; alpha lets rays through in
// proportion).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>

#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "render_for_tests.h"
#include "scene/loader.h"
#include "scene/shapes.h"
#include "textures/normal_mapping.h"
#include "core/rng.h"
#include "textures/texture_store.h"

namespace gp {
namespace {

std::shared_ptr<TextureImage> image(int w, int h, std::vector<float> rgba) {
  auto img = std::make_shared<TextureImage>();
  img->width = w;
  img->height = h;
  img->rgba = std::move(rgba);
  return img;
}

float srgb_to_linear(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

// ---- Lookup ----

TEST(Texture, BilinearLookupMatchesHandComputedValues) {
  // 2 x 2, row 0 at the bottom: values 0, 1 (bottom), 2, 3 (top) in red.
  auto img = image(2, 2, {0, 0, 0, 1, 1, 0, 0, 1, 2, 0, 0, 1, 3, 0, 0, 1});
  auto red = [&](float u, float v, TextureWrap w) { return img->lookup(Vec2(u, v), w, TextureFilter::Linear).rgb.r; };
  // Texel centres (0.25, 0.25) ... (0.75, 0.75) hold the texels exactly.
  EXPECT_FLOAT_EQ(red(0.25f, 0.25f, TextureWrap::Repeat), 0.0f);
  EXPECT_FLOAT_EQ(red(0.75f, 0.75f, TextureWrap::Repeat), 3.0f);
  // Halfway between all four: their mean; a quarter of the way right of the first centre.
  EXPECT_FLOAT_EQ(red(0.5f, 0.5f, TextureWrap::Repeat), 1.5f);
  EXPECT_FLOAT_EQ(red(0.375f, 0.25f, TextureWrap::Repeat), 0.25f);
  // At u = 0 (between texel 1 of the previous tile and texel 0): Repeat mixes 1 and 0, Extend
  // holds texel 0, Clip fades to transparent black outside.
  EXPECT_FLOAT_EQ(red(0.0f, 0.25f, TextureWrap::Repeat), 0.5f);
  EXPECT_FLOAT_EQ(red(0.0f, 0.25f, TextureWrap::Extend), 0.0f);
  EXPECT_FLOAT_EQ(red(1.0f, 0.25f, TextureWrap::Extend), 1.0f);
  EXPECT_FLOAT_EQ(red(1.0f, 0.25f, TextureWrap::Clip), 0.5f);
  EXPECT_FLOAT_EQ(red(1.5f, 0.25f, TextureWrap::Clip), 0.0f);
  EXPECT_FLOAT_EQ(red(1.25f, 0.75f, TextureWrap::Repeat), 2.0f);
  EXPECT_FLOAT_EQ(red(-0.75f, 0.75f, TextureWrap::Repeat), 2.0f);
  EXPECT_FLOAT_EQ(img->lookup(Vec2(0.6f, 0.4f), TextureWrap::Repeat, TextureFilter::Closest).rgb.r, 1.0f);
  // A mapping (Mapping node) scales uv before the lookup: 2 u repeats the image twice.
  TextureRef t;
  t.image = img;
  t.mapping[0][0] = 2.0f;
  EXPECT_FLOAT_EQ(t.rgb(Vec2(0.125f + 0.5f, 0.25f)).r, 0.0f);
  t.channel = TextureChannel::R;
  t.scale = 0.5f;
  t.square = true;
  EXPECT_FLOAT_EQ(t.value(Vec2(0.625f, 0.75f)), 1.0f);  // (2 * 0.5)^2
}

TEST(Texture, BilinearWrapsEveryTexelAsTheClipPathDoes) {
  // Repeat and Extend look the four texels up with each axis wrapped once (a fast path); the
  // same weights through the per-texel path, written out here, across edges and far tiles.
  std::vector<float> px;
  for (int i = 0; i < 5 * 3; ++i) px.insert(px.end(), {float(i), float(i * i % 7), 0.5f * i, 1.0f - 0.05f * i});
  auto img = image(5, 3, px);
  auto wrapped = [](int i, int n, TextureWrap w) { return w == TextureWrap::Repeat ? ((i % n) + n) % n : std::clamp(i, 0, n - 1); };
  Rng rng(9, 0);
  for (TextureWrap w : {TextureWrap::Repeat, TextureWrap::Extend})
    for (int t = 0; t < 2000; ++t) {
      const Vec2 uv(4.0f * rng.uniform() - 2.0f, 4.0f * rng.uniform() - 2.0f);
      const float fx = uv.x * 5 - 0.5f, fy = uv.y * 3 - 0.5f;
      const float x0f = std::floor(fx), y0f = std::floor(fy), tx = fx - x0f, ty = fy - y0f;
      const int x0 = int(x0f), y0 = int(y0f);
      const float wt[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
      const int xs[4] = {x0, x0 + 1, x0, x0 + 1}, ys[4] = {y0, y0, y0 + 1, y0 + 1};
      float want[4] = {0, 0, 0, 0};
      for (int k = 0; k < 4; ++k) {
        const RGBA c = img->texel(wrapped(xs[k], 5, w), wrapped(ys[k], 3, w));
        const float ch[4] = {c.rgb.r, c.rgb.g, c.rgb.b, c.a};
        for (int j = 0; j < 4; ++j) want[j] += ch[j] * wt[k];
      }
      const RGBA got = img->lookup(uv, w, TextureFilter::Linear);
      const float g[4] = {got.rgb.r, got.rgb.g, got.rgb.b, got.a};
      for (int j = 0; j < 4; ++j) ASSERT_FLOAT_EQ(g[j], want[j]) << uv.x << " " << uv.y << " channel " << j;
    }
}

TEST(Texture, SrgbTexelsBecomeLinearAndDataStaysAsIs) {
  std::vector<float> px = {0.5f, 0.2f, 1.0f, 0.7f};
  convert_to_scene_linear(px, "sRGB");
  EXPECT_NEAR(px[0], srgb_to_linear(0.5f), 2e-3f);  // 0.214
  EXPECT_NEAR(px[1], srgb_to_linear(0.2f), 2e-3f);
  EXPECT_NEAR(px[2], 1.0f, 2e-3f);
  EXPECT_FLOAT_EQ(px[3], 0.7f);  // alpha is never converted
  std::vector<float> data = {0.5f, 0.2f, 1.0f, 0.7f};
  convert_to_scene_linear(data, "Non-Color");
  EXPECT_EQ(data, (std::vector<float>{0.5f, 0.2f, 1.0f, 0.7f}));
  EXPECT_THROW(convert_to_scene_linear(data, "No Such Space"), std::runtime_error);
}

TEST(Texture, FilesAreReadOnceBottomRowFirstAndMissingOnesAreMagenta) {
  // 1 x 2: top texel red, bottom texel blue.
  const std::string path = write_ppm("top_red.ppm", 1, 2, {255, 0, 0, 0, 0, 255});
  TextureLoad a = load_texture(path, "sRGB");
  TextureLoad b = load_texture(path, "sRGB");
  ASSERT_TRUE(a.warning.empty()) << a.warning;
  EXPECT_EQ(a.image.get(), b.image.get());  // shared, not read twice
  EXPECT_NE(load_texture(path, "Non-Color").image.get(), a.image.get());  // another colour space: another image
  EXPECT_FLOAT_EQ(a.image->texel(0, 0).rgb.b, 1.0f);  // row 0 = the file's last row
  EXPECT_FLOAT_EQ(a.image->texel(0, 1).rgb.r, 1.0f);
  EXPECT_NEAR(a.image->mean.rgb.r, 0.5f, 1e-6f);
  TextureLoad missing = load_texture(path + ".nope", "sRGB");
  EXPECT_TRUE(missing.image->missing);
  EXPECT_NE(missing.warning.find("not found"), std::string::npos);
  const RGBA m = missing.image->lookup(Vec2(0.3f, 0.3f), TextureWrap::Repeat, TextureFilter::Linear);
  EXPECT_EQ(m.rgb.r, 1.0f);
  EXPECT_EQ(m.rgb.g, 0.0f);
  EXPECT_EQ(m.rgb.b, 1.0f);
}

// ---- Scenes ----

TEST(TexturedScene, QuadUnderAConstantEnvironmentShowsItsTexels) {
  // 2 x 2 texture (closest): top-left red, top-right green, bottom-left blue, bottom-right grey,
  // sRGB 8-bit: the render must show the linear values.
  const std::string path = write_ppm("quadrants.ppm", 2, 2, {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128});
  const std::string mat = R"({"type": "diffuse", "color": {"texture": ")" + path +
                          R"(", "colorspace": "sRGB", "interpolation": "closest"}})";
  const Scene scene = load_scene_from_string(furnace_scene(mat), ".", "furnace.json");
  const float grey = srgb_to_linear(128 / 255.0f);
  const RGB expect[2][2] = {{RGB(1, 0, 0), RGB(0, 1, 0)}, {RGB(0, 0, 1), RGB(grey)}};
  Params p;
  p.set("seed", 3);
  p.set("photons", int64_t(40000));
  // PPM (photons carry all the light; SPPM would take it by NEE): on an untextured white quad at
  // this budget its 4 x 4-pixel windows stray
  // by up to 0.085 (photon noise); a texture ignored by photons would be off by 0.7.
  for (const auto& [method, tolerance] : {std::pair{"pt", 0.04f}, {"gpt", 0.04f}, {"ppm", 0.12f}}) {
    const Film f = render(method, scene, std::string(method) == "pt" ? 16 : 24, p);
    for (int qy = 0; qy < 2; ++qy)
      for (int qx = 0; qx < 2; ++qx) {
        const RGB c = quadrant_mean(f, qx, qy);
        for (int k = 0; k < 3; ++k)
          EXPECT_NEAR(c[k], expect[qy][qx][k], tolerance) << method << " quadrant " << qx << "," << qy << " channel " << k;
      }
  }
}

TEST(TexturedScene, MixFactorFromATextureWeighsItsComponentsPerPoint) {
  // Factor texture: left column 0 (all of `a`, black), right column 1 (all of `b`, white).
  const std::string path = write_ppm("half.ppm", 2, 1, {0, 0, 0, 255, 255, 255});
  const std::string json = R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 16, "height": 16},
    "materials": {"black": {"type": "diffuse", "color": 0}, "white": {"type": "diffuse", "color": 1},
                  "m": {"type": "mix", "a": "black", "b": "white",
                        "factor": {"texture": ")" + path + R"(", "colorspace": "Non-Color", "interpolation": "closest"}}},
    "objects": [{"type": "mesh", "positions": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                 "indices": [[0, 1, 2], [0, 2, 3]], "uvs": [[0, 0], [1, 0], [1, 1], [0, 1]], "material": "m"}],
    "environment": {"color": [1, 1, 1], "strength": 1}})";
  const Scene scene = load_scene_from_string(json, ".", "mix.json");
  const Film f = render("pt", scene, 16, Params());
  EXPECT_NEAR(quadrant_mean(f, 0, 0).g, 0.0f, 0.01f);
  EXPECT_NEAR(quadrant_mean(f, 1, 0).g, 1.0f, 0.03f);
}

// A quad with a normal map made of one texel (a float image in memory).
Scene normal_mapped_quad(RGB texel, float strength = 1.0f) {
  Scene s;
  Material m;
  m.name = "n";
  m.color = RGB(1.0f);
  m.normal_tex.image = image(1, 1, {texel.r, texel.g, texel.b, 1.0f});
  m.normal_strength = strength;
  s.materials.push_back(m);
  Mesh q;
  q.name = "quad";
  q.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  q.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  q.indices = {0, 1, 2, 0, 2, 3};
  q.material_ids = {0, 0};
  s.meshes.push_back(q);
  s.lights.push_back(Light{});
  s.lights.back().type = LightType::Point;
  s.lights.back().position = Vec3(0, 0, 5);
  s.lights.back().emit = RGB(1.0f);
  s.finalize();
  return s;
}

TEST(NormalMap, FlatMapEqualsNoMapAndATiltedTexelTiltsAlongU) {
  const Ray down(Vec3(0.2f, 0.1f, 2), Vec3(0, 0, -1));
  const auto flat = normal_mapped_quad(RGB(0.5f, 0.5f, 1.0f)).intersect(down);
  ASSERT_TRUE(flat);
  EXPECT_NEAR(flat->ns.z, 1.0f, 1e-6f);
  // t = 2c - 1 = (sin 30deg, 0, cos 30deg): 30 degrees toward +u = +x.
  const float s30 = 0.5f, c30 = std::sqrt(3.0f) / 2;
  const auto tilted = normal_mapped_quad(RGB((s30 + 1) / 2, 0.5f, (c30 + 1) / 2)).intersect(down);
  ASSERT_TRUE(tilted);
  EXPECT_NEAR(tilted->ns.x, s30, 1e-3f);
  EXPECT_NEAR(tilted->ns.y, 0.0f, 1e-3f);
  EXPECT_NEAR(tilted->ns.z, c30, 1e-3f);
  // Strength 0 is no map.
  const auto off = normal_mapped_quad(RGB((s30 + 1) / 2, 0.5f, (c30 + 1) / 2), 0.0f).intersect(down);
  EXPECT_NEAR(off->ns.z, 1.0f, 1e-6f);
  // A map tilted so far that the mirror direction would go below the surface is bent back.
  const Ray grazing(Vec3(-2, 0.1f, 0.5f), normalize(Vec3(2.2f, 0, -0.5f)));
  const auto bent = normal_mapped_quad(RGB(0.98f, 0.5f, 0.6f)).intersect(grazing);
  ASSERT_TRUE(bent);
  const Vec3 wo = -grazing.d;
  const Vec3 r = bent->ns * (2 * dot(bent->ns, wo)) - wo;
  EXPECT_GE(r.z, 0.0f);
}

TEST(NormalMap, WhiteNormalMappedQuadUnderAConstantEnvironmentIsEnergyBounded) {
  // A bumpy normal map (8-bit, Non-Color, tilts up to 45 degrees) on a white diffuse quad under
  // a white environment: the radiance is at most 1 (no energy from a bent frame), and below 1
  // only by the shading hemisphere's part under the geometric surface, which scatters nothing
  // (Bsdf::set_geometric_normal, as Cycles); for PT and PPM alike.
  std::vector<uint8_t> px;
  for (int i = 0; i < 16; ++i) {
    const float a = 0.7f * std::sin(1.3f * i), b = 0.6f * std::cos(2.1f * i);
    const Vec3 n = normalize(Vec3(a, b, 1.0f));
    for (int k = 0; k < 3; ++k) px.push_back(static_cast<uint8_t>(std::lround((n[k] + 1) * 0.5f * 255)));
  }
  const std::string path = write_ppm("bumpy_normals.ppm", 4, 4, px);
  const std::string mat = R"({"type": "diffuse", "color": 1, "normal_map": {"texture": ")" + path + R"("}})";
  const Scene scene = load_scene_from_string(furnace_scene(mat), ".", "furnace.json");
  // (PPM's tolerance as in QuadUnderAConstantEnvironmentShowsItsTexels.)
  for (const auto& [method, tolerance] : {std::pair{"pt", 0.04f}, {"ppm", 0.12f}}) {
    Params p;
    p.set("photons", int64_t(40000));
    const Film f = render(method, scene, 24, p);
    for (int q = 0; q < 4; ++q) {
      const RGB c = quadrant_mean(f, q % 2, q / 2);
      EXPECT_LE(c.g, 1.0f + tolerance) << method << " quadrant " << q;
      EXPECT_GE(c.g, 0.85f - tolerance) << method << " quadrant " << q;
    }
  }
}

// A white diffuse quad whose 1 x 1 normal map tilts every normal `degrees` (40) along u (8-bit texel), and
// that normal in the local frame.
struct TiltedNormalMap {
  std::string path;
  Vec3 ns;
  explicit TiltedNormalMap(int degrees = 40) {
    const float s = std::sin(degrees * kPi / 180.0f), c = std::cos(degrees * kPi / 180.0f);
    const std::vector<uint8_t> texel = {static_cast<uint8_t>(std::lround((s + 1) * 0.5f * 255)), 128,
                                        static_cast<uint8_t>(std::lround((c + 1) * 0.5f * 255))};
    path = write_ppm("tilted_normal_" + std::to_string(degrees) + ".ppm", 1, 1, texel);
    ns = normalize(Vec3(texel[0] / 255.0f * 2 - 1, texel[1] / 255.0f * 2 - 1, texel[2] / 255.0f * 2 - 1));
  }
  std::string material() const {
    return R"({"type": "diffuse", "color": 1, "normal_map": {"texture": ")" + path + R"("}})";
  }
  // The quad's radiance under a white sky of radiance 1, int_{z > 0, w.n_s > 0} G'(w) (w.n_s) dw / pi
  // with G' Cycles' smoothed bump shadowing term, by the midpoint rule over the upper hemisphere.
  double radiance_under_white_sky() const {
    double L = 0;
    const int n = 400;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < 4 * n; ++j) {
        const double ct = (i + 0.5) / n, st = std::sqrt(1 - ct * ct), ph = 2 * M_PI * (j + 0.5) / (4 * n);
        const Vec3 w(float(st * std::cos(ph)), float(st * std::sin(ph)), float(ct));
        const double cs = dot(w, ns);
        if (cs <= 0) continue;
        const double g = std::min(1.0, ct / (cs * ns.z));
        L += (g * (1 + g * (1 - g))) * cs / M_PI * (1.0 / n) * (2 * M_PI / (4 * n));  // dw = d(cos) d(phi)
      }
    return L;
  }
};

TEST(NormalMap, PhotonGathersTakeTheBumpShadowingTermAndTheBentCosine) {
  // The tilted quad under a white sky: PPM lights it by photons alone (deposited at their first
  // hit, gathered at the measurement point), so its gather must shade as the path tracer does:
  // with the bump shadowing term (Scene::bsdf with the point's smooth normal) and the light
  // weighed by the bent normal's cosine, which a density estimate (photons land with their
  // geometric cosine) gets by gather_shading_correction. Both then have the closed form
  // int_{z > 0, w.n_s > 0} G'(w) (w.n_s) dw / pi, G' Cycles' smoothed term. Measured: pt 1.013,
  // ppm 0.989 of it; before the correction ppm was 1.102 (1.088 of pt: it took the geometric
  // cosine), and more again without the normals. MSPPM (photons take about 44 % of its image
  // here, path tracing the rest) 1.006; seen failing at 1.125 without the bent cosine and at
  // 1.071 with its measurement points' BSDF built without the normals. Bound 3 %.
  const TiltedNormalMap map;
  const Scene scene = load_scene_from_string(furnace_scene(map.material()), ".", "furnace.json");
  const double expected = map.radiance_under_white_sky();
  Params p;
  p.set("photons", int64_t(40000));
  const float pt = quadrant_mean(render("pt", scene, 64, Params()), 0, 0).g;
  const float ppm = quadrant_mean(render("ppm", scene, 32, p), 0, 0).g;
  const float msppm = quadrant_mean(render("msppm", scene, 32, p), 0, 0).g;
  std::printf("tilted quad under a sky: pt %.4f, ppm %.4f, msppm %.4f of the closed form %.4f\n", pt / expected,
              ppm / expected, msppm / expected, expected);
  EXPECT_LT(expected, 0.9) << "the term darkens the tilted quad";
  EXPECT_NEAR(pt / expected, 1.0, 0.03) << "pt " << pt << " closed form " << expected;
  EXPECT_NEAR(ppm / expected, 1.0, 0.03) << "ppm " << ppm << " closed form " << expected;
  EXPECT_NEAR(msppm / expected, 1.0, 0.03) << "msppm " << msppm << " closed form " << expected;
}

TEST(NormalMap, SppmGathersOfIndirectLightMatchThePathTracer) {
  // SPPM takes direct light by NEE (as pt) and only indirect light from photons: the tilted
  // quad lit only by a white ceiling (which a lamp facing it lights; both hidden from the
  // camera, the lamp's back towards the quad). Its photons arrive from all over the upper
  // hemisphere, many at grazing angles. Measured against pt at 512 samples: sppm 1.006,
  // sppm-adaptive 1.005, msppm 1.002 (pt at 4096 samples, two seeds, within 0.3 % of each
  // other); before the gather's cosine correction 1.283, 1.287 and 1.176 (msppm, seen failing
  // again with the correction dropped). Bound 3 %.
  const TiltedNormalMap map;
  const Scene scene = scene_from(R"({"camera": {"position": [0, 0, 1.6], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 16, "height": 16},
    "materials": {"m": )" + map.material() + R"(,
                  "ceiling": {"type": "diffuse", "color": 0.9, "visible_to_camera": false},
                  "lamp": {"type": "emission", "emission": 1, "strength": 20, "visible_to_camera": false}},
    "objects": [{"type": "mesh", "positions": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                 "indices": [[0, 1, 2], [0, 2, 3]], "uvs": [[0, 0], [1, 0], [1, 1], [0, 1]], "material": "m"},
                {"type": "quad", "center": [0, 0, 2], "u": [0, 12, 0], "v": [12, 0, 0], "material": "ceiling"},
                {"type": "quad", "center": [0, 0, 1], "u": [0.6, 0, 0], "v": [0, 0.6, 0], "material": "lamp"}]})");
  Params p;
  p.set("photons", int64_t(10000));
  p.set("seed", 2);
  const float pt = image_mean(render("pt", scene, 512, Params())).g;
  for (const char* method : {"sppm", "sppm-adaptive", "msppm"}) {
    const float m = image_mean(render(method, scene, 96, p)).g;
    std::printf("tilted quad lit by the ceiling: %s %.4f of pt\n", method, m / pt);
    EXPECT_NEAR(m / pt, 1.0, 0.03) << method << " " << m << " pt " << pt;
  }
  // GPM's primal is SPPM's image (its gather takes the same bent cosine: seen failing without it),
  // and its combined is as bright as pt's (measured 1.011; the offsets' own bent cosine is not
  // what this checks: without it 1.017, inside the bound, as the solve keeps the primal's mean).
  const Film sppm = render("sppm", scene, 24, p), gpm = render("gpm", scene, 24, p);
  const auto& a = gpm.pass(pass::kPrimal).data;
  const auto& b = sppm.pass(pass::kCombined).data;
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-4f * (1 + std::abs(b[i]))) << i;
  const float g = image_mean(gpm).g;
  std::printf("tilted quad lit by the ceiling: gpm %.4f of pt\n", g / pt);
  EXPECT_NEAR(g / pt, 1.0, 0.03) << "gpm " << g << " pt " << pt;
}

TEST(NormalMap, SpectralMethodsTakeTheBumpShadowingTerm) {
  // The tilted quad under a white sky (a grey scene: spectral upsampling is exact) in the
  // spectral methods, against the closed form of PhotonGathersTakeTheBumpShadowingTermAndTheBentCosine:
  // spt and sgpt (per-wavelength BSDFs with the hit's normals) and SPPM with spectral photons,
  // whose eye paths light the measurement point by next-event estimation alone here. Measured
  // (seed 2; seeds 2-4 at 256 passes within 2.1 %): spt 1.008, sgpt 1.000, spectral SPPM 1.004;
  // with per-wavelength BSDFs made without the normals (no bump shadowing term, no
  // geometric-side test: the sky below the quad lights it), sgpt 1.299, spectral SPPM 1.300.
  // Bound 3 %.
  const TiltedNormalMap map;
  const Scene scene = load_scene_from_string(furnace_scene(map.material()), ".", "furnace.json");
  const double expected = map.radiance_under_white_sky();
  Params p;
  p.set("seed", 2);
  Params photons = photon_params(2000, 2);  // (direct light only: no photon is gathered)
  photons.set("spectral", "spectral");
  for (const auto& [method, passes, params] :
       {std::tuple{"spt", 1024, p}, std::tuple{"sgpt", 512, p}, std::tuple{"sppm", 512, photons}}) {
    const float m = image_mean(render(method, scene, passes, params)).g;  // the quad fills the view
    std::printf("tilted quad under a sky: %s %.4f of the closed form\n", method, m / expected);
    EXPECT_NEAR(m / expected, 1.0, 0.03) << method << " " << m << " closed form " << expected;
  }
}

// A white floor under a white sky seen from above, its left half (x < 0) tilted by `map`, its
// right half plain: a step in brightness where the map ends.
std::string half_mapped_floor(const TiltedNormalMap& map) {
  return R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 16, "height": 48},
    "materials": {"m": )" + map.material() + R"(, "plain": {"type": "diffuse", "color": 1}},
    "objects": [{"type": "mesh", "positions": [[-1, -3, 0], [0, -3, 0], [0, 3, 0], [-1, 3, 0]],
                 "indices": [[0, 1, 2], [0, 2, 3]], "uvs": [[0, 0], [1, 0], [1, 1], [0, 1]], "material": "m"},
                {"type": "quad", "center": [0.5, 0, 0], "u": [0.5, 0, 0], "v": [0, 3, 0], "material": "plain"}],
    "environment": {"color": [1, 1, 1], "strength": 1}})";
}

TEST(NormalMap, GradientPathTracingShiftsShadeAsTheBase) {
  // E[gpt's x-gradients] across the step of half_mapped_floor = the closed-form step: the sum,
  // over the rows, of the gradients of the three pixel pairs from column 6 (wholly on the tilted
  // half) to column 9 (wholly plain) has the expectation rows x (1 - L), L the tilted quad's
  // radiance; a z-test over passes (|z| < 4). An offset that shades its own vertex without the
  // map's normals (no bump shadowing term: brighter on the tilted half) biases the pairs whose
  // two pixels differ in the map. Measured (seeds 3-5): z 0.93, -0.31, 0.45 (the sum 1.007,
  // 0.998, 1.003 of the closed form); with the offset's own vertex rebuilt from its material and
  // uv without its normals (before issue 14), z -8.4 to -10.4 (0.92 of it).
  const TiltedNormalMap map;
  const Scene scene = scene_from(half_mapped_floor(map));
  Params p;
  p.set("seed", 3);
  p.set("max_depth", 3);
  auto integ = make_integrator("gpt", scene, p);
  const int passes = 1024, c0 = 6, c1 = 9;  // the step lies between columns 7 and 8
  double prev = 0, sum = 0, sum2 = 0;
  int rows = 0;
  for (int k = 1; k <= passes; ++k) {
    integ->iterate(nullptr);
    Film f;
    integ->develop(f);
    double g = 0;  // the mean so far of the gradients summed over the pairs
    rows = f.height();
    for (int y = 0; y < f.height(); ++y)
      for (int x = c0; x < c1; ++x) g += f.rgb(pass::kGradientX, x, y).g;
    const double v = g * k - prev;  // this pass's value
    prev = g * k;
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / passes, se = std::sqrt(std::max(0.0, sum2 / passes - mean * mean) / (passes - 1));
  const double expected = rows * (1.0 - map.radiance_under_white_sky());
  ASSERT_TRUE(std::isfinite(mean) && std::isfinite(se) && se > 0);
  std::printf("gpt on a half-mapped floor: gradients across the step %.4f +- %.4f, closed form %.4f, z %.2f\n", mean, se,
              expected, (mean - expected) / se);
  EXPECT_LT(std::abs(mean - expected) / se, 4.0);
}

TEST(TexturedScene, BadTextureReferencesNameTheirPath) {
  auto load = [](const std::string& tex) {
    return load_scene_from_string(furnace_scene(R"({"type": "diffuse", "color": )" + tex + "}"), ".", "bad.json");
  };
  try {
    load(R"({"texture": "x.png", "wrap": "mirror"})");
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("/materials/m/color/wrap"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load(R"({"texture": 3})"), SceneError);
  EXPECT_THROW(load(R"({"texture": "x.png", "mapping": [[1, 0]]})"), SceneError);
  // A missing file is no error: magenta and a counted warning, as Cycles.
  const Scene s = load(R"({"texture": "no/such/file.png"})");
  EXPECT_EQ(s.warnings.count("missing image texture (magenta)"), 1u);
}

}  // namespace
}  // namespace gp
