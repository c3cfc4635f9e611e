// The gradient methods' unbiasedness statistic (gpm_test, multiscatter_shift_test): over
// independent runs (one seed each), per pixel pair of the image (x and y, summed over RGB),
// z = mean(G - dP) / its standard error; when the gradients are the primal's expected
// differences, the sum of z^2 over the pairs is chi-square with one degree of freedom per pair.
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "core/film.h"

namespace gp {

class GradientPairChi2 {
 public:
  GradientPairChi2(int width, int height)
      : w_(width), h_(height), n_(static_cast<size_t>(width) * height), sx_(2 * n_, 0.0), sxx_(2 * n_, 0.0) {}

  // One run's developed film (its primal and gradient passes).
  void add(const Film& f) {
    const auto& P = f.pass(pass::kPrimal).data;
    const auto& GX = f.pass(pass::kGradientX).data;
    const auto& GY = f.pass(pass::kGradientY).data;
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        const size_t i = static_cast<size_t>(y) * w_ + x;
        double ex = 0, ey = 0;
        for (int c = 0; c < 3; ++c) {
          if (x + 1 < w_) ex += GX[3 * i + c] - (P[3 * (i + 1) + c] - P[3 * i + c]);
          if (y + 1 < h_) ey += GY[3 * i + c] - (P[3 * (i + w_) + c] - P[3 * i + c]);
        }
        sx_[i] += ex, sxx_[i] += ex * ex;
        sx_[n_ + i] += ey, sxx_[n_ + i] += ey * ey;
      }
    ++runs_;
  }

  struct Result {
    double chi2 = 0;
    int pairs = 0;
    // How many standard deviations chi2 lies above its mean (pairs; its variance is 2 pairs).
    double excess() const { return (chi2 - pairs) / std::sqrt(2.0 * pairs); }
  };

  Result result() const {
    Result r;
    const double runs = runs_;
    for (size_t k = 0; k < 2 * n_; ++k) {
      const double mean = sx_[k] / runs, var = (sxx_[k] / runs - mean * mean) * runs / (runs - 1.0);
      if (!(var > 1e-20)) continue;  // a pair nothing reached (or the image border)
      r.chi2 += mean * mean / (var / runs);
      ++r.pairs;
    }
    return r;
  }

 private:
  int w_, h_;
  size_t n_;
  std::vector<double> sx_, sxx_;
  int runs_ = 0;
};

}  // namespace gp
