// Transparent bounces of camera paths (issue 30): Cycles 3.4 counts a path's passes through
// Transparent BSDF closures against Light Paths > Transparent only (Scene::transparent_bounces),
// never against Max Bounces (path_state.h path_state_next: LABEL_TRANSPARENT keeps the ray's
// flags and bounce count), and the ray that makes the last allowed transparent bounce still sees
// the next surface's emission (PATH_RAY_TERMINATE_ON_NEXT_SURFACE). The camera-path loop
// (pt, spt), the photon methods' eye walk (sppm) and gpt's base path follow it.
//
// The scene: ten panes between the camera and an emitting wall that fills the view, no lights,
// no World. A camera ray meets the wall after ten transparent bounces; max_depth 2 (Blender's
// Max Bounces 0, direct light only) would end it at the second pane if the panes counted as
// bounces. Every camera sample takes the same path, so the image is exactly Le x tint^10 or 0.
#include <gtest/gtest.h>

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
  Params p = method == "sppm" ? photon_params(1000, 5) : Params();
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
  for (const char* method : {"pt", "spt", "sppm", "gpt"}) {
    const int passes = std::string(method) == "spt" ? 8 : 2;
    const RGB open = image_mean(render(method, scene_from(panes_scene(kClear, 16, 0)), passes, params_for(method)));
    for (const auto& [pane, tint] : {std::pair{kClear, 1.0f}, std::pair{kGrey, 0.9f}}) {
      const Scene scene = scene_from(panes_scene(pane, 16));
      const RGB mean = image_mean(render(method, scene, passes, params_for(method)));
      const float t10 = std::pow(tint, 10.0f);
      std::printf("%s, tint %.1f, transparent_bounces 16: %.5f %.5f %.5f (without panes x tint^10: %.5f %.5f %.5f)\n",
                  method, tint, mean.r, mean.g, mean.b, open.r * t10, open.g * t10, open.b * t10);
      for (int k = 0; k < 3; ++k) {
        ASSERT_GT(open[k], 0.0f) << method;
        EXPECT_NEAR(mean[k] / (open[k] * t10), 1.0f, 1e-3f) << method << " tint " << tint << " channel " << k;
        if (std::string(method) != "spt") EXPECT_NEAR(open[k], RGB(2, 1, 0.5f)[k], 1e-3f) << method;
      }
    }
  }
}

TEST(TransparentBounce, TheLastAllowedTransparentBounceStillSeesTheNextSurface) {
  // Cycles: the 10th transparent bounce with transparent_max_bounce 10 flags the path to end on
  // the next surface after its emission (the wall: seen); with 9 the 9th flags it and the 10th
  // pane ends it (black), as with 4.
  for (const char* method : {"pt", "spt", "sppm", "gpt"}) {
    for (const char* pane : {kClear, kGrey}) {
      const RGB ten = image_mean(render(method, scene_from(panes_scene(pane, 10)), 1, params_for(method)));
      EXPECT_GT(ten.r, 0.5f) << method << " " << pane;
      for (int limit : {9, 4}) {
        const RGB cut = image_mean(render(method, scene_from(panes_scene(pane, limit)), 1, params_for(method)));
        EXPECT_EQ(cut.r, 0.0f) << method << " " << pane << " limit " << limit;
        EXPECT_EQ(cut.g, 0.0f) << method << " " << pane << " limit " << limit;
      }
    }
  }
}

}  // namespace
}  // namespace gp
