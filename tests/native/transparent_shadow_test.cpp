// Cycles' transparent shadows (paths/medium_walk.h ShadowTest, Scene::transparent_bounces): a
// shadow ray passes a Transparent BSDF multiplied by the closure's weight at the hit, in every
// method's next-event estimation, up to Light Paths > Transparent bounces.
//
// The scene: a diffuse floor (albedo 0.5) under a point light, and between them a pane that
// camera rays do not see. Nothing else is in the scene and there is no World, so the floor's
// radiance is its direct light only: with the pane transparent to shadows (colour c), exactly c
// times the floor's without the pane's shadow, per pixel (the random numbers are consumed alike).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "render_for_tests.h"

namespace gp {
namespace {

// `pane`: the pane's material JSON ("" for no pane); `extra`: more top-level keys; `light`:
// the lights' JSON.
std::string pane_scene(const std::string& pane, const std::string& extra = "",
                       const std::string& light = R"([{"type": "point", "position": [0, 0, 2], "intensity": 10}])",
                       const std::string& more_objects = "") {
  std::string s = R"({"camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 20, "width": 16, "height": 16},
    "materials": {"floor": {"type": "diffuse", "color": 0.5})";
  if (!pane.empty()) s += R"(, "pane": )" + pane;
  s += R"(, "red": {"type": "transparent", "color": [1, 0.2, 0.1]}, "grey": {"type": "diffuse", "color": 0.8}},
    "lights": )" + light + R"(,
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "floor"})";
  if (!pane.empty())
    s += R"(, {"type": "quad", "center": [0, 0, 1], "u": [4, 0, 0], "v": [0, 4, 0], "material": "pane"})";
  s += more_objects + "]" + extra + "}";
  return s;
}

Params seeded(int max_depth = 8) {
  Params p;
  p.set("seed", 3);
  p.set("max_depth", max_depth);
  return p;
}

// The red pane as a plain material, hidden from the camera, casting shadows or not.
std::string red_pane(bool casts_shadow) {
  return std::string(R"({"type": "transparent", "color": [1, 0.2, 0.1], "visible_to_camera": false, "casts_shadow": )") +
         (casts_shadow ? "true" : "false") + "}";
}

void expect_ratio(const RGB& shadowed, const RGB& open, const RGB& expected, float tolerance, const char* what) {
  for (int k = 0; k < 3; ++k) {
    ASSERT_GT(open[k], 0.0f) << what;
    EXPECT_NEAR(shadowed[k] / open[k], expected[k], tolerance) << what << " channel " << k;
  }
  std::printf("%s: shadowed / open = %.5f %.5f %.5f (expected %.3f %.3f %.3f)\n", what, shadowed.r / open.r,
              shadowed.g / open.g, shadowed.b / open.b, expected.r, expected.g, expected.b);
}

TEST(TransparentShadow, RedPaneTintsTheFloorUnderItExactly) {
  // pt and gpt (whose offsets take the base's factor where they share its vertex): the floor
  // under the pane is exactly red times the floor without the pane's shadow (gpt: to its
  // reconstruction, 1e-3).
  const Scene open = scene_from(pane_scene(red_pane(false)));
  const Scene shadowed = scene_from(pane_scene(red_pane(true)));
  ASSERT_TRUE(shadowed.has_transparent_shadows());
  EXPECT_EQ(shadowed.transparent_bounces, 8);  // Cycles' default
  const RGB red(1.0f, 0.2f, 0.1f);
  for (const char* method : {"pt", "gpt"}) {
    const int passes = std::string(method) == "gpt" ? 16 : 4;
    const RGB a = image_mean(render(method, shadowed, passes, seeded()));
    const RGB b = image_mean(render(method, open, passes, seeded()));
    expect_ratio(a, b, red, std::string(method) == "gpt" ? 1e-3f : 1e-4f, method);
  }
}

TEST(TransparentShadow, PhotonsThatOnlyCrossedThePaneAreNotStored) {
  // SPPM's measurement points take the pane's red by next-event estimation; a photon that only
  // passed the pane is that direct light again and must not be stored, or the floor is lit
  // twice (1.44x here). Nothing else lights the floor: SPPM's image is pt's, to round-off.
  // (PPM takes all light from photons, no next-event estimation: nothing to check here.)
  const Scene shadowed = scene_from(pane_scene(red_pane(true)));
  const RGB pt = image_mean(render("pt", shadowed, 8, seeded()));
  const RGB sppm = image_mean(render("sppm", shadowed, 8, photon_params(20000, 3)));
  expect_ratio(sppm, pt, RGB(1.0f), 1e-4f, "sppm / pt");
}

