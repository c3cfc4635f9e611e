// Chi-square of a World's direction sampler (lights/background.h) against its own density:
// samples binned in equal-solid-angle cells (z, phi), expected counts by quadrature of pdf().
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "chi2.h"
#include "core/rng.h"
#include "lights/background.h"

namespace gp {

inline Chi2Result chi2_of(const BackgroundTerm& map, int n, int nt = 24, int np = 48, int sub = 12) {
  std::vector<double> observed(size_t(nt) * np, 0.0), expected(size_t(nt) * np, 0.0);
  Rng rng(11, 0);
  int accepted = 0;
  auto cell_of = [&](const Vec3& d) {
    const int t = std::clamp(int((d.z + 1) * 0.5f * nt), 0, nt - 1);
    float phi = std::atan2(d.y, d.x);
    if (phi < 0) phi += 2 * kPi;
    const int p = std::clamp(int(phi / (2 * kPi) * np), 0, np - 1);
    return size_t(t) * np + p;
  };
  for (int i = 0; i < n; ++i) {
    Vec3 d;
    float pdf;
    if (!map.sample(Vec2(rng.uniform(), rng.uniform()), &d, &pdf)) continue;
    ++accepted;
    observed[cell_of(d)] += 1;
  }
  Chi2Result r;
  double total = 0;
  for (int t = 0; t < nt; ++t)
    for (int p = 0; p < np; ++p) {
      double s = 0;
      for (int j = 0; j < sub; ++j)
        for (int i = 0; i < sub; ++i) {
          const float z = -1 + 2 * (t + (j + 0.5f) / sub) / nt, phi = 2 * kPi * (p + (i + 0.5f) / sub) / np;
          const float st = std::sqrt(std::max(0.0f, 1 - z * z));
          s += map.pdf(Vec3(st * std::cos(phi), st * std::sin(phi), z));
        }
      const double cell_sr = 4 * kPi / (nt * np);
      expected[size_t(t) * np + p] = s / (sub * sub) * cell_sr;
      total += expected[size_t(t) * np + p];
    }
  r.pdf_integral = total;
  r.accepted_fraction = double(accepted) / n;
  for (double& e : expected) e *= n;  // rejected samples: the density integrates to < 1
  pearson_pooled(observed, expected, 5.0, r);
  return r;
}

}  // namespace gp
