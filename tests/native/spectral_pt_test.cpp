// Spectral path tracer: agreement with the RGB path tracer on a scene without dispersion,
// analytic furnace answers in spectral mode, Cauchy B = 0 against no dispersion at all, hero vs
// single-wavelength agreement on a dispersive scene, and the spectral mode selection.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "integrators/spectral/spectral_pt.h"
#include "scene/loader.h"
#include "render_for_tests.h"

namespace gp {
namespace {

Scene cornell_box(int size) {
  Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-box.json");
  s.camera.width = s.camera.height = size;
  return s;
}

TEST(SpectralPathTracer, CornellBoxMatchesRgbColours) {
  // No dispersion: spectral and RGB rendering differ only where products of upsampled spectra
  // differ from products of RGB colours (interreflection); the image mean agrees within 1%.
  const Scene s = cornell_box(32);
  Params rgb;
  rgb.set("spectral", "rgb");
  const RGB m_rgb = image_mean(render_with_seed(s, "pt", 1024, rgb));
  const RGB m_spt = image_mean(render_with_seed(s, "spt-hero", 1024));
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(m_spt[c] / m_rgb[c], 1.0, 0.01) << "channel " << c << ": " << m_spt[c] << " vs " << m_rgb[c];
}

TEST(SpectralPathTracer, ColouredFurnaceReproducesTheEnvironment) {
  // Albedo-1 convex object under a uniform coloured sky: the image is the sky's colour, which
  // in spectral mode goes through illuminant upsampling and back through the CMFs.
  const Scene s = scene_from(R"({"camera": {"position": [0, -3, 0], "look_at": [0, 0, 0], "fov": 40, "width": 16, "height": 16},
    "materials": {"white": {"type": "diffuse", "color": 1}},
    "environment": {"color": [0.5, 1.0, 2.0], "strength": 1},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "segments": 32, "material": "white"}]})");
  for (const char* method : {"spt", "spt-hero"}) {
    const RGB m = image_mean(render_with_seed(s, method, std::string(method) == "spt" ? 1024 : 256));
    EXPECT_NEAR(m.r, 0.5, 0.01) << method;
    EXPECT_NEAR(m.g, 1.0, 0.02) << method;
    EXPECT_NEAR(m.b, 2.0, 0.04) << method;
  }
}

const char* kGlassScene = R"({"camera": {"position": [0, -3, 1.2], "look_at": [0, 0, 0.3], "fov": 40, "width": 20, "height": 20},
    "materials": {"white": {"type": "diffuse", "color": [0.8, 0.7, 0.5]},
                  "glass": {"type": "dielectric", "ior": 1.5, "roughness": ROUGH GLASS_B},
                  "light": {"type": "emission", "emission": [1, 0.9, 0.8], "strength": 2}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"},
                {"type": "sphere", "center": [0, 0, 0.5], "radius": 0.4, "segments": 24, "material": "glass"},
                {"type": "quad", "center": [0, 0, 2], "u": [0, 1, 0], "v": [1, 0, 0], "material": "light"}]})";

std::string glass_scene(const std::string& b, float roughness) {
  std::string j = kGlassScene;
  j.replace(j.find("ROUGH"), 5, std::to_string(roughness));
  j.replace(j.find("GLASS_B"), 7, b);
  return j;
}

TEST(SpectralPathTracer, CauchyBZeroIsTheNonDispersiveMaterial) {
  // An explicit "cauchy_b": 0 is no dispersion: same seed, same image, bit for bit.
  const Scene a = scene_from(glass_scene("", 0.0f));
  const Scene b = scene_from(glass_scene(", \"cauchy_b\": 0", 0.0f));
  Params p;
  p.set("spectral", "spectral");
  const Film fa = render_with_seed(a, "pt", 4, p), fb = render_with_seed(b, "pt", 4, p);
  EXPECT_EQ(fa.pass(pass::kCombined).data, fb.pass(pass::kCombined).data);
}

TEST(SpectralPathTracer, VanishingDispersionConvergesToNoDispersion) {
  // A tiny B takes the dispersive code paths (per-wavelength IOR, secondary wavelengths
  // dropped at smooth refraction, per-wavelength pdfs at rough ones) but is physically the
  // non-dispersive glass: the means agree within the noise.
  for (float rough : {0.0f, 0.2f}) {
    const Scene nd = scene_from(glass_scene("", rough));
    const Scene d = scene_from(glass_scene(", \"cauchy_b\": 1e-7", rough));
    const RGB m0 = image_mean(render_with_seed(nd, "spt-hero", 1024));
    const RGB m1 = image_mean(render_with_seed(d, "spt-hero", 1024, Params(nlohmann::json{{"seed", 2}})));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m1[c] / m0[c], 1.0, 0.025) << "roughness " << rough << " channel " << c;
  }
}