TEST(TransparentShadow, SpectralMethodsUpsampleTheColourPerWavelength) {
  // spt, spt-hero and sgpt (its offsets at their own wavelengths): the pane's red upsampled at
  // each wavelength (Jakob-Hanika), whose image is the red back within the upsampling's round
  // trip (3 %).
  const Scene open = scene_from(pane_scene(red_pane(false)));
  const Scene shadowed = scene_from(pane_scene(red_pane(true)));
  for (const char* method : {"spt", "spt-hero", "sgpt"}) {
    Params p = seeded();
    if (std::string(method) != "sgpt") p.set("spectral", std::string("spectral"));
    const RGB a = image_mean(render(method, shadowed, 16, p));
    const RGB b = image_mean(render(method, open, 16, p));
    expect_ratio(a, b, RGB(1.0f, 0.2f, 0.1f), 0.03f, method);
  }
}

TEST(TransparentShadow, MixWeighsTheTransparentClosure) {
  // A Mix of the red Transparent BSDF (a) and a grey diffuse (b) by factor 0.25: the shadow keeps
  // (1 - 0.25) red (Cycles' shader_bsdf_transparency sums the closures' mix weights).
  const std::string mix = R"({"type": "mix", "a": "red", "b": "grey", "factor": 0.25, "visible_to_camera": false})";
  const Scene shadowed = scene_from(pane_scene(mix));
  const Scene open = scene_from(pane_scene(red_pane(false)));
  ASSERT_TRUE(shadowed.has_transparent_shadows());
  // The floor's bounce rays now meet a diffuse part of the pane (indirect light): one bounce only.
  const RGB a = image_mean(render("pt", shadowed, 4, seeded(2)));
  const RGB b = image_mean(render("pt", open, 4, seeded(2)));
  expect_ratio(a, b, RGB(0.75f, 0.15f, 0.075f), 1e-4f, "mix 0.25");
}

TEST(TransparentShadow, AlphaIsAMixWithAWhiteTransparentBsdf) {
  // Cycles 3.4's Principled Alpha a (shader_nodes.cpp PrincipledBsdfNode::expand): a Mix Shader
  // of a Transparent BSDF (weight 1 - a) and the rest (weight a), the emission inside it. The
  // scene format's `alpha` loads as that mix, so a shadow ray keeps exactly 1 - a (it was a
  // stochastic cut-out: 0.75 only on average) and the emission is weighted by a.
  const std::string leaf = R"({"type": "diffuse", "color": 0.8, "alpha": 0.25, "visible_to_camera": false})";
  const Scene shadowed = scene_from(pane_scene(leaf));
  const Scene open = scene_from(pane_scene(red_pane(false)));
  ASSERT_TRUE(shadowed.has_transparent_shadows());
  const RGB b = image_mean(render("pt", open, 4, seeded(2)));
  expect_ratio(image_mean(render("pt", shadowed, 4, seeded(2))), b, RGB(0.75f), 1e-4f, "alpha 0.25, pt");
  // Every method renders it as the mix written out (the photon methods' indirect light off the
  // leaf's diffuse part included): sppm and msppm bit for bit.
  std::string mix = pane_scene(R"({"type": "mix", "a": "clear", "b": "leaf", "factor": 0.25, "visible_to_camera": false})");
  mix.replace(mix.find(R"("materials": {)"), 14,
              R"("materials": {"clear": {"type": "transparent", "color": 1}, "leaf": {"type": "diffuse", "color": 0.8}, )");
  const Scene written = scene_from(mix);
  for (const char* method : {"sppm", "msppm"}) {
    const RGB a = image_mean(render(method, shadowed, 2, photon_params(5000, 3)));
    const RGB w = image_mean(render(method, written, 2, photon_params(5000, 3)));
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a[k], w[k]) << method << " channel " << k;
  }
  const Scene glow = scene_from(pane_scene(R"({"type": "diffuse", "alpha": 0.3, "emission": [1, 1, 1], "strength": 2})"));
  for (const Material& m : glow.materials)
    if (m.name == "pane") {
      EXPECT_EQ(m.type, MaterialType::Mix);
      ASSERT_TRUE(m.mix_a && m.mix_b);
      EXPECT_TRUE(m.mix_a->has_transparent_closure());
      EXPECT_EQ(m.mix_b->type, MaterialType::Diffuse);
      EXPECT_FLOAT_EQ(m.mix_factor, 0.3f);
      EXPECT_NEAR(m.radiance().r, 0.6f, 1e-6f);
      EXPECT_TRUE(m.mix_b->radiance().is_black());
    }
}

