// Cycles' per-kind ray visibility (object and light Visibility > Diffuse / Glossy / Transmission,
// World > Settings > Ray Visibility) in the methods other than the path tracer, against the path
// tracer with the same switches (path_tracer_test.cpp checks the path tracer against closed
// forms), and the World's switches in the path tracer against closed forms.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "core/rng.h"
#include "materials/bsdf.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// A grey scene (spectral upsampling of greys is exact, so spectral methods must match the RGB
// path tracer) in which every switch changes the image: a floor half Principled (a diffuse and a
// glossy lobe), half rough Glossy, seen at an angle with the sky above its far edge; a Blender
// area light (a pass-through surface hidden from the camera) with `lamp_keys`; a dark panel
// standing on the floor, seen in the Glossy half, with `panel_keys`; a sky with `world_keys`.
std::string switches_scene(const std::string& lamp_keys, const std::string& panel_keys, const std::string& world_keys) {
  return std::string(R"({"camera": {"position": [0, -3, 1.2], "look_at": [0, 0, 0.3], "up": [0, 0, 1], "fov": 50, "width": 24, "height": 24},
    "materials": {"floor": {"type": "principled", "color": 0.6, "roughness": 0.2, "ior": 1.5},
                  "metal": {"type": "conductor", "color": 0.8, "roughness": 0.05, "fresnel": false},
                  "panel": {"type": "diffuse", "color": 0.1)") + panel_keys + R"(},
                  "lamp": {"type": "dielectric", "ior": 1, "emission": 1, "strength": 6, "visible_to_camera": false,
                           "casts_shadow": false)" + lamp_keys + R"(}},
    "environment": {"color": 0.4, "strength": 1)" + world_keys + R"(},
    "objects": [{"type": "quad", "center": [-1, 0, 0], "u": [1, 0, 0], "v": [0, 2, 0], "material": "floor"},
                {"type": "quad", "center": [1, 0, 0], "u": [1, 0, 0], "v": [0, 2, 0], "material": "metal"},
                {"type": "quad", "center": [0, 1, 0.5], "u": [1, 0, 0], "v": [0, 0, 0.5], "material": "panel"},
                {"type": "quad", "center": [-0.3, 0, 1.2], "u": [0, 0.5, 0], "v": [0.5, 0, 0], "material": "lamp"}]})";
}

// A switch of each kind off: the lamp hidden from diffuse rays, the panel from glossy rays, the
// sky from the camera (its lobes: WorldSwitchesAgainstClosedForms).
const char* kLampOff = R"(, "visible_to_diffuse": false)";
const char* kPanelOff = R"(, "visible_to_glossy": false)";
const char* kWorldOff = R"(, "visible_to_camera": false)";

Params depth_params(uint64_t seed) {
  Params p;
  p.set("seed", seed);
  p.set("max_depth", 5);
  return p;
}

// The path tracer's mean with the switches (4096 samples: within 0.2 % of its limit).
RGB pt_reference(const Scene& s) { return image_mean(render("pt", s, 4096, depth_params(7))); }

// SPPM, adaptive SPPM and MSPPM (256 passes of 5000 photons, seed `seed`): image mean within
// `bound` of the path tracer's.
void expect_photon_methods_match_pt(const Scene& s, uint64_t seed, double bound) {
  const RGB ref = pt_reference(s);
  for (const char* method : {"sppm", "sppm-adaptive", "msppm"}) {
    Params p = photon_params(5000, seed);
    p.set("max_depth", 5);
    const RGB m = image_mean(render(method, s, 256, p));
    std::printf("%s: %.4f of pt\n", method, m.luminance() / ref.luminance());
    EXPECT_NEAR(m.luminance() / ref.luminance(), 1.0, bound)
        << method << ": " << m.luminance() << " against pt " << ref.luminance();
  }
}

TEST(RayVisibility, SwitchesChangeTheReferenceImage) {
  // What the method tests below rely on: each switch alone moves the path tracer's mean by more
  // than their bounds (measured: lamp 20 %, panel 3.9 %, world (camera) 33 %).
  const RGB all = pt_reference(scene_from(switches_scene("", "", "")));
  for (const auto& [name, json] :
       {std::pair{"lamp", switches_scene(kLampOff, "", "")}, std::pair{"panel", switches_scene("", kPanelOff, "")},
        std::pair{"world", switches_scene("", "", kWorldOff)}}) {
    const RGB m = image_mean(render("pt", scene_from(json), 1024, depth_params(7)));
    EXPECT_GT(std::abs(m.g / all.g - 1.0f), 0.03f) << name << ": " << m.g << " against " << all.g;
  }
}

