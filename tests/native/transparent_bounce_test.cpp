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
// Every method that writes alpha with film_transparent, RGB and spectral: the spectral methods
// average the RGB colour of the closures passed (RgbTransparency, paths/medium_walk.h), not
// their throughput over the path's wavelengths (with which this test read a red pane's alpha
// 0.434 in spt, 0.438 in spt-hero, 0.285 in spectral sppm; (0.2, 0.9, 0.4): 0.685, 0.711,
// 0.677 for 0.5; (0.1, 0.3, 0.95): 0.426, 0.385, 0.369 for 0.55). A Transparent BSDF alone is passed with
// probability 1 and weight c, so every sample, hence every pixel, is exactly 1 - mean(c).
const std::pair<const char*, float> kTintedPanes[] = {
    {R"({"type": "transparent", "color": [1, 0, 0]})", 2.0f / 3.0f},
    {R"({"type": "transparent", "color": [0.2, 0.9, 0.4]})", 0.5f},
    {R"({"type": "transparent", "color": [0.1, 0.3, 0.95]})", 0.55f},
    {R"({"type": "transparent", "color": 1})", 0.0f},
    {R"({"type": "transparent", "color": 0.9})", 0.1f}};
// `more`: further materials (", \"name\": {...}") that the pane's may name.
Scene pane_before_world(const std::string& pane, const std::string& more = "", int size = 8) {
  const std::string n = std::to_string(size);
  return scene_from(R"({"camera": {"position": [0, 0, 12], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 10, "width": )" + n +
                    R"(, "height": )" + n + R"(},
    "materials": {"pane": )" + pane + more + R"(}, "environment": {"color": [0.2, 0.5, 1], "strength": 1},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [20, 0, 0], "v": [0, 20, 0], "material": "pane"}]})");
}
// Calls fn(method, mode, params) for every method that writes alpha with film_transparent, in
// RGB and, where it has them, in its spectral modes.
template <class Fn>
void for_each_alpha_method(Fn fn) {
  for (const Method& m : methods()) {
    if (!m.find("film_transparent")) continue;
    const bool spt = std::string(m.name).rfind("spt", 0) == 0;  // spectral only
    for (const char* mode : {"rgb", "spectral"}) {
      if (std::string(mode) == "spectral" ? !m.find("spectral") : spt) continue;
      Params p = m.find("photons") ? photon_params(500, 5) : Params();
      p.set("seed", 5);
      p.set("film_transparent", true);
      if (m.find("spectral")) p.set("spectral", std::string(mode));
      fn(std::string(m.name), std::string(mode), p);
    }
  }
}
struct AlphaStats {
  double mean = 0, lo = 1, hi = 0, se = 0;  // se: the mean's standard error (pixels independent)
  RGB colour;
};
AlphaStats alpha_of(const std::string& method, const Scene& scene, int passes, const Params& p) {
  const Film f = render(method, scene, passes, p);
  const Pass& a = f.pass(pass::kAlpha);
  AlphaStats s;
  for (size_t i = 0; i < f.pixel_count(); ++i) {
    s.mean += a.data[i];
    s.lo = std::min<double>(s.lo, a.data[i]);
    s.hi = std::max<double>(s.hi, a.data[i]);
  }
  s.mean /= f.pixel_count();
  double ss = 0;
  for (size_t i = 0; i < f.pixel_count(); ++i) ss += (a.data[i] - s.mean) * (a.data[i] - s.mean);
  s.se = std::sqrt(ss / (f.pixel_count() - 1) / f.pixel_count());
  s.colour = image_mean(f);
  return s;
}

TEST(FilmTransparent, ATintedPaneBeforeTheWorldLeavesOneMinusTheAverageOfItsColour) {
  int spectral_runs = 0;
  for_each_alpha_method([&](const std::string& name, const std::string& mode, const Params& p) {
    spectral_runs += mode == "spectral";
    for (const auto& [pane, alpha] : kTintedPanes) {
      const AlphaStats a = alpha_of(name, pane_before_world(pane), 2, p);
      std::printf("%s (%s), pane %s: alpha mean %.5f [%.5f, %.5f] (Cycles %.5f), colour %.5f %.5f %.5f\n",
                  name.c_str(), mode.c_str(), pane, a.mean, a.lo, a.hi, alpha, a.colour.r, a.colour.g, a.colour.b);
      const std::string what = name + " " + mode + " " + pane;
      EXPECT_NEAR(a.lo, alpha, 1e-5) << what;
      EXPECT_NEAR(a.hi, alpha, 1e-5) << what;
      EXPECT_EQ(a.colour.r + a.colour.g + a.colour.b, 0.0f) << what;  // no background
    }
  });
  EXPECT_GE(spectral_runs, 4);  // spt, spt-hero, and pt and sppm in spectral mode (at least)
}

// The same panes' colours as a Transparent BSDF mixed half and half with a diffuse one (a leaf's
// Alpha): a camera path passes with probability 1/2 in pt (Cycles picks the closure by its
// weight), with the closure's mean weight in the photon methods (a photon-diffuse surface,
// trace_eye), so alpha is 1 - mean(c)/2 only in expectation. Spectral: the pass's probability is
// RGB's (pt: the mix factor, the photon methods: the closure's RGB mean), the weight the
// closure's RGB colour over it. 64 x 64 pixels, 16 passes, seed 5: the image's alpha within kTol
// of Cycles'. A sample's transparency is 0 or its weight (at most 1), so its standard deviation
// is at most 1/2: the image's standard error at most 0.5 / 64 = 0.0078 with one camera path per
// pixel (ppm), less with one per pass; kTol is 5 of those (printed: se, the measured one).
TEST(FilmTransparent, AHalfTransparentMixLeavesOneMinusHalfTheAverageOfItsColourOnAverage) {
  constexpr double kTol = 0.04;
  for_each_alpha_method([&](const std::string& name, const std::string& mode, const Params& p) {
    for (const auto& [pane, alpha] : kTintedPanes) {
      if (alpha == 0.0f) continue;  // clear: not a tint
      const std::string more = R"(, "leaf": {"type": "diffuse", "color": 0.5}, "tint": )" + std::string(pane);
      const double expected = 1.0 - 0.5 * (1.0 - alpha);
      const AlphaStats a =
          alpha_of(name, pane_before_world(R"({"type": "mix", "factor": 0.5, "a": "leaf", "b": "tint"})", more, 64), 16, p);
      std::printf("%s (%s), half-transparent %s: alpha mean %.5f (se %.5f) [%.5f, %.5f] (Cycles %.5f)\n", name.c_str(),
                  mode.c_str(), pane, a.mean, a.se, a.lo, a.hi, expected);
      EXPECT_NEAR(a.mean, expected, kTol) << name << " " << mode << " " << pane;
    }
  });
}

}  // namespace
}  // namespace gp
