// Transparent bounces of camera paths (issue 30): Cycles 3.4 counts a path's passes through
// Transparent BSDF closures against Light Paths > Transparent only (Scene::transparent_bounces),
// never against Max Bounces (path_state.h path_state_next: LABEL_TRANSPARENT keeps the ray's
// flags and bounce count), and the ray that makes the last allowed transparent bounce still sees
// the next surface's emission (PATH_RAY_TERMINATE_ON_NEXT_SURFACE). The camera-path loop
// (pt, spt), the photon methods' eye walk (sppm), gpt's base path, sgpt's base path and msppm's
// camera paths follow it.
//
// The scene: ten panes between the camera and an emitting wall that fills the view, no lights,
// no World. A camera ray meets the wall after ten transparent bounces; max_depth 2 (Blender's
// Max Bounces 0, direct light only) would end it at the second pane if the panes counted as
// bounces. Every camera sample takes the same path, so the image is exactly Le x tint^10 or 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "render_for_tests.h"

namespace gp {
namespace {

// `pane`: the panes' material; `transparent_bounces`: the scene's Light Paths > Transparent.
std::string panes_scene(const std::string& pane, int transparent_bounces, int panes = 10) {
  std::string s = R"({"camera": {"position": [0, 0, 12], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 10, "width": 8, "height": 8},
    "materials": {"wall": {"type": "emission", "emission": [1, 0.5, 0.25], "strength": 2}, "pane": )" + pane + R"(},
    "lights": [], "transparent_bounces": )" + std::to_string(transparent_bounces) + R"(,
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [20, 0, 0], "v": [0, 20, 0], "material": "wall"})";
  for (int i = 1; i <= panes; ++i)
    s += R"(, {"type": "quad", "center": [0, 0, )" + std::to_string(0.5 * i) +
         R"(], "u": [20, 0, 0], "v": [0, 20, 0], "material": "pane"})";
  return s + "]}";
}

Params params_for(const std::string& method) {
  Params p = method == "sppm" || method == "msppm" ? photon_params(1000, 5) : Params();
  p.set("seed", 5);
  p.set("max_depth", 2);
  if (method == "spt") p.set("spectral", std::string("spectral"));
  return p;
}

// A clear pane (a pass-through surface) and a grey one (a BSDF sample through it).
const char* kClear = R"({"type": "transparent", "color": 1})";
const char* kGrey = R"({"type": "transparent", "color": 0.9})";

TEST(TransparentBounce, TenPanesPassWithinTheTransparentLimitWhateverMaxDepth) {
  // Against the same scene without panes (the panes draw no random numbers, so every sample is the
  // same path): the image times tint^10, exactly (gpt: to its reconstruction, 1e-3); and for the
  // RGB methods the wall's radiance itself.
  for (const char* method : {"pt", "spt", "sppm", "gpt", "sgpt", "msppm"}) {
    const std::string name = method;
    const bool spectral = name == "spt" || name == "sgpt";
    const int passes = spectral ? 8 : 2;
    const RGB open = image_mean(render(method, scene_from(panes_scene(kClear, 16, 0)), passes, params_for(method)));
    for (const auto& [pane, tint] : {std::pair{kClear, 1.0f}, std::pair{kGrey, 0.9f}}) {
      // sgpt through tinted panes reads 0.80-0.89 of the exact value whatever the depth
      // (pre-existing: main e818fe0 with max_depth 32 gives the same 0.511 0.303 0.153): its
      // clear panes are checked here, the tinted ones' bias is an open fault.
      if (name == "sgpt" && tint != 1.0f) continue;
      const Scene scene = scene_from(panes_scene(pane, 16));
      const RGB mean = image_mean(render(method, scene, passes, params_for(method)));
      const float t10 = std::pow(tint, 10.0f);
      std::printf("%s, tint %.1f, transparent_bounces 16: %.5f %.5f %.5f (without panes x tint^10: %.5f %.5f %.5f)\n",
                  method, tint, mean.r, mean.g, mean.b, open.r * t10, open.g * t10, open.b * t10);
      for (int k = 0; k < 3; ++k) {
        ASSERT_GT(open[k], 0.0f) << method;
        EXPECT_NEAR(mean[k] / (open[k] * t10), 1.0f, 1e-3f) << method << " tint " << tint << " channel " << k;
        if (!spectral) EXPECT_NEAR(open[k], RGB(2, 1, 0.5f)[k], 1e-3f) << method;
      }
    }
  }
}