TEST(RayVisibility, SpectralPathTracersHonourEverySwitch) {
  // spt and spt-hero against pt, a switch of each kind off on the grey scene. Measured over
  // seeds 2-4: spt 0.9989-1.0022 (4096 passes), spt-hero 0.9954-0.9993 (1024); each switch
  // alone moves pt's mean by 3.9 % (panel) to 33 % (SwitchesChangeTheReferenceImage). Bound 1.5 %.
  const Scene s = scene_from(switches_scene(kLampOff, kPanelOff, kWorldOff));
  EXPECT_TRUE(s.warnings.empty());
  const RGB ref = pt_reference(s);
  for (const auto& [method, passes] : {std::pair{"spt", 4096}, std::pair{"spt-hero", 1024}}) {
    const RGB m = image_mean(render(method, s, passes, depth_params(4)));
    EXPECT_NEAR(m.luminance() / ref.luminance(), 1.0, 0.015) << method << ": " << m.luminance() << " against pt " << ref.luminance();
  }
}

TEST(RayVisibility, PhotonMethodsHonourTheLightsSwitches) {
  // SPPM, adaptive SPPM and MSPPM against pt with the lamp hidden from diffuse rays and the sky
  // from the camera and from glossy rays. Measured over seeds 2-4 (256 passes of 5000 photons):
  // 0.993-1.006 (512 passes of 20000: 0.999); MSPPM 0.999-1.007 (2.28 before it honoured the
  // switches; seen failing at 2.12 with its camera paths' hits ignoring the lamp's switches, 1.45
  // with next-event estimation lighting every lobe, 1.80 with gathers of every lobe). Bound 2 %. PPM's
  // camera paths are traced once, too few for a mean here: WorldSwitchesAgainstClosedForms
  // checks its photons deposited at their first hit.
  const Scene s = scene_from(switches_scene(kLampOff, "", R"(, "visible_to_camera": false, "visible_to_glossy": false)"));
  expect_photon_methods_match_pt(s, 4, 0.02);
}

// Surfaces' switches with large effects: a lamp (`lamp_keys`) faces a wall (`wall_keys`), a Mix
// of diffuse and a rough Glossy, that lights a floor the camera sees; a dark veil (`veil_keys`)
// hangs over the floor below the lamp, hidden from the camera. Hiding the wall from diffuse rays
// takes its light off the floor (-7 %); with the lamp hidden from diffuse rays (the wall's glossy
// lobe alone then lights the floor), hiding the veil from them lets the floor see the wall
// through it (+12 %: the photons cross it). The veil casts shadows: a surface casting none is
// seen through by shadow rays only, which photons cannot follow (docs/blender.md).
std::string surfaces_scene(const std::string& lamp_keys, const std::string& wall_keys, const std::string& veil_keys) {
  return std::string(R"({"camera": {"position": [-1.5, 0, 2], "look_at": [0.3, 0, 0], "up": [0, 0, 1], "fov": 50, "width": 24, "height": 24},
    "materials": {"white": {"type": "diffuse", "color": 0.8},
                  "d": {"type": "diffuse", "color": 0.8},
                  "g": {"type": "conductor", "color": 0.9, "roughness": 0.3, "fresnel": false},
                  "wall": {"type": "mix", "a": "d", "b": "g", "factor": 0.5)") + wall_keys + R"(},
                  "veil": {"type": "diffuse", "color": 0.1, "visible_to_camera": false)" + veil_keys + R"(},
                  "lamp": {"type": "dielectric", "ior": 1, "emission": 1, "strength": 20, "visible_to_camera": false,
                           "casts_shadow": false)" + lamp_keys + R"(}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "white"},
                {"type": "quad", "center": [1, 0, 0.5], "u": [0, 1, 0], "v": [0, 0, 0.5], "material": "wall"},
                {"type": "quad", "center": [0.6, 0, 0.25], "u": [0.35, 0, 0], "v": [0, 1, 0], "material": "veil"},
                {"type": "quad", "center": [0.3, 0, 0.6], "u": [0, 0.3, 0], "v": [0, 0, 0.3], "material": "lamp"}]})";
}
const char* kDiffuseOff = R"(, "visible_to_diffuse": false)";

