// RGB triples in scene-linear Rec.709. The spectral mode (integrators/spectral) converts its
// wavelength samples to this type at the film, so everything downstream stays RGB.
#pragma once

#include <cmath>

namespace gp {

struct RGB {
  float r = 0, g = 0, b = 0;
  constexpr RGB() = default;
  constexpr RGB(float r_, float g_, float b_) : r(r_), g(g_), b(b_) {}
  constexpr explicit RGB(float s) : r(s), g(s), b(s) {}
  float operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
  float& operator[](int i) { return i == 0 ? r : (i == 1 ? g : b); }
  RGB operator+(const RGB& o) const { return {r + o.r, g + o.g, b + o.b}; }
  RGB operator-(const RGB& o) const { return {r - o.r, g - o.g, b - o.b}; }
  RGB operator*(const RGB& o) const { return {r * o.r, g * o.g, b * o.b}; }
  RGB operator/(const RGB& o) const { return {r / o.r, g / o.g, b / o.b}; }
  RGB operator*(float s) const { return {r * s, g * s, b * s}; }
  RGB operator/(float s) const { float inv = 1.0f / s; return {r * inv, g * inv, b * inv}; }
  RGB& operator+=(const RGB& o) { r += o.r; g += o.g; b += o.b; return *this; }
  RGB& operator*=(const RGB& o) { r *= o.r; g *= o.g; b *= o.b; return *this; }
  RGB& operator*=(float s) { r *= s; g *= s; b *= s; return *this; }
  bool is_black() const { return r == 0 && g == 0 && b == 0; }
  bool is_finite() const { return std::isfinite(r) && std::isfinite(g) && std::isfinite(b); }
  float max_component() const { return std::fmax(r, std::fmax(g, b)); }
  float average() const { return (r + g + b) * (1.0f / 3.0f); }
  // Rec.709 / sRGB luminance weights.
  float luminance() const { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }
};
inline RGB operator*(float s, const RGB& c) { return c * s; }

}  // namespace gp
