// Gradient-domain Metropolis light transport (integrators/gradient/gdmlt): convergence to a
// path-traced reference and its mean, determinism across thread counts, finiteness through
// glass, the sample-density pass, statistics and parameter checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/progress.h"
#include "integrators/methods.h"
#include "integrators/gradient/gdmlt.h"
#include "io/metrics.h"
#include "scene/loader.h"

namespace gp {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

Scene scene_sized(const std::string& file, int width, int height) {
  auto j = nlohmann::json::parse(read_text(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/" + file));
  j["camera"]["width"] = width;
  j["camera"]["height"] = height;
  return load_scene_from_string(j.dump(), std::string(GRADPHOTON_SOURCE_DIR) + "/scenes", file);
}

std::unique_ptr<Integrator> run(const Scene& s, const std::string& method, int passes, uint64_t seed, int threads = 0,
                                nlohmann::json extra = nlohmann::json::object()) {
  Params p(std::move(extra));
  p.set("seed", seed);
  p.set("threads", threads);
  auto integ = make_integrator(method, s, p);
  if (passes > 0) run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  return integ;
}

TEST(GradientDomainMlt, ConvergesToThePathTracedReferenceAndItsMean) {
  const Scene s = scene_sized("cornell-box.json", 16, 16);
  Film ref, early, late;
  run(s, "pt", 2000, 99)->develop(ref);
  auto g = run(s, "gdmlt", 64, 1);
  g->develop(early);
  run_progressive(*g, StopRule{0, 1024, 0}, nullptr);
  g->develop(late);
  const DiffResult d0 = diff_images(early.pass(pass::kCombined), ref.pass(pass::kCombined), 16, 16);
  const DiffResult d = diff_images(late.pass(pass::kCombined), ref.pass(pass::kCombined), 16, 16);
  std::printf("gdmlt relMSE %.4g (64 passes) %.4g (1024 passes), mean ratio %.4f, acceptance %.3f, b %.4g\n",
              d0.rel_mse, d.rel_mse, d.mean_ratio, g->stats().extra.at("acceptance rate"),
              g->stats().extra.at("brightness b"));
  EXPECT_LT(d.rel_mse, 8e-3);  // measured 1.8e-3 (2.1e-3 without large-step MIS; the reference adds ~1e-3)
  EXPECT_LT(d.rel_mse, 0.3 * d0.rel_mse);  // it converges (about as 1 / passes)
  // One seed's mean is Metropolis noise of a few percent (per-seed standard deviation ~2.5 % here);
  // the mean's bias is checked over seeds in ImageMeanIsUnbiasedOverSeeds.
  EXPECT_NEAR(d.mean_ratio, 1.0, 0.08);
  EXPECT_EQ(d.nonfinite, 0u);

  // The chains concentrate where the image changes (the slides' "many samples along shadow
  // boundaries"), not merely where it is bright: per unit of reference luminance, the pixels
  // that differ most from a neighbour get more chain states than the flattest half. (Image-domain
  // Metropolis, density ~ luminance, gives a ratio near 1: primal_share = 100 fails this check.)
  const int n = 16 * 16;
  std::vector<std::pair<double, double>> edge_density(n);  // (max |lum difference|, density)
  auto lum = [&](int x, int y) { return ref.rgb(pass::kCombined, x, y).luminance(); };
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      double e = 0;
      if (x + 1 < 16) e = std::max<double>(e, std::abs(lum(x + 1, y) - lum(x, y)));
      if (x > 0) e = std::max<double>(e, std::abs(lum(x - 1, y) - lum(x, y)));
      if (y + 1 < 16) e = std::max<double>(e, std::abs(lum(x, y + 1) - lum(x, y)));
      if (y > 0) e = std::max<double>(e, std::abs(lum(x, y - 1) - lum(x, y)));
      edge_density[y * 16 + x] = {e, late.pass(pass::kSampleDensity).data[y * 16 + x] / (lum(x, y) + 1e-3)};
    }
  std::sort(edge_density.begin(), edge_density.end());
  double flat = 0, edges = 0;
  for (int i = 0; i < n / 2; ++i) flat += edge_density[i].second / (n / 2);
  for (int i = 3 * n / 4; i < n; ++i) edges += edge_density[i].second / (n / 4);
  std::printf("mean sample density / luminance: flattest half %.1f, strongest-edge quarter %.1f\n", flat, edges);
  EXPECT_GT(edges, 1.25 * flat);  // measured 1.44 (primal_share = 100: 1.02)
}

double image_mean(const Pass& p) {
  double s = 0;
  for (float v : p.data) s += v;
  return s / static_cast<double>(p.data.size());
}

// The image mean, averaged over independent seeds, matches path tracing within its error bar:
// a 5 % brightness bias (e.g. in b, the start states or the splat weights) fails this with a wide
// margin. The reconstruction is L2 here, which keeps the primal's mean, so the check covers the
// primal estimator and the reconstruction alike. One seed alone is not enough on glass: a chain that
// sits on a caustic moves a whole image's mean by several percent (docs/gradient.md).
void expect_unbiased_over_seeds(const std::string& file, int w, int h, int seeds, int passes, int ref_passes,
                                double tolerance, nlohmann::json extra) {
  const Scene s = scene_sized(file, w, h);
  Film ref;
  run(s, "pt", ref_passes, 99)->develop(ref);
  const double ref_mean = image_mean(ref.pass(pass::kCombined));
  extra["recon"] = "l2";
  double sum = 0, sum2 = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    Film f;
    run(s, "gdmlt", passes, seed, 0, extra)->develop(f);
    const double r = image_mean(f.pass(pass::kCombined)) / ref_mean;
    sum += r;
    sum2 += r * r;
  }
  const double mean = sum / seeds, se = std::sqrt(std::max(0.0, sum2 / seeds - mean * mean) / (seeds - 1));
  std::printf("%s %s: mean ratio over %d seeds %.4f +- %.4f (standard error)\n", file.c_str(), extra.dump().c_str(),
              seeds, mean, se);
  EXPECT_NEAR(mean, 1.0, tolerance);
}

TEST(GradientDomainMlt, ImageMeanIsUnbiasedOverSeeds) {
  // cornell-box 16 x 12, 24 seeds x 400 passes (~3 s): measured 0.997, standard error 0.011
  // (one seed alone: standard deviation ~5 %). A 5 % bias fails (checked: scaling b by 1.05 in
  // the estimator without large-step MIS gave 1.048).
  expect_unbiased_over_seeds("cornell-box.json", 16, 12, 24, 400, 3000, 0.025, nlohmann::json::object());
  // The other estimators: without large-step MIS (b / T splats), and the direct light from the
  // uniform samples. Measured 1.002 +- 0.009.
  expect_unbiased_over_seeds("cornell-box.json", 16, 12, 24, 400, 3000, 0.025,
                             {{"large_step_mis", false}, {"direct", "uniform"}});
}

TEST(GradientDomainMlt, SameImageWhateverTheThreadCountAndFiniteThroughGlass) {
  const Scene s = scene_sized("cornell-glass.json", 20, 16);
  Film one, two;
  auto a = run(s, "gdmlt", 3, 42, 1);
  a->develop(one);
  run(s, "gdmlt", 3, 42, 2)->develop(two);
  for (auto name : {pass::kCombined, pass::kPrimal, pass::kGradientX, pass::kGradientY, pass::kSampleDensity}) {
    EXPECT_EQ(one.pass(name).data, two.pass(name).data) << name;
    for (float v : one.pass(name).data) ASSERT_TRUE(std::isfinite(v)) << name;
  }
  EXPECT_EQ(a->stats().extra.at("chains"), 64);
  EXPECT_GT(a->stats().extra.at("acceptance rate"), 0.0);
  EXPECT_LT(a->stats().extra.at("acceptance rate"), 1.0);
  EXPECT_NEAR(a->stats().extra.at("large-step share"), 0.3, 0.05);
  EXPECT_GT(a->stats().extra.at("brightness b"), 0.0);
}

TEST(GradientDomainMlt, SampleDensityIsNonNegativeAndCountsEveryMutation) {
  const Scene s = scene_sized("cornell-box.json", 12, 10);
  auto g = run(s, "gdmlt", 5, 7, 0, {{"mutations", 2}});
  Film f;
  g->develop(f);
  double sum = 0, peak = 0;
  for (float v : f.pass(pass::kSampleDensity).data) {
    ASSERT_GE(v, 0.0f);
    sum += v;
    peak = std::max<double>(peak, v);
  }
  EXPECT_EQ(sum, 5.0 * 2 * 12 * 10);
  EXPECT_GT(peak, 2.0 * sum / (12 * 10));  // Metropolis concentrates samples: not uniform
}

TEST(GradientDomainMlt, RejectsBadParameters) {
  const Scene s = scene_sized("cornell-box.json", 8, 8);
  for (auto bad : {nlohmann::json{{"recon", "l3"}}, nlohmann::json{{"lambda", 0}}, nlohmann::json{{"primal_share", 0}},
                   nlohmann::json{{"large_step", 1.5}}, nlohmann::json{{"chains", 0}},
                   nlohmann::json{{"mutations", 0}}, nlohmann::json{{"sigma", 0}},
                   nlohmann::json{{"direct", "somewhere"}}}) {
    Params p(bad);
    EXPECT_THROW(make_integrator("gdmlt", s, p), ParamError) << bad.dump();
  }
  Params typo(nlohmann::json{{"large_stp", 0.3}});
  make_integrator("gdmlt", s, typo);
  EXPECT_EQ(typo.unused(), std::vector<std::string>{"large_stp"});
  const auto names = integrator_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "gdmlt"), names.end());
}

}  // namespace
}  // namespace gp