TEST(TransparentBounce, TheLastAllowedTransparentBounceStillSeesTheNextSurface) {
  // Measured in Blender 3.4's Cycles (ten clear panes, min_transparent_bounces 16, 4 samples):
  // the wall shows with Transparent 9, 10, 11 and not with 4 to 8. So the path that made the 10th
  // pass with a limit of 9 still sees the wall's emission; with 8 the 10th pane ends it (black),
  // as with 4. (This test once asserted black at 9, against Cycles.)
  for (const char* method : {"pt", "spt", "sppm", "gpt", "sgpt", "msppm"}) {
    for (const char* pane : {kClear, kGrey}) {
      if (std::string(method) == "sgpt" && pane == kGrey) continue;  // its tinted-pane bias (above)
      for (int limit : {10, 9}) {
        const RGB seen = image_mean(render(method, scene_from(panes_scene(pane, limit)), 1, params_for(method)));
        EXPECT_GT(seen.r, 0.5f) << method << " " << pane << " limit " << limit;
      }
      for (int limit : {8, 4}) {
        const RGB cut = image_mean(render(method, scene_from(panes_scene(pane, limit)), 1, params_for(method)));
        EXPECT_EQ(cut.r, 0.0f) << method << " " << pane << " limit " << limit;
        EXPECT_EQ(cut.g, 0.0f) << method << " " << pane << " limit " << limit;
      }
    }
  }
}

// Film > Transparent through a tinted pane (Cycles 3.4 integrate_background): a camera ray that
// leaves the scene after transparent bounces only adds the average of its throughput to the
// transparent pass and no background, so alpha = 1 - average(throughput): a red (1, 0, 0) pane
// before the World gives alpha 2/3 and no colour, a clear one alpha 0, a grey 0.9 one 0.1.
// Every method that writes alpha with film_transparent; every camera ray passes the pane, so
// every pixel is exactly that.
TEST(FilmTransparent, ATintedPaneBeforeTheWorldLeavesOneMinusTheAverageOfItsColour) {
  auto pane_before_world = [](const std::string& pane) {
    return scene_from(R"({"camera": {"position": [0, 0, 12], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 10, "width": 8, "height": 8},
      "materials": {"pane": )" + pane + R"(}, "environment": {"color": [0.2, 0.5, 1], "strength": 1},
      "objects": [{"type": "quad", "center": [0, 0, 0], "u": [20, 0, 0], "v": [0, 20, 0], "material": "pane"}]})");
  };
  const std::pair<const char*, float> panes[] = {{R"({"type": "transparent", "color": [1, 0, 0]})", 2.0f / 3.0f},
                                                 {kClear, 0.0f},
                                                 {kGrey, 0.1f}};
  for (const Method& m : methods()) {
    if (!m.find("film_transparent")) continue;
    const bool spt = std::string(m.name).rfind("spt", 0) == 0;  // spectral only
    for (const char* mode : {"rgb", "spectral"}) {
      if (std::string(mode) == "spectral" ? !m.find("spectral") : spt) continue;
      Params p = m.find("photons") ? photon_params(500, 5) : Params();
      p.set("seed", 5);
      p.set("film_transparent", true);
      if (m.find("spectral")) p.set("spectral", std::string(mode));
      const bool spectral = std::string(mode) == "spectral";
      for (const auto& [pane, alpha] : panes) {
        // Spectral: a tinted pane's transparency is the average of the path's throughput over
        // its wavelengths, an estimate of the tint spectrum's mean, not the RGB average Cycles
        // takes (a red pane's alpha read 0.44 in pt, 0.28 in sppm): only grey panes checked.
        if (spectral && alpha != 0.0f && std::string(pane).find("[1, 0, 0]") != std::string::npos) continue;
        const Film f = render(std::string(m.name), pane_before_world(pane), 2, p);
        const Pass& a = f.pass(pass::kAlpha);
        double sum = 0, lo = 1, hi = 0;
        for (size_t i = 0; i < f.pixel_count(); ++i) {
          sum += a.data[i];
          lo = std::min<double>(lo, a.data[i]);
          hi = std::max<double>(hi, a.data[i]);
        }
        const RGB c = image_mean(f);
        std::printf("%s (%s), pane %s: alpha mean %.5f [%.5f, %.5f] (Cycles %.5f), colour %.5f %.5f %.5f\n",
                    std::string(m.name).c_str(), mode, pane, sum / f.pixel_count(), lo, hi, alpha, c.r, c.g, c.b);
        const std::string what = std::string(m.name) + " " + mode + " " + pane;
        EXPECT_NEAR(lo, alpha, 1e-5) << what;
        EXPECT_NEAR(hi, alpha, 1e-5) << what;
        EXPECT_EQ(c.r + c.g + c.b, 0.0f) << what;  // no background
      }
    }
  }
}

}  // namespace
}  // namespace gp
