// `render --pixel` (core/parallel.h PixelWindow): one pixel, single-threaded, computes the
// same samples as the full multi-threaded render of the same seed.
#include <gtest/gtest.h>

#include "core/parallel.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// The pass `pass` of pixel (x, y) after `passes` passes: the whole image with two threads, or
// that pixel alone with one.
std::vector<float> pixel_value(const std::string& method, const Scene& s, std::string_view pass, int x, int y,
                               bool alone, nlohmann::json extra = nlohmann::json::object()) {
  Params p(std::move(extra));
  p.set("seed", 5);
  p.set("threads", alone ? 1 : 2);
  std::optional<PixelWindow> window;
  if (alone) window.emplace(x, y);
  const Film f = render(method, s, 3, p);
  const Pass& ps = f.pass(pass);
  const size_t i = static_cast<size_t>(y) * f.width() + x;
  return std::vector<float>(ps.data.begin() + ps.channels * i, ps.data.begin() + ps.channels * (i + 1));
}

// Bit for bit where every pixel's estimate is its own samples alone; photon methods gather the
// same photons, but their lookup grid's cells are sized by the largest radius over all the
// measurement points (photon_hash.h), so the sums run in another order: float rounding apart.
TEST(PixelWindow, OnePixelIsTheFullRendersPixel) {
  const Scene box = cornell_box(12, 10);
  const Scene prism = test_scene("prism", 12, 10);
  const nlohmann::json none = nlohmann::json::object(), few_photons = {{"photons", 5000}};
  const std::vector<std::tuple<std::string, const Scene*, std::string_view, nlohmann::json, float>> cases = {
      {"pt", &box, pass::kCombined, none, 0.0f},
      {"gpt", &box, pass::kPrimal, none, 0.0f},  // the primal: the reconstruction needs every pixel
      {"spt-hero", &prism, pass::kCombined, none, 0.0f},
      {"sgpt", &prism, pass::kCombined, none, 0.0f},  // its reconstruction is per pixel (over wavelengths)
      {"sppm", &box, pass::kCombined, few_photons, 1e-6f},
      {"ppm", &box, pass::kCombined, few_photons, 1e-6f},
      {"msppm", &box, pass::kCombined, none, 1e-6f},
      {"gpm", &box, pass::kPrimal, few_photons, 1e-6f}};
  for (const auto& [method, scene, pass, extra, rel] : cases)
    for (auto [x, y] : {std::pair{3, 4}, std::pair{7, 2}}) {
      const auto full = pixel_value(method, *scene, pass, x, y, false, extra);
      const auto alone = pixel_value(method, *scene, pass, x, y, true, extra);
      EXPECT_GT(full[0] + full[1] + full[2], 0.0f) << method << ": a lit pixel, so the comparison means something";
      if (rel == 0) {
        EXPECT_EQ(full, alone) << method << " pixel " << x << "," << y;
        continue;
      }
      for (size_t c = 0; c < full.size(); ++c)
        EXPECT_NEAR(alone[c], full[c], rel * full[c]) << method << " pixel " << x << "," << y << " channel " << c;
    }
}

TEST(PixelWindow, LeavesEveryOtherPixelUntouched) {
  const Scene box = cornell_box(8, 6);
  Params p(nlohmann::json{{"seed", 5}, {"threads", 1}});
  std::optional<PixelWindow> window(std::in_place, 2, 3);
  const Film f = render("pt", box, 2, p);
  const Pass& c = f.pass(pass::kCombined);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) {
      const float v = c.data[3 * (y * 8 + x)];
      if (x == 2 && y == 3) EXPECT_GT(v, 0.0f);
      else EXPECT_EQ(v, 0.0f) << x << "," << y;
    }
}

}  // namespace
}  // namespace gp
