// The film's pixel filter, as Cycles 3.4 applies it (scene/film.cpp filter_table, kernel/camera/
// camera.h camera_sample): each camera ray's film offset is importance-sampled from the filter,
// separably in x and y, and the sample counts with weight 1 in its own pixel. The image is then
// the filtered one without any splatting, and every method that starts its paths at
// start_pixel (core/rng.h) gets it.
//
// Cycles' filters, f(x) at distance x (pixels) from the pixel's centre, for Blender's width w:
//   box:             1 on |x| <= w / 2;
//   gaussian:        exp(-8 x^2 / w^2) on |x| <= 1.5 w (Cycles: width 3 w, v = 6 x / (3 w),
//                    exp(-2 v^2): a sigma of w / 4 cut at 6 sigma);
//   blackman-harris: 0.35875 - 0.48829 cos(v) + 0.14128 cos(2 v) - 0.01168 cos(3 v),
//                    v = 2 pi (x / (2 w) + 1/2), on |x| <= w (Cycles doubles the width: the
//                    window spans 2 w pixels, so Blender's 1.5 px reaches 1.5 px each side).
// Cycles inverts a 1024-entry table of the filter's CDF and reads it with linear interpolation;
// here the CDF of |x| is tabulated on kTableCells cells (the filter integrated exactly within
// each by Simpson's rule) and inverted exactly, so the offsets follow the filter up to the
// table's piecewise-constant density.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace gp {

enum class PixelFilterType { Box, Gaussian, BlackmanHarris };

class PixelFilter {
 public:
  static constexpr int kTableCells = 1024;
  // Box of one pixel: the sub-pixel position uniform in the pixel (images as before filters).
  PixelFilter() = default;
  // Throws std::invalid_argument for a width that is not a finite number in (0, 64].
  PixelFilter(PixelFilterType type, float width);
  // "box", "gaussian", "blackman-harris" (also Blender's "BLACKMAN_HARRIS" spellings, any case).
  // Throws std::invalid_argument naming the known types.
  static PixelFilterType parse_type(const std::string& name);
  // Parses the CLI's "TYPE[:WIDTH]" (width defaults to Cycles' 1.5 for blackman-harris and
  // gaussian, 1 for box).
  static PixelFilter parse(const std::string& spec);

  PixelFilterType type() const { return type_; }
  float width() const { return width_; }
  const char* type_name() const;
  // Largest |offset| from the pixel's centre a sample can take, in pixels.
  float radius() const;
  // The filter's (unnormalised) value at distance x from the pixel's centre; 0 outside radius().
  double eval(double x) const;
  // Film position within pixel `pixel` (an integer coordinate) for a uniform u in [0, 1): the
  // pixel's corner plus 0.5 plus a filter-distributed offset. For a box of width 1 it is exactly
  // pixel + u, the position every method drew before pixel filters.
  float sample(float pixel, float u) const;
  bool is_default_box() const { return type_ == PixelFilterType::Box && width_ == 1.0f; }

 private:
  PixelFilterType type_ = PixelFilterType::Box;
  float width_ = 1.0f;
  // CDF of |x| on [0, radius()] at kTableCells + 1 evenly spaced points (0 ... 1); empty for box.
  std::shared_ptr<const std::vector<double>> cdf_;
};

}  // namespace gp