// Scenes whose surfaces' switches the methods must honour: the two of surfaces_scene, and
// switches_scene's panel hidden from glossy rays (its reflection in the sharp metal is gone: the
// camera paths' bounce rays pass it; -3.9 %).
std::vector<Scene> surfaces_scenes() {
  std::vector<Scene> out;
  out.push_back(scene_from(switches_scene("", kPanelOff, "")));
  out.push_back(scene_from(surfaces_scene("", kDiffuseOff, "")));
  out.push_back(scene_from(surfaces_scene(kDiffuseOff, "", kDiffuseOff)));
  return out;
}

TEST(RayVisibility, PhotonMethodsHonourTheSurfacesSwitches) {
  // SPPM and adaptive SPPM against pt on surfaces_scenes(): the metal's reflection passes the
  // panel, the wall's photons light no diffuse lobe, the wall's photons cross the veil for the
  // floor's diffuse lobe. Measured over seeds 2-4, the three
  // scenes: 0.992-0.996, 0.994-1.004, 0.991-1.004 (both methods); with the switches ignored
  // (the camera paths' bounce rays not tagged: 0.957 on the first; photons neither crossing nor
  // carrying the kinds that see where they scattered: 1.07 and 0.89 on the others; crossing
  // without its 1/q weight: 0.938 on the third). MSPPM 1.001-1.002, 1.001-1.003, 1.002-1.003
  // (before: 0.966, 1.075, 1.85); seen failing with its camera rays untagged (0.965, 1.039,
  // 0.934) and with its recorded photons ignoring surfaces' switches (1.036, 0.963 on the
  // wall and veil). Bound 2 %.
  for (const Scene& s : surfaces_scenes()) expect_photon_methods_match_pt(s, 2, 0.02);
}

// Relative L1 distance between two images' 6x6-pixel block means, over `a`'s mean: a shift that
// ignores a switch the base honours biases the gradients, which moves regions of the
// reconstructed image while its mean stays the primal's (the screened Poisson solution keeps it).
double block_distance(const Film& a, const Film& b) {
  constexpr int kB = 6;
  const int bw = a.width() / kB, bh = a.height() / kB;
  double dist = 0, mean = 0;
  for (int by = 0; by < bh; ++by)
    for (int bx = 0; bx < bw; ++bx) {
      double sa = 0, sb = 0;
      for (int y = by * kB; y < (by + 1) * kB; ++y)
        for (int x = bx * kB; x < (bx + 1) * kB; ++x) {
          sa += a.rgb(pass::kCombined, x, y).luminance();
          sb += b.rgb(pass::kCombined, x, y).luminance();
        }
      dist += std::abs(sa - sb);
      mean += sa;
    }
  return dist / mean;
}

TEST(RayVisibility, GradientPathTracingHonoursEverySwitch) {
  // gpt against pt with a switch of each kind off on the grey scene, and on the veil scene
  // (its offsets cross the veil as the base does): the mean (the primal's) and the
  // reconstructed image by 6x6 blocks. Measured over seeds 2-4 (256 passes): means 0.990-1.007;
  // blocks 0.010-0.020 and 0.012-0.016 (pt at 256 samples: 0.003-0.017). With the offsets'
  // rays and reconnections ignoring the surfaces' switches: blocks 0.095-0.109 and 0.021-0.029
  // (seen failing). Bounds: mean 2 %, blocks 0.03 / 0.025.
  // (Offsets weighing a hidden light's hits by every lobe moved the blocks too little to tell.)
  for (const auto& [scene, bound] : {std::pair{switches_scene(kLampOff, kPanelOff, kWorldOff), 0.03},
                                     std::pair{surfaces_scene(kDiffuseOff, "", kDiffuseOff), 0.025}}) {
    const Scene s = scene_from(scene);
    const Film ref = render("pt", s, 4096, depth_params(7));
    const Film f = render("gpt", s, 256, depth_params(2));
    EXPECT_NEAR(image_mean(f).luminance() / image_mean(ref).luminance(), 1.0, 0.02);
    EXPECT_LT(block_distance(ref, f), bound);
  }
  // gdmlt drives gpt's paths (its shifts and weights) by Metropolis: its mean (0.967-1.012 over
  // seeds 2-4, 256 passes) on the grey scene with the lamp hidden from diffuse rays (which moves
  // pt's by 20 %). Bound 6 %.
  const Scene lamp = scene_from(switches_scene(kLampOff, "", ""));
  EXPECT_NEAR(image_mean(render("gdmlt", lamp, 256, depth_params(2))).luminance() / pt_reference(lamp).luminance(), 1.0,
              0.06);
}