namespace gp {
namespace {

// A sink that asks for a pause at every chance (Blender's F12 window asking for images as often
// as it can).
class PauseAlways : public ProgressSink {
 public:
  bool pause() override { return true; }
};

// The bootstrap (one gradient sample per pixel, about a gpt pass: 7 s at 1920 x 1080) pauses
// between its blocks of samples as the passes do between chains' polls, so Blender publishes
// images during it: develop() then shows its samples so far over the whole film (finite, more
// pixels lit at each call, no chain sample yet), and the calls after go on to the image, the
// statistics and the passes of an unpaused render, bit for bit. 64 x 48 pixels: three blocks of
// kCancelPoll samples, one a call, the third call going on into the first pass (64 chains of 48
// mutations, too few for a poll), the fourth the second pass.
TEST(GradientDomainMlt, APausedBootstrapGivesTheUnpausedImage) {
  const Scene s = scene_sized("cornell-box.json", 64, 48);
  auto whole = run(s, "gdmlt", 2, 11, 1);
  auto paused = run(s, "gdmlt", 0, 11, 1);
  PauseAlways sink;
  int calls = 0;
  std::vector<int> lit;
  while (paused->stats().passes < 2 && calls < 100) {
    paused->iterate(&sink);
    ++calls;
    if (paused->stats().passes == 0) {
      Film f;
      paused->develop(f);
      int n = 0;
      for (size_t i = 0; i < f.pixel_count(); ++i) {
        const RGB c = f.rgb(pass::kCombined, static_cast<int>(i % 64), static_cast<int>(i / 64));
        ASSERT_TRUE(c.is_finite());
        n += c.max_component() > 0;
      }
      for (float v : f.pass(pass::kSampleDensity).data) ASSERT_EQ(v, 0.0f);
      lit.push_back(n);
    }
  }
  EXPECT_EQ(calls, 4);
  ASSERT_EQ(lit.size(), 2u);  // the first two calls each did one block and paused
  EXPECT_GT(lit[0], 0);
  EXPECT_GT(lit[1], lit[0]);
  const Stats& a = paused->stats();
  const Stats& b = whole->stats();
  EXPECT_EQ(a.rays, b.rays);
  EXPECT_EQ(a.shadow_rays, b.shadow_rays);
  EXPECT_EQ(a.paths, b.paths);
  EXPECT_EQ(a.invalid_samples, b.invalid_samples);
  Film fa, fb;
  paused->develop(fa);
  whole->develop(fb);
  for (auto name : {pass::kCombined, pass::kPrimal, pass::kGradientX, pass::kGradientY, pass::kSampleDensity})
    EXPECT_EQ(fa.pass(name).data, fb.pass(name).data) << name;
}

TEST(PrimarySampleChain, FirstEvaluationIsTheRngStreamAndRejectRestoresTheState) {
  // The chains' start states replay bootstrap samples drawn with RngSampler: the first
  // (all-uniform) evaluation must read the very same numbers.
  Rng stream = Rng::for_key(5, 6, 7);
  PrimarySampleChain chain(stream, 0.01, 0.3);
  std::vector<float> first;
  for (int i = 0; i < 8; ++i) {
    first.push_back(chain.uniform());
    EXPECT_EQ(first.back(), stream.uniform());
  }
  chain.accept();
  // A rejected proposal leaves the state as it was: after 400 rejected small steps the next
  // proposal is one step (sigma = 0.01) from `first`, not a 400-step random walk (~0.2) away.
  PrimarySampleChain c2(Rng::for_key(5, 6, 7), 0.01, 0.0);
  for (int i = 0; i < 8; ++i) c2.uniform();
  c2.accept();
  for (int it = 0; it < 400; ++it) {
    c2.start_iteration();
    for (int i = 0; i < 8; ++i) c2.uniform();
    c2.reject();
  }
  c2.start_iteration();
  for (int i = 0; i < 8; ++i) {
    const float d = std::abs(c2.uniform() - first[i]);
    EXPECT_LT(std::min(d, 1.0f - d), 0.05f) << i;  // distance on the circle [0, 1)
  }
}

}  // namespace
}  // namespace gp
