// Image error metrics for `gradphoton diff`, convergence charts and tests.
#pragma once

#include <cstddef>
#include <vector>

#include "core/film.h"

namespace gp {

struct DiffResult {
  double rel_mse = 0;     // mean over pixels and channels of (A-R)^2 / (R^2 + 0.001)
  double rmse = 0;        // sqrt(mean over pixels and channels of (A-R)^2)
  double mean_ratio = 0;  // mean(A) / mean(R) (1 if both means are 0, +-inf if only mean(R) is 0)
  size_t pixels = 0;      // width * height (all pixels, including non-finite ones)
  size_t nonfinite = 0;   // pixels with a NaN/Inf channel in A (or in the reference)
  // Per pixel (row-major, row 0 at the top): mean over channels of (A-R)^2 / (R^2 + 0.001);
  // +inf for non-finite pixels (write_false_color_png shows them in magenta).
  std::vector<float> per_pixel_rel_se;
};

// Compares image `a` against reference `ref` (both width x height, same channel count).
// Non-finite pixels are counted in `nonfinite` and left out of every mean (rel_mse, rmse,
// mean_ratio are over the finite pixels; NaN if there are none).
// Throws std::invalid_argument when the channel counts differ or a pass does not hold
// width * height * channels values.
DiffResult diff_images(const Pass& a, const Pass& ref, int width, int height);

}  // namespace gp