TEST(RayVisibility, GpmHonoursTheSurfacesSwitches) {
  // gpm against pt on surfaces_scene: the wall hidden from diffuse rays (its primal gathers by
  // the photons' lobes; measured 0.997-1.002 over seeds 2-4, 1.046-1.059 gathering every lobe),
  // and the veil (the photons cross it; 512 passes: mean 0.998-1.006, 6x6 blocks 0.006-0.011,
  // and 0.015-0.020 when photons whose last segment crossed or landed on it are shifted
  // anyway). Bounds: mean 2 %, blocks 0.013 (seed 2: 0.0095, 0.0165 shifted anyway).
  for (const auto& [scene, passes, blocks] : {std::tuple{surfaces_scene("", kDiffuseOff, ""), 256, 0.0},
                                              std::tuple{surfaces_scene(kDiffuseOff, "", kDiffuseOff), 512, 0.013}}) {
    const Scene s = scene_from(scene);
    const Film ref = render("pt", s, 4096, depth_params(7));
    Params p = photon_params(5000, 2);
    p.set("max_depth", 5);
    const Film f = render("gpm", s, passes, p);
    EXPECT_NEAR(image_mean(f).luminance() / image_mean(ref).luminance(), 1.0, 0.02);
    if (blocks > 0) EXPECT_LT(block_distance(ref, f), blocks);
  }
}

// surfaces_scene with a single-lobe wall, `wall` (the spectral methods scatter a Mix as one
// diffuse surface, which moves their image away from pt's whatever the switches).
std::string with_wall(const std::string& json, const std::string& wall) {
  const std::string mix = R"("wall": {"type": "mix", "a": "d", "b": "g", "factor": 0.5)";
  std::string out = json;
  out.replace(out.find(mix), mix.size(), R"("wall": )" + wall);
  return out;
}

TEST(RayVisibility, SpectralPhotonsHonourEverySwitch) {
  // SPPM with spectral photons (its own eye paths and photon tracer) against pt on grey scenes
  // (spectral upsampling of greys is exact): the panel hidden from glossy rays; the lamp hidden
  // from diffuse rays and the sky from the camera and glossy rays; a diffuse wall hidden from
  // diffuse rays (-7 % in pt); a rough Glossy wall lit by a lamp hidden from diffuse rays, seen
  // through a veil hidden from them (+11.5 %). Measured over seeds 2-4 (256 passes of 5000
  // photons): 0.991-0.996, 0.992-1.006, 0.996-1.002, 0.990-1.003. Seen failing: camera paths'
  // bounce rays untagged 0.957 (panel); photons neither crossing nor narrowing their kinds 1.072
  // (wall) and 0.893 (veil); not crossing 0.892 (veil). Bound 2 %.
  const std::string diffuse = R"({"type": "diffuse", "color": 0.8)";
  const std::string glossy = R"({"type": "conductor", "color": 0.9, "roughness": 0.3, "fresnel": false)";
  for (const std::string& json :
       {switches_scene("", kPanelOff, ""), switches_scene(kLampOff, "", R"(, "visible_to_camera": false, "visible_to_glossy": false)"),
        with_wall(surfaces_scene("", kDiffuseOff, ""), diffuse), with_wall(surfaces_scene(kDiffuseOff, "", kDiffuseOff), glossy)}) {
    const Scene s = scene_from(json);
    const RGB ref = pt_reference(s);
    Params p = photon_params(5000, 2);
    p.set("max_depth", 5);
    p.set("spectral", "spectral");
    const RGB m = image_mean(render("sppm", s, 256, p));
    EXPECT_NEAR(m.luminance() / ref.luminance(), 1.0, 0.02) << m.luminance() << " against pt " << ref.luminance();
  }
}

