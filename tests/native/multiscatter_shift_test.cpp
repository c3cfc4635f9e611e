// Gradient methods on a caustic through a Multiscatter GGX glass (issue 30): its BSDF is a random
// walk on the microsurface (bsdf.cpp), whose sampled directions hold no half-vector and whose
// density is unknown. GPM never walks a chain through it (photon_walk.h: such photons stay in the
// primal domain); gpt (and gdmlt, which runs its paths) stops offsets that do not share the base's
// vertex there (gpt.cpp). The images keep the means of the methods they refine: gpm SPPM's, gpt
// and gdmlt the path tracer's (their gradients that image's expected differences).
//
// The scene: a light above a glass ball over a diffuse floor; the ball is glossy below the
// specular threshold (alpha 0.03: its vertices would join the photons' chains) or rough above it
// (alpha 0.3: photons are stored on it and shifts reconnect there).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "gradient_test_util.h"
#include "render_for_tests.h"

namespace gp {
namespace {

Scene caustic_scene(float alpha) {
  return scene_from(R"({
    "lights": [{"type": "spot", "position": [0.05, 0.02, 2.0], "direction": [0, 0, -1], "spot_size": 40, "spot_blend": 0.5, "intensity": 8}],
    "materials": {"white": {"type": "diffuse", "color": 0.7},
                  "glass": {"type": "dielectric", "ior": 1.5, "distribution": "multi_ggx", "roughness": )" +
                    std::to_string(alpha) + R"(}},
    "objects": [
      {"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"},
      {"type": "sphere", "center": [0, 0, 0.7], "radius": 0.3, "segments": 48, "material": "glass"}],
    "camera": {"position": [0.9, -0.9, 1.0], "look_at": [0, 0, 0.2], "fov": 35, "width": 24, "height": 24}})");
}

float luminance_mean(const Film& f) { return image_mean(f).luminance(); }

TEST(MultiscatterShift, GpmKeepsSppmsMeanAndWalksNoChainThroughTheGlass) {
  for (float alpha : {0.03f, 0.3f}) {
    const Scene s = caustic_scene(alpha);
    Params p = photon_params(20000, 3, 1);
    Stats stats;
    const float gpm = luminance_mean(render("gpm", s, 8, p, &stats));
    const float sppm = luminance_mean(render("sppm", s, 8, p));
    const double walks = stats.extra.count("manifold walks") ? stats.extra.at("manifold walks") : 0.0;
    std::printf("alpha %.2f: gpm / sppm = %.4f (%.0f manifold walks)\n", alpha, gpm / sppm, walks);
    EXPECT_EQ(walks, 0.0) << alpha;
    EXPECT_NEAR(gpm / sppm, 1.0, 0.03) << alpha;  // L1 reconstruction of the same photons
  }
}

// gpt: its gradients are the expected differences of its primal (the path tracer's image) when
// its shifts are right. One sample per pixel per seed, an area light above the ball (a point
// light's caustic is found only by next-event estimation through the glass, too noisy to test
// here); per pixel pair, z = mean(G - dP) / its standard error over the seeds, whose squares sum
// to a chi-square with one degree of freedom per pair (as GPM's test, gpm_test.cpp). gdmlt's
// pairs are gpt's paths (PathPair), the same shifts.
TEST(MultiscatterShift, GptGradientsAreThePrimalsExpectedDifferences) {
  for (float alpha : {0.03f, 0.3f}) {
    const Scene s = scene_from(R"({
      "lights": [],
      "materials": {"white": {"type": "diffuse", "color": 0.7},
                    "lamp": {"type": "emission", "emission": 1, "strength": 20, "two_sided": false},
                    "glass": {"type": "dielectric", "ior": 1.5, "distribution": "multi_ggx", "roughness": )" +
                               std::to_string(alpha) + R"(}},
      "objects": [
        {"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"},
        {"type": "quad", "center": [0.05, 0.02, 2.0], "u": [0, 0.3, 0], "v": [0.3, 0, 0], "material": "lamp"},
        {"type": "sphere", "center": [0, 0, 0.7], "radius": 0.3, "segments": 48, "material": "glass"}],
      "camera": {"position": [0.9, -0.9, 1.0], "look_at": [0, 0, 0.2], "fov": 35, "width": 16, "height": 16}})");
    const int seeds = 200;
    GradientPairChi2 stat(16, 16);
    for (int seed = 1; seed <= seeds; ++seed) {
      Params p;
      p.set("seed", seed);
      p.set("threads", 1);
      auto g = make_integrator("gpt", s, p);
      g->iterate(nullptr);
      Film f;
      g->develop(f);
      stat.add(f);
    }
    const GradientPairChi2::Result r = stat.result();
    const double chi2 = r.chi2, excess = r.excess();
    const int pairs = r.pairs;
    std::printf("alpha %.2f: gpt chi2 %.1f over %d pairs (%.1f sd from its mean)\n", alpha, chi2, pairs, excess);
    EXPECT_GT(pairs, 200) << alpha;
    EXPECT_LT(excess, 4.0) << alpha;
  }
}

}  // namespace
}  // namespace gp
