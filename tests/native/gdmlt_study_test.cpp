// Measurement harness for GD-MLT's bias and convergence studies (docs/gradient.md). Disabled:
// run by hand with
//   STUDY_SCENE=cornell-glass.json STUDY_W=48 STUDY_H=36 STUDY_METHOD=gdmlt STUDY_PASSES=64,256 \
//   STUDY_SEEDS=0:32 STUDY_PARAMS='{"recon":"l2"}' STUDY_REF=ref.exr \
//   build/gradphoton_tests --gtest_also_run_disabled_tests --gtest_filter='*Study*'
// Prints one line per seed and checkpoint: seed, passes, image means (all channels) of the
// combined and primal passes, relMSE of combined against STUDY_REF (if given), b, acceptance.
// STUDY_SAVE=path writes the last seed's film at the last checkpoint.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "integrators/integrator.h"
#include "io/exr.h"
#include "io/metrics.h"
#include "scene/loader.h"

namespace gp {
namespace {

std::string env(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v ? v : fallback;
}

double mean_of(const Pass& p) {
  double s = 0;
  for (float v : p.data) s += v;
  return s / static_cast<double>(p.data.size());
}

TEST(GdmltStudy, DISABLED_Study) {
  const std::string file = env("STUDY_SCENE", "cornell-glass.json");
  std::ifstream f(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/" + file);
  std::stringstream ss;
  ss << f.rdbuf();
  auto j = nlohmann::json::parse(ss.str());
  const int w = std::stoi(env("STUDY_W", "48")), h = std::stoi(env("STUDY_H", "36"));
  j["camera"]["width"] = w;
  j["camera"]["height"] = h;
  const Scene scene = load_scene_from_string(j.dump(), std::string(GRADPHOTON_SOURCE_DIR) + "/scenes", file);
  const std::string method = env("STUDY_METHOD", "gdmlt");
  std::vector<int64_t> checkpoints;
  {
    std::stringstream cs(env("STUDY_PASSES", "64"));
    std::string t;
    while (std::getline(cs, t, ',')) checkpoints.push_back(std::stoll(t));
  }
  const std::string seeds = env("STUDY_SEEDS", "0:8");
  const int s0 = std::stoi(seeds.substr(0, seeds.find(':'))), s1 = std::stoi(seeds.substr(seeds.find(':') + 1));
  const std::string ref_path = env("STUDY_REF", "");
  Film ref;
  if (!ref_path.empty()) ref = read_exr(ref_path);
  const std::string save = env("STUDY_SAVE", "");
  for (int seed = s0; seed < s1; ++seed) {
    Params p(nlohmann::json::parse(env("STUDY_PARAMS", "{}")));
    p.set("seed", static_cast<uint64_t>(seed));
    auto integ = make_integrator(method, scene, p);
    for (int64_t c : checkpoints) {
      run_progressive(*integ, StopRule{0, c, 0}, nullptr);
      Film film;
      integ->develop(film);
      double rel = -1;
      if (!ref_path.empty())
        rel = diff_images(film.pass(pass::kCombined), ref.pass(pass::kCombined), w, h).rel_mse;
      const auto& ex = integ->stats().extra;
      std::printf("STUDY %d %lld %.6g %.6g %.6g %.6g %.4f %.3f\n", seed, static_cast<long long>(c),
                  mean_of(film.pass(pass::kCombined)),
                  film.has_pass(pass::kPrimal) ? mean_of(film.pass(pass::kPrimal)) : 0.0, rel,
                  ex.count("brightness b") ? ex.at("brightness b") : 0.0,
                  ex.count("acceptance rate") ? ex.at("acceptance rate") : 0.0, integ->stats().seconds);
      std::fflush(stdout);
      if (seed == s1 - 1 && c == checkpoints.back() && !save.empty()) {
        write_exr(save, film);
        // Raw float32 dumps for numpy: <save>.<pass>.f32
        for (const auto& [name, pass] : film.passes()) {
          std::ofstream o(save + "." + name + ".f32", std::ios::binary);
          o.write(reinterpret_cast<const char*>(pass.data.data()), pass.data.size() * sizeof(float));
        }
        if (!ref_path.empty()) {
          std::ofstream o(save + ".ref.f32", std::ios::binary);
          const auto& d = ref.pass(pass::kCombined).data;
          o.write(reinterpret_cast<const char*>(d.data()), d.size() * sizeof(float));
        }
      }
    }
  }
}

}  // namespace
}  // namespace gp
