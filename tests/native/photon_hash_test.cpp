// Photon hash grid: exact queries return exactly the photons within the radius, and the
// stochastic hashing of thesis ch. 10 gives the same sums in expectation.
#include <gtest/gtest.h>

#include <string>

#include "integrators/photon/photon_hash.h"

#include <map>

#include "chi2.h"
#include "core/rng.h"
#include "scene/loader.h"

namespace gp {
namespace {

std::vector<Photon> cornell_photons(int64_t n) {
  static const Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-box.json");
  std::vector<Photon> out;
  PhotonTracer(s, 16, kDefaultSpecularThreshold, 11, 0).trace(n, 0, 0, out);
  return out;
}

// Power (green) within r of q according to the grid: sum of weight * power.
double grid_sum(const PhotonHashGrid& g, const Vec3& q, float r, double* count = nullptr) {
  double sum = 0, m = 0;
  g.query(q, r, [&](const Photon& p, float, float w) { sum += w * p.power.g; m += w; });
  if (count) *count = m;
  return sum;
}

TEST(PhotonHash, ExactQueryFindsExactlyThePhotonsInRange) {
  const std::vector<Photon> photons = cornell_photons(20000);
  PhotonHashGrid g;
  const float r = 0.08f;
  g.build(photons, 2 * r, PhotonHashMode::Exact, 0, 0, 0);
  EXPECT_EQ(g.stored(), photons.size());
  for (size_t k = 0; k < photons.size(); k += 997) {
    const Vec3 q = photons[k].p + Vec3(0.01f, -0.02f, 0.015f);
    double brute = 0, brute_n = 0;
    for (const Photon& p : photons)
      if (length_squared(p.p - q) <= r * r) { brute += p.power.g; brute_n += 1; }
    double n = 0;
    EXPECT_NEAR(grid_sum(g, q, r, &n), brute, 1e-6 * (1 + brute));
    EXPECT_EQ(n, brute_n);
  }
  // A radius larger than half a cell still works (more cells visited).
  g.build(photons, 0.05f, PhotonHashMode::Exact, 0, 0, 0);
  const Vec3 q = photons[5].p;
  double brute = 0;
  for (const Photon& p : photons)
    if (length_squared(p.p - q) <= 0.2f * 0.2f) brute += p.power.g;
  EXPECT_NEAR(grid_sum(g, q, 0.2f), brute, 1e-6 * (1 + brute));
}

// A cancelled build (Esc during a photon pass's grid build) stops between its stages and leaves
// an empty grid; a build polled but not cancelled is the full grid.
TEST(PhotonHash, CancelledExactBuildStopsAndLeavesAnEmptyGrid) {
  const std::vector<Photon> photons = cornell_photons(20000);
  PhotonHashGrid g;
  int polls = 0;
  g.build(photons, 0.16f, PhotonHashMode::Exact, 0, 0, 0, 0, [&] { ++polls; return false; });
  EXPECT_EQ(polls, 3);  // polled between the stages, not cancelled: the full grid
  EXPECT_EQ(g.stored(), photons.size());
  EXPECT_GT(grid_sum(g, photons[7].p, 0.08f), 0.0);
  polls = 0;  // a later build cancelled at its first poll replaces that grid by an empty one
  g.build(photons, 0.16f, PhotonHashMode::Exact, 0, 0, 0, 0, [&] { return ++polls >= 1; });
  EXPECT_EQ(polls, 1);
  EXPECT_EQ(g.stored(), 0u);
  EXPECT_EQ(grid_sum(g, photons[7].p, 0.08f), 0.0);
}

TEST(PhotonHash, StochasticSelectionIsUnbiased) {
  // Thesis §10.2.1: one photon per bucket, power times the bucket count. Averaged over many
  // independent selections, every query's sum must approach the exact one.
  const std::vector<Photon> photons = cornell_photons(20000);
  const float r = 0.06f;
  PhotonHashGrid exact, stochastic;
  exact.build(photons, 2 * r, PhotonHashMode::Exact, 0, 0, 0);
  std::vector<Vec3> queries;
  for (size_t k = 0; k < photons.size(); k += 401) queries.push_back(photons[k].p);
  std::vector<double> want(queries.size()), got(queries.size(), 0.0);
  double want_total = 0, got_total = 0;
  for (size_t i = 0; i < queries.size(); ++i) want_total += want[i] = grid_sum(exact, queries[i], r);
  const int trials = 300;
  for (int t = 0; t < trials; ++t) {
    stochastic.build(photons, 2 * r, PhotonHashMode::Stochastic, 1234, t, 0);
    EXPECT_LT(stochastic.stored(), photons.size());
    for (size_t i = 0; i < queries.size(); ++i) got[i] += grid_sum(stochastic, queries[i], r) / trials;
  }
  for (double g : got) got_total += g;
  EXPECT_NEAR(got_total / want_total, 1.0, 0.03);
  // Not merely the total: most single queries agree within their Monte Carlo noise.
  int close = 0;
  for (size_t i = 0; i < queries.size(); ++i) close += std::abs(got[i] - want[i]) <= 0.2 * want[i] + 1e-9;
  EXPECT_GE(close, static_cast<int>(0.9 * queries.size()));
}

TEST(PhotonHash, StochasticBuildKeepsAUniformChoiceWeightedByTheCount) {
  // Thesis §10.2.1 / §10.2.4: 8 photons in one cell, told apart by their power (1 .. 8); over
  // 8000 builds (passes) each must be the bucket's photon 1/8 of the time (chi-square), with
  // weight 8. A build that kept the first photon written or the lowest index would fail.
  std::vector<Photon> photons;
  for (int k = 0; k < 8; ++k) photons.push_back(Photon{Vec3(0.1f + 0.01f * k, 0.2f, 0.3f), Vec3(0, 0, 1), RGB(float(k + 1))});
  PhotonHashGrid g;
  std::vector<double> observed(8, 0.0), expected(8, 1000.0);
  for (int pass = 0; pass < 8000; ++pass) {
    g.build(photons, 1.0f, PhotonHashMode::Stochastic, 5, pass, 0);
    ASSERT_EQ(g.stored(), 1u);
    int found = 0;
    g.query(Vec3(0.12f, 0.2f, 0.3f), 0.2f, [&](const Photon& ph, float, float w) {
      EXPECT_EQ(w, 8.0f);
      observed[static_cast<int>(ph.power.g) - 1] += 1;
      ++found;
    });
    ASSERT_EQ(found, 1);
  }
  Chi2Result r;
  pearson_pooled(observed, expected, 5, r);
  EXPECT_GE(r.p_value, 1e-3) << "chi2 " << r.statistic;
}

TEST(PhotonHash, StochasticBuildIsTheSameWhateverTheThreadCount) {
  // The atomic minimum does not depend on the order of the writes; the counts add up to the
  // photons written.
  const std::vector<Photon> photons = cornell_photons(20000);
  PhotonHashGrid one, two;
  one.build(photons, 0.1f, PhotonHashMode::Stochastic, 3, 7, 1);
  two.build(photons, 0.1f, PhotonHashMode::Stochastic, 3, 7, 2);
  EXPECT_EQ(one.stored(), two.stored());
  double total = 0;
  for (size_t k = 0; k < photons.size(); k += 53) {
    double n1 = 0, n2 = 0;
    EXPECT_EQ(grid_sum(one, photons[k].p, 0.05f, &n1), grid_sum(two, photons[k].p, 0.05f, &n2));
    EXPECT_EQ(n1, n2);
  }
  // Every photon is counted once: with cells larger than the box, a query covering the box
  // sums the weights to n.
  one.build(photons, 8.0f, PhotonHashMode::Stochastic, 3, 7, 2);
  one.query(Vec3(0, 0, 1), 3.9f, [&](const Photon&, float, float w) { total += w; });
  EXPECT_EQ(total, static_cast<double>(photons.size()));
}

}  // namespace
}  // namespace gp
