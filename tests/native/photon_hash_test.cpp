// Photon hash grid: exact queries return exactly the photons within the radius, and the
// stochastic hashing of thesis ch. 10 gives the same sums in expectation.
#include <gtest/gtest.h>

#include <string>

#include "integrators/photon/photon_hash.h"
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

}  // namespace
}  // namespace gp