TEST(SpectralPathTracer, HeroAndSingleWavelengthAgreeOnDispersiveGlass) {
  // Strong dispersion (dense flint, B = 0.015 um^2), rough and smooth: both estimators are
  // unbiased for the same spectral integral.
  for (float rough : {0.0f, 0.15f}) {
    const Scene s = scene_from(glass_scene(", \"cauchy_b\": 0.015", rough));
    const RGB a = image_mean(render_with_seed(s, "spt", 2048));
    const RGB b = image_mean(render_with_seed(s, "spt-hero", 1024, Params(nlohmann::json{{"seed", 5}})));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(b[c] / a[c], 1.0, 0.025) << "roughness " << rough << " channel " << c;
  }
}

TEST(SpectralMode, SelectionFollowsTheSceneAndTheFlag) {
  EXPECT_EQ(parse_spectral_mode("auto"), SpectralMode::Auto);
  EXPECT_EQ(parse_spectral_mode("rgb"), SpectralMode::Rgb);
  EXPECT_EQ(parse_spectral_mode("spectral"), SpectralMode::Spectral);
  EXPECT_THROW(parse_spectral_mode("hero"), ParamError);

  const Scene plain = scene_from(glass_scene(", \"cauchy_b\": 0", 0.0f));
  const Scene disp = scene_from(glass_scene(", \"abbe\": 30", 0.0f));
  EXPECT_EQ(first_dispersive_material(plain), "");
  EXPECT_EQ(first_dispersive_material(disp), "glass");
  EXPECT_FALSE(use_spectral(SpectralMode::Auto, plain));
  EXPECT_TRUE(use_spectral(SpectralMode::Auto, disp));
  EXPECT_FALSE(use_spectral(SpectralMode::Rgb, disp));
  EXPECT_TRUE(use_spectral(SpectralMode::Spectral, plain));

  auto method_of = [](const Scene& s, const std::string& m, const char* mode) {
    Params p;
    if (mode) p.set("spectral", mode);
    return make_integrator(m, s, p)->name();
  };
  EXPECT_EQ(method_of(plain, "pt", nullptr), "pt");  // auto without dispersion: RGB as before
  EXPECT_EQ(method_of(disp, "pt", nullptr), "spt-hero");
  EXPECT_EQ(method_of(disp, "pt", "rgb"), "pt");
  EXPECT_EQ(method_of(plain, "pt", "spectral"), "spt-hero");
  EXPECT_EQ(method_of(plain, "spt", nullptr), "spt");
  EXPECT_THROW(method_of(plain, "spt-hero", "rgb"), ParamError);
  EXPECT_THROW(method_of(plain, "pt", "maybe"), ParamError);
}

}  // namespace
}  // namespace gp

namespace gp {
namespace {

// Cycles' light disks (a point light of radius 0.3 over a rough mirror): the RGB path shares the
// disk between next-event estimation and BSDF hits by MIS, the spectral path takes it by
// next-event estimation alone; both count it once. Measured with 256 passes: spt-hero / pt 1.004;
// adding the disk's BSDF hits to the spectral path too (counting it twice) gave 1.16.
TEST(SpectralPt, SeesLightDisksAsThePathTracer) {
  const Scene s = scene_from(R"({
    "camera": {"position": [0, -3, 1.2], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40, "width": 24, "height": 18},
    "materials": {"rough": {"type": "conductor", "color": 0.9, "roughness": 0.15, "fresnel": false}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "rough"}],
    "lights": [{"type": "point", "position": [0, 1.0, 1.0], "power": 200, "radius": 0.3}]})");
  Params p;
  p.set("threads", 2);
  const RGB rgb = image_mean(render_with_seed(s, "pt", 256, p));
  const RGB hero = image_mean(render_with_seed(s, "spt-hero", 256, p));
  EXPECT_GT(rgb.luminance(), 0.01f);
  EXPECT_NEAR(hero.luminance() / rgb.luminance(), 1.0, 0.04) << rgb.luminance() << " " << hero.luminance();
}

}  // namespace
}  // namespace gp
