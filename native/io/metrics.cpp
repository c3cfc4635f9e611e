#include "io/metrics.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace gp {

DiffResult diff_images(const Pass& a, const Pass& ref, int width, int height) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("diff: bad image size " + std::to_string(width) + "x" + std::to_string(height));
  if (a.channels != ref.channels)
    throw std::invalid_argument("diff: channel count mismatch: image has " + std::to_string(a.channels) +
                                ", reference has " + std::to_string(ref.channels));
  if (a.channels != 1 && a.channels != 3)
    throw std::invalid_argument("diff: channels must be 1 or 3, got " + std::to_string(a.channels));
  const size_t n = size_t(width) * size_t(height);
  const size_t expected = n * size_t(a.channels);
  if (a.data.size() != expected || ref.data.size() != expected)
    throw std::invalid_argument("diff: size mismatch: image has " + std::to_string(a.data.size()) +
                                " values, reference has " + std::to_string(ref.data.size()) + ", expected " +
                                std::to_string(expected) + " (" + std::to_string(width) + "x" +
                                std::to_string(height) + "x" + std::to_string(a.channels) + ")");

  const int c = a.channels;
  DiffResult r;
  r.pixels = n;
  r.per_pixel_rel_se.assign(n, 0.0f);
  double sum_rel = 0, sum_sq = 0, sum_a = 0, sum_r = 0;
  size_t finite_pixels = 0;
  for (size_t i = 0; i < n; ++i) {
    bool finite = true;
    for (int k = 0; k < c; ++k)
      finite = finite && std::isfinite(a.data[i * c + k]) && std::isfinite(ref.data[i * c + k]);
    if (!finite) {
      ++r.nonfinite;
      r.per_pixel_rel_se[i] = std::numeric_limits<float>::infinity();
      continue;
    }
    ++finite_pixels;
    double pixel_rel = 0;
    for (int k = 0; k < c; ++k) {
      const double av = a.data[i * c + k], rv = ref.data[i * c + k];
      const double d = av - rv;
      const double rel = d * d / (rv * rv + 0.001);
      pixel_rel += rel;
      sum_sq += d * d;
      sum_a += av;
      sum_r += rv;
    }
    sum_rel += pixel_rel;
    r.per_pixel_rel_se[i] = static_cast<float>(pixel_rel / c);
  }
  if (finite_pixels == 0) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.rel_mse = r.rmse = r.mean_ratio = nan;
    return r;
  }
  const double count = double(finite_pixels) * c;
  r.rel_mse = sum_rel / count;
  r.rmse = std::sqrt(sum_sq / count);
  r.mean_ratio = (sum_a == 0 && sum_r == 0) ? 1.0 : sum_a / sum_r;  // +-inf if only mean(R) is 0
  return r;
}

}  // namespace gp