TEST(RayVisibility, SpectralGradientSamplingHonoursEverySwitch) {
  // sgpt against pt with the panel hidden from glossy rays, with a diffuse wall hidden from
  // diffuse rays (-7 % in pt), and with the lamp hidden from diffuse rays and the sky from the
  // camera, and that with the sky hidden from glossy rays too (Cycles' rule for the World,
  // lobe_split.h, in both): the mean and the reconstructed image by 6x6 blocks. Measured over
  // seeds 2-4 (512 passes): means 1.002-1.006, 1.001-1.003, 0.993-1.012 and 0.994-1.011, blocks
  // 0.006-0.008, 0.005-0.011, 0.004-0.012 and 0.006-0.013; the last with sgpt on the lights' rule
  // for the World (before): mean 1.027, blocks 0.027. (A surface hidden from a kind of ray that casts shadows between a
  // light and what it lights is left out: pt and Cycles count the light its BSDF rays find
  // through it with their MIS weight, which differs between pt's power heuristic and sgpt's
  // balance heuristic.) Seen failing with base and offset rays untagged: both means off by over
  // 2 %, blocks 0.038 / 0.077; with lights lighting every lobe (before issue 14), mean 2.01, blocks 1.01 on the last.
  // Offsets alone change nothing here: without dispersion an offset is the base path
  // (Sgpt.HonoursTheLightsSwitchesAtTheBaseAndTheOffsets checks them). Bounds: mean 2 %, blocks 0.02.
  for (const std::string& json : {switches_scene("", kPanelOff, ""),
                                  with_wall(surfaces_scene("", kDiffuseOff, ""), R"({"type": "diffuse", "color": 0.8)"),
                                  switches_scene(kLampOff, "", R"(, "visible_to_camera": false)"),
                                  switches_scene(kLampOff, "", R"(, "visible_to_camera": false, "visible_to_glossy": false)")}) {
    const Scene s = scene_from(json);
    const Film ref = render("pt", s, 4096, depth_params(7));
    const Film f = render("sgpt", s, 512, depth_params(2));
    std::printf("sgpt against pt: mean %.4f, blocks %.4f\n", image_mean(f).luminance() / image_mean(ref).luminance(),
                block_distance(ref, f));
    EXPECT_NEAR(image_mean(f).luminance() / image_mean(ref).luminance(), 1.0, 0.02);
    EXPECT_LT(block_distance(ref, f), 0.02);
  }
}

TEST(RayVisibility, PhotonsFollowTheLobeSampledAtTheirFirstHit) {
  // A lamp hidden from diffuse rays faces a wall that is a Mix of diffuse and a rough Glossy; the
  // floor the camera sees gets the lamp's light only through the wall's glossy lobe (photon_tracer.cpp's
  // rule: photons that scattered diffusely at the wall die; the glossy ones carry f_G / p_G). SPPM
  // against pt over seeds 2-4: 0.985-0.995 (SPPM's own bias, the same sign on every seed); with
  // the diffuse scatters kept 1.25, with the glossy ones weighted by the whole f 1.23, without the
  // rule 1.44. MSPPM 0.996-0.998 (2.63 before it honoured the switches). Bound 4 %.
  const Scene s = scene_from(R"({"camera": {"position": [-1.5, 0, 2], "look_at": [0.3, 0, 0], "up": [0, 0, 1], "fov": 50, "width": 24, "height": 24},
    "materials": {"white": {"type": "diffuse", "color": 0.8},
                  "d": {"type": "diffuse", "color": 0.8},
                  "g": {"type": "conductor", "color": 0.9, "roughness": 0.3, "fresnel": false},
                  "wall": {"type": "mix", "a": "d", "b": "g", "factor": 0.5},
                  "lamp": {"type": "dielectric", "ior": 1, "emission": 1, "strength": 20, "visible_to_camera": false,
                           "casts_shadow": false, "visible_to_diffuse": false}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [1, 0, 0], "v": [0, 1, 0], "material": "white"},
                {"type": "quad", "center": [1, 0, 0.5], "u": [0, 1, 0], "v": [0, 0, 0.5], "material": "wall"},
                {"type": "quad", "center": [0.3, 0, 0.6], "u": [0, 0.3, 0], "v": [0, 0, 0.3], "material": "lamp"}]})");
  expect_photon_methods_match_pt(s, 2, 0.04);
}

