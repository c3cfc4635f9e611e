#include "core/pixel_filter.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>

namespace gp {

namespace {

constexpr double kTwoPi = 6.283185307179586;

// Cycles 3.4 scene/film.cpp: filter_func_gaussian and filter_func_blackman_harris, written for
// the distance x from the pixel's centre and Blender's width w (Cycles scales its width by 3
// and 2 before calling them).
double gaussian(double x, double w) {
  const double v = x * 6.0 / (3.0 * w);
  return std::exp(-2.0 * v * v);
}
double blackman_harris(double x, double w) {
  const double v = kTwoPi * (x / (2.0 * w) + 0.5);
  return 0.35875 - 0.48829 * std::cos(v) + 0.14128 * std::cos(2 * v) - 0.01168 * std::cos(3 * v);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (char& c : s)
    if (c == '_') c = '-';
  return s;
}

}  // namespace

PixelFilterType PixelFilter::parse_type(const std::string& name) {
  const std::string n = lower(name);
  if (n == "box") return PixelFilterType::Box;
  if (n == "gaussian") return PixelFilterType::Gaussian;
  if (n == "blackman-harris") return PixelFilterType::BlackmanHarris;
  throw std::invalid_argument(
      fmt::format("unknown pixel filter '{}' (known: box, gaussian, blackman-harris)", name));
}

PixelFilter PixelFilter::parse(const std::string& spec) {
  const size_t colon = spec.find(':');
  const PixelFilterType type = parse_type(spec.substr(0, colon));
  float width = type == PixelFilterType::Box ? 1.0f : 1.5f;
  if (colon != std::string::npos) {
    const std::string w = spec.substr(colon + 1);
    size_t used = 0;
    try {
      width = std::stof(w, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != w.size())
      throw std::invalid_argument(fmt::format("pixel filter width '{}' is not a number", w));
  }
  return PixelFilter(type, width);
}

PixelFilter::PixelFilter(PixelFilterType type, float width) : type_(type), width_(width) {
  if (!(std::isfinite(width) && width > 0.0f && width <= 64.0f))
    throw std::invalid_argument(fmt::format("pixel filter width must be in (0, 64] pixels (got {})", width));
  if (type == PixelFilterType::Box) return;
  // CDF of |x| over [0, radius]: each cell's integral by Simpson's rule on 4 sub-intervals
  // (the filters are smooth; the error is far below what a chi-square test at 10^7 samples sees).
  auto cdf = std::make_shared<std::vector<double>>(kTableCells + 1, 0.0);
  const double r = radius(), h = r / kTableCells;
  for (int k = 0; k < kTableCells; ++k) {
    const double a = k * h;
    double s = 0;
    for (int j = 0; j < 4; ++j) {
      const double x0 = a + j * h / 4, x1 = x0 + h / 8, x2 = x0 + h / 4;
      s += (h / 24) * (eval(x0) + 4 * eval(x1) + eval(x2));
    }
    (*cdf)[k + 1] = (*cdf)[k] + std::max(0.0, s);
  }
  const double total = cdf->back();
  for (double& c : *cdf) c /= total;
  cdf->back() = 1.0;
  cdf_ = std::move(cdf);
}

const char* PixelFilter::type_name() const {
  switch (type_) {
    case PixelFilterType::Box: return "box";
    case PixelFilterType::Gaussian: return "gaussian";
    case PixelFilterType::BlackmanHarris: return "blackman-harris";
  }
  return "?";
}

float PixelFilter::radius() const {
  switch (type_) {
    case PixelFilterType::Box: return 0.5f * width_;
    case PixelFilterType::Gaussian: return 1.5f * width_;  // Cycles' table spans 3 w
    case PixelFilterType::BlackmanHarris: return width_;   // Cycles' table spans 2 w
  }
  return 0.5f * width_;
}

double PixelFilter::eval(double x) const {
  x = std::abs(x);
  if (x > radius()) return 0.0;
  switch (type_) {
    case PixelFilterType::Box: return 1.0;
    case PixelFilterType::Gaussian: return gaussian(x, width_);
    case PixelFilterType::BlackmanHarris: return std::max(0.0, blackman_harris(x, width_));
  }
  return 0.0;
}

float PixelFilter::sample(float pixel, float u) const {
  if (type_ == PixelFilterType::Box) {
    if (width_ == 1.0f) return pixel + u;  // bit for bit the position drawn before filters
    return pixel + 0.5f + (u - 0.5f) * width_;
  }
  // The sign from which half of [0, 1) u lies in, |x| from the CDF at |2u - 1| (as Cycles'
  // symmetric table: u = 1/2 is the pixel's centre).
  const double v = std::abs(2.0 * static_cast<double>(u) - 1.0);
  const std::vector<double>& cdf = *cdf_;
  const auto it = std::upper_bound(cdf.begin(), cdf.end(), v);
  const int k = std::clamp(static_cast<int>(it - cdf.begin()) - 1, 0, kTableCells - 1);
  const double span = cdf[k + 1] - cdf[k];
  const double t = span > 0 ? std::clamp((v - cdf[k]) / span, 0.0, 1.0) : 0.0;
  const double x = (k + t) * (static_cast<double>(radius()) / kTableCells);
  return static_cast<float>(pixel + 0.5 + (u < 0.5f ? -x : x));
}

}  // namespace gp