TEST(TransparentShadow, TransparentBouncesLimitTheSurfacesCrossed) {
  // Two red panes: the shadow ray crosses at most max(transparent_bounces - 0 - 1, 0) of them
  // (Cycles' integrate_shadow_max_transparent_hits): 3 lets both through (red squared), 2 one,
  // so the second blocks it.
  const std::string second =
      R"(, {"type": "quad", "center": [0, 0, 1.5], "u": [4, 0, 0], "v": [0, 4, 0], "material": "pane"})";
  const std::string light = R"([{"type": "point", "position": [0, 0, 2], "intensity": 10}])";
  const Scene open = scene_from(pane_scene(red_pane(false), "", light, second));
  const Scene three = scene_from(pane_scene(red_pane(true), R"(, "transparent_bounces": 3)", light, second));
  const Scene two = scene_from(pane_scene(red_pane(true), R"(, "transparent_bounces": 2)", light, second));
  const RGB b = image_mean(render("pt", open, 4, seeded()));
  expect_ratio(image_mean(render("pt", three, 4, seeded())), b, RGB(1.0f, 0.04f, 0.01f), 1e-4f, "two panes, 3 bounces");
  const RGB blocked = image_mean(render("pt", two, 4, seeded()));
  EXPECT_EQ(blocked.r, 0.0f);
  EXPECT_EQ(blocked.g, 0.0f);
  EXPECT_THROW(scene_from(pane_scene(red_pane(true), R"(, "transparent_bounces": -1)")), std::exception);
}

TEST(TransparentShadow, AreaLightIsCountedOnceThroughThePane) {
  // An area light above the pane: next-event estimation through the pane and the floor's BSDF
  // rays through it to the light share the light by MIS, as Cycles keeps mis_ray_pdf across a
  // transparent bounce; counted twice, the floor would be ~1.5-2x red. Against the scene without
  // a pane (whose floor's light is the same but not red): red within 2 % (pt and spt-hero,
  // 1024 samples a pixel; seen at 0.3 % / 0.6 % with seed 3).
  const std::string lamp = R"([])";
  const std::string panel = R"(, {"type": "quad", "center": [0, 0, 2], "u": [1, 0, 0], "v": [0, 1, 0], "material": "lamp"})";
  auto scene = [&](const std::string& pane) {
    std::string s = pane_scene(pane, "", lamp, panel);
    const std::string key = R"("grey": {"type": "diffuse", "color": 0.8})";
    s.replace(s.find(key), key.size(),
              key + R"(, "lamp": {"type": "emission", "emission": [1, 1, 1], "strength": 20, "two_sided": true, "visible_to_camera": false})");
    return scene_from(s);
  };
  const Scene shadowed = scene(red_pane(true)), open = scene("");
  for (const char* method : {"pt", "spt-hero"}) {
    Params p = seeded();  // (the lamp is black but for its emission: the floor's light is direct)
    if (std::string(method) != "pt") p.set("spectral", std::string("spectral"));
    const RGB a = image_mean(render(method, shadowed, 1024, p));
    const RGB b = image_mean(render(method, open, 1024, p));
    expect_ratio(a, b, RGB(1.0f, 0.2f, 0.1f), 0.02f, method);
  }
}

TEST(TransparentShadow, MsppmShadowRaysPassThePane) {
  // msppm's next-event estimation goes through the shared ShadowTest (issue 30): under the red
  // pane its path-tracing part is the light through the pane (it was 0: the pane blocked every
  // shadow ray and only photons lit the floor), and its image is pt's within the photons' noise.
  // The pane is no vertex of the paths through it (the camera path and the photons cross it as
  // the shadow rays do), so next-event estimation and the photons share that light by MIS.
  const Scene shadowed = scene_from(pane_scene(red_pane(true)));
  const RGB pt = image_mean(render("pt", shadowed, 8, seeded()));
  Params p = photon_params(20000, 3);
  p.set("max_depth", 8);
  const Film film = render("msppm", shadowed, 16, p);
  const RGB m = image_mean(film);
  double path_tracing[3] = {0, 0, 0};
  const Pass& pt_pass = film.pass(pass::kPathTracing);
  const size_t n = static_cast<size_t>(film.width()) * film.height();
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) path_tracing[c] += pt_pass.data[3 * i + c] / static_cast<double>(n);
  std::printf("msppm / pt %.4f %.4f %.4f; its path-tracing part / pt %.4f %.4f %.4f\n", m.r / pt.r, m.g / pt.g,
              m.b / pt.b, path_tracing[0] / pt.r, path_tracing[1] / pt.g, path_tracing[2] / pt.b);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(m[c] / pt[c], 1.0, 0.02) << "channel " << c;
    EXPECT_GT(path_tracing[c] / pt[c], 0.2) << "channel " << c;  // next-event estimation's share
  }
}

}  // namespace
}  // namespace gp