// ---- The World's Ray Visibility, against closed forms ----

// A camera looking down at a diffuse floor of albedo 0.5 (filling the view) under a sky of
// radiance 2 with `world_keys`: it sees the whole sky, whatever its size, so L = 0.5 x 2. Not
// much larger than the view, so that the sky's photons land densely enough.
Scene floor_under_sky(const std::string& floor, const std::string& world_keys) {
  return scene_from(std::string(R"({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 16, "height": 16},
    "materials": {)") + floor + R"(},
    "environment": {"color": 2, "strength": 1)" + world_keys + R"(},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "floor"}]})");
}

TEST(RayVisibility, WorldSwitchesAgainstClosedForms) {
  const std::string diffuse = R"("floor": {"type": "diffuse", "color": 0.5})";
  const std::string mix = R"("d": {"type": "diffuse", "color": 0.5},
    "g": {"type": "conductor", "color": 1, "roughness": 0.2, "fresnel": false},
    "floor": {"type": "mix", "a": "d", "b": "g", "factor": 0.5})";
  const Scene open = scene_from(R"({"camera": {"position": [0, -2, 0.5], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "fov": 60, "width": 16, "height": 16},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}},
    "environment": {"color": 2, "strength": 1, "visible_to_camera": false},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "grey"}]})");
  for (const auto& [method, passes] : {std::pair{"pt", 64}, std::pair{"spt", 1024}, std::pair{"spt-hero", 256},
                                       std::pair{"ppm", 64}, std::pair{"sppm", 64}, std::pair{"sppm-adaptive", 64},
                                       std::pair{"msppm", 64}}) {
    Params p = depth_params(1);
    if (std::string(method).find("ppm") != std::string::npos) p.set("photons", 20000);
    // A diffuse floor under the sky reflects 0.5 x 2; hidden from diffuse rays, nothing; hidden
    // from glossy rays, all of it.
    EXPECT_NEAR(image_mean(render(method, floor_under_sky(diffuse, ""), passes, p)).g, 1.0, 0.01) << method;
    EXPECT_EQ(image_mean(render(method, floor_under_sky(diffuse, R"(, "visible_to_diffuse": false)"), 16, p)).g, 0.0f)
        << method;
    EXPECT_NEAR(image_mean(render(method, floor_under_sky(diffuse, R"(, "visible_to_glossy": false)"), passes, p)).g,
                1.0, 0.01)
        << method;
    // A Mix of that diffuse and a white Glossy (no Fresnel) by 0.5 under a sky hidden from
    // diffuse rays: about the glossy half, 0.5 x 2 x the GGX lobe's albedo (0.948 at alpha 0.2),
    // plus the diffuse colour that Cycles' glossy rays carry (int f q_V Le cos = 0.954 by
    // quadrature; WorldHiddenFromSomeKindsAsCyclesRendersIt pins it); 1.45 with the sky lighting
    // the diffuse half too. msppm keeps the lights' rule for the World (the glossy lobe's f / pdf:
    // 0.947 measured; 0.867 with its camera paths' sky hits carrying the whole f / pdf).
    if (std::string(method).find("spt") == std::string::npos) {  // the spectral methods scatter a mix as one diffuse surface
      const float glossy_half =
          image_mean(render(method, floor_under_sky(mix, R"(, "visible_to_diffuse": false)"), passes, p)).g;
      EXPECT_GT(glossy_half, 0.9f) << method;
      EXPECT_LT(glossy_half, 1.0f) << method;
    }
    // Camera off: the sky seen directly is black, what it lights is not.
    const Film f = render(method, open, passes, p);
    float top = 0, bottom = 0;  // the mean of the first and last rows
    for (int x = 0; x < 16; ++x) {
      top += f.rgb(pass::kCombined, x, 0).g / 16;
      bottom += f.rgb(pass::kCombined, x, 15).g / 16;
    }
    EXPECT_EQ(std::min(top, bottom), 0.0f) << method << ": the sky above the horizon";
    EXPECT_NEAR(std::max(top, bottom), 1.0f, 0.05f) << method << ": the floor below it";
  }
}

// ---- The World hidden from some kinds over a Mix, as Cycles 3.4 renders it ----

// A Mix by `t` of a coloured Diffuse and a white Glossy (GGX alpha 0.2, no Fresnel) under a sky
// of radiance 2 with `world_keys`, the camera looking down (floor_under_sky).
constexpr float kMixT = 0.3f;
const RGB kMixDiffuse(0.8f, 0.5f, 0.2f);
Scene mix_under_sky(const std::string& world_keys) {
  return floor_under_sky(R"("d": {"type": "diffuse", "color": [0.8, 0.5, 0.2]},
    "g": {"type": "conductor", "color": 1, "roughness": 0.2, "fresnel": false},
    "floor": {"type": "mix", "a": "d", "b": "g", "factor": 0.3})",
                         world_keys);
}

// Cycles' estimator, brute force, at each pixel's centre: pick a closure in proportion to its
// sample weight (its mean weight colour: (1 - t) x the diffuse's, t x the glossy's 1), sample
// it, and count the sky when that closure's kind sees it, with the whole Mix's f over the
// closure-weighted pdf (shade_surface.h, shade_background.h; a constant World is no light to
// Cycles, so no next-event estimation). Built from the components' own samplers, not from the
// Mix's code or Bsdf::closure_pdf.
RGB cycles_way_reference(const Scene& s, uint8_t visible, int samples_per_pixel) {
  auto find = [&](const char* name) -> const Material& {
    for (const Material& m : s.materials)
      if (m.name == name) return m;
    throw std::runtime_error(name);
  };
  const Bsdf diffuse(find("d")), glossy(find("g"));
  const float w_d = (1 - kMixT) * kMixDiffuse.average(), w_g = kMixT * 1.0f;
  Rng rng(12345, 0);
  double sum[3] = {0, 0, 0};
  const int w = s.camera.film_width(), h = s.camera.film_height();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto hit = s.intersect(s.camera.generate_ray(Vec2(x + 0.5f, y + 0.5f), Vec2(0.5f, 0.5f)));
      if (!hit) throw std::runtime_error("the floor fills the view");
      const Vec3 wo = hit->frame.to_local(-s.camera.generate_ray(Vec2(x + 0.5f, y + 0.5f), Vec2(0.5f, 0.5f)).d);
      for (int i = 0; i < samples_per_pixel; ++i) {
        const bool pick_glossy = rng.uniform() * (w_d + w_g) < w_g;
        const auto bs = (pick_glossy ? glossy : diffuse).sample(wo, rng.uniform(), Vec2(rng.uniform(), rng.uniform()));
        if (!bs || !(visible & (pick_glossy ? kRayGlossy : kRayDiffuse))) continue;
        const RGB f = diffuse.eval(wo, bs->wi) * (1 - kMixT) + glossy.eval(wo, bs->wi) * kMixT;
        const float pdf = (w_d * diffuse.pdf(wo, bs->wi) + w_g * glossy.pdf(wo, bs->wi)) / (w_d + w_g);
        if (!(pdf > 0)) continue;
        const RGB c = f * (std::abs(bs->wi.z) * 2.0f / pdf);
        for (int k = 0; k < 3; ++k) sum[k] += c[k];
      }
    }
  const double n = double(w) * h * samples_per_pixel;
  return RGB(float(sum[0] / n), float(sum[1] / n), float(sum[2] / n));
}

TEST(RayVisibility, WorldHiddenFromSomeKindsAsCyclesRendersIt) {
  // Cycles lets a visible kind's BSDF ray carry the whole f/pdf, so the other lobe's colour leaks
  // into what the sky lights. Cycles' way (the reference above, 256 x 4096 samples): hidden from
  // glossy rays (0.969, 0.694, 0.420), from diffuse rays (0.719, 0.573, 0.428), as a quadrature
  // of int f q_V Le cos gives at normal incidence (0.966, 0.695, 0.423) and (0.723, 0.574, 0.426).
  // The rule of lights (the lobes that see it, int f_V Le: gradphoton's before) gives exactly
  // (1 - t) x the diffuse colour x 2 = (1.12, 0.70, 0.28) hidden from glossy rays (R +16 %,
  // B -33 %; the test then fails in every method) and t x 2 x the GGX albedo = 0.57 grey hidden
  // from diffuse rays (R -21 %). Measured over seeds 3-5, channel by channel: pt within 0.5 %,
  // sppm (next-event estimation; photons add nothing on a lone floor) 0.6 %, spt 1.4 %,
  // spt-hero 1.1 %, gpt 1.3 %, sgpt 0.8 %: bounds of about twice that (sgpt's 2 %). sgpt with
  // the lights' rule (its base and offsets before): R 1.163 / B 0.667 hidden from glossy rays;
  // with the whole f / pdf and no P_C / P: 1.22-1.26 / 0.71-0.74; its offsets on the lights' rule
  // (the base on Cycles'): B 0.830 / 1.166, through the reconstruction's gradients.
  for (const auto& [keys, visible] : {std::pair{R"(, "visible_to_glossy": false)", uint8_t(kRayDiffuse | kRayTransmission)},
                                      std::pair{R"(, "visible_to_diffuse": false)", uint8_t(kRayGlossy | kRayTransmission)}}) {
    const Scene s = mix_under_sky(keys);
    const RGB ref = cycles_way_reference(s, visible, 4096);
    for (const auto& [method, passes, bound] :
         {std::tuple{"pt", 256, 0.01}, std::tuple{"spt", 1024, 0.03}, std::tuple{"spt-hero", 256, 0.025},
          std::tuple{"gpt", 128, 0.025}, std::tuple{"sppm", 1024, 0.012}, std::tuple{"sgpt", 1024, 0.02}}) {
      Params p = depth_params(3);
      if (std::string(method) == "sppm") p.set("photons", 1000);  // its glossy lobe needs many NEE samples
      const RGB m = image_mean(render(method, s, passes, p));
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(m[k] / ref[k], 1.0, bound) << method << keys << " channel " << k << ": " << m[k] << " against " << ref[k];
    }
    // PPM: all of the sky's light by photons, gathered with f q_V (Photon::world_share). Its
    // level on this glossy floor reads 3-9 % high over seeds 3-5 in every channel alike (5 % at
    // seed 3 with the World's switches off too, against pt: PPM's own error here, not the
    // rule's), so the colour, which the rule decides, is held tightly: each channel's ratio to
    // Cycles' over their mean within 0.6 % measured (bound 2 %), the level within 10 % (seed 3:
    // 1.038-1.060). The rule now gives (1.005, 0.723, 0.441) hidden from glossy and
    // (0.762, 0.607, 0.452) hidden from diffuse rays; the lights' rule (f_V) gave (1.118, 0.699,
    // 0.280) and (0.582, 0.582, 0.582): R / B ratios to Cycles' 1.15 / 0.67 and 0.81 / 1.36.
    Params p = depth_params(3);
    p.set("photons", 1000);
    const RGB m = image_mean(render("ppm", s, 512, p));
    const RGB r(m[0] / ref[0], m[1] / ref[1], m[2] / ref[2]);
    const float level = (r[0] + r[1] + r[2]) / 3;
    EXPECT_NEAR(level, 1.0, 0.1) << "ppm" << keys << ": " << m[0] << ", " << m[1] << ", " << m[2];
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(r[k] / level, 1.0, 0.02) << "ppm" << keys << " channel " << k << ": " << m[k] << " against " << ref[k];
  }
}

TEST(RayVisibility, WorldCameraSwitchInEveryMethod) {
  // The sky hidden from the camera over a grey floor (L = 1 below the horizon): every method
  // shows black above the horizon (the gradient methods' reconstruction may bleed a little) and
  // the lit floor below. Shown, the sky is 2 there.
  const Scene open = scene_from(R"({"camera": {"position": [0, -2, 0.5], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "fov": 60, "width": 16, "height": 16},
    "materials": {"grey": {"type": "diffuse", "color": 0.5}},
    "environment": {"color": 2, "strength": 1, "visible_to_camera": false},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "grey"}]})");
  for (const Method& m : methods()) {
    Params p;
    p.set("seed", 1);
    if (m.find("photons")) p.set("photons", 5000);
    const Film f = render(m.name, open, 8, p);
    float top = 0, bottom = 0;
    for (int x = 0; x < 16; ++x) {
      top += f.rgb(pass::kCombined, x, 0).g / 16;
      bottom += f.rgb(pass::kCombined, x, 15).g / 16;
    }
    EXPECT_LT(std::min(top, bottom), 0.05f) << m.name << ": the sky above the horizon";
    EXPECT_GT(std::max(top, bottom), 0.5f) << m.name << ": the floor below it";
  }
}

}  // namespace
}  // namespace gp
