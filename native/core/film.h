// Film: named image passes, each with 1 (scalar) or 3 (RGB) float channels, row-major,
// row 0 at the top of the image. Integrators keep their own accumulators and write
// finished estimates here in develop(); the EXR writer, the Python module and Blender read it.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/color.h"

namespace gp {

// Pass names shared by C++, Python and the addon: define them once, here. The Python module
// exposes kAll so the addon registers exactly these with Blender (tested there).
namespace pass {
inline constexpr std::string_view kCombined = "combined";
inline constexpr std::string_view kError = "error";               // estimated relative error (thesis eq. 6.13)
inline constexpr std::string_view kRadius = "radius";             // photon gathering radius (m)
inline constexpr std::string_view kPhotonCount = "photon_count";  // accumulated photon count N
// Gradient-domain methods: the primal (throughput) image and the forward-difference gradients
// G_x(x, y) = I(x+1, y) - I(x, y), G_y(x, y) = I(x, y+1) - I(x, y) (row 0 at the top) that the
// screened Poisson reconstruction turns into `combined` (reconstruction/poisson.h).
inline constexpr std::string_view kPrimal = "primal";
inline constexpr std::string_view kGradientX = "gradient_x";
inline constexpr std::string_view kGradientY = "gradient_y";
// Spectral gradient sampling (integrators/spectral/sgpt): the base paths' spectrum before the
// 1D Poisson reconstruction, and the RMS of the per-pixel spectral gradients.
inline constexpr std::string_view kSpectralPrimal = "spectral_primal";
inline constexpr std::string_view kSpectralGradient = "spectral_gradient";
// Metropolis methods: how many chain states (one per mutation) fell in each pixel.
inline constexpr std::string_view kSampleDensity = "sample_density";
// Multisampled PPM (integrators/msppm): the path-tracing share of `combined` after the
// balance-heuristic weights (thesis Fig. 9.10); combined minus it is the density estimation.
inline constexpr std::string_view kPathTracing = "path_tracing";
// Coverage of the camera samples with a transparent film (parameter film_transparent): 0 where
// every camera ray escaped to the world, 1 where every one hit the scene; `combined` then holds
// no background (premultiplied). Blender takes it as the Alpha of Combined, not a pass of its own.
inline constexpr std::string_view kAlpha = "alpha";
// Written for every method by integrators/aov.h (Cycles' names for Blender).
inline constexpr std::string_view kAlbedo = "albedo";
inline constexpr std::string_view kNormal = "normal";
inline constexpr std::string_view kDepth = "depth";

struct Info {
  std::string_view name;
  int channels;             // 1 or 3
  std::string_view label;   // human-readable, for Blender's pass list
};
// Every pass any method may produce. A method's develop() writes a subset.
inline constexpr Info kAll[] = {
    {kCombined, 3, "Combined"},
    {kError, 1, "Estimated Error"},
    {kRadius, 1, "Photon Radius"},
    {kPhotonCount, 1, "Photon Count"},
    {kPrimal, 3, "Primal"},
    {kGradientX, 3, "Gradient X"},
    {kGradientY, 3, "Gradient Y"},
    {kSpectralPrimal, 3, "Spectral Primal"},
    {kSpectralGradient, 1, "Spectral Gradient"},
    {kSampleDensity, 1, "Sample Density"},
    {kPathTracing, 3, "Path Tracing Share"},
    {kAlpha, 1, "Alpha"},
    {kAlbedo, 3, "Denoising Albedo"},
    {kNormal, 3, "Normal"},
    {kDepth, 1, "Depth"},
};
}  // namespace pass

struct Pass {
  int channels = 3;          // 1 or 3
  std::vector<float> data;   // width * height * channels
};

class Film {
 public:
  Film() = default;
  Film(int width, int height) : width_(width), height_(height) {}

  int width() const { return width_; }
  int height() const { return height_; }
  size_t pixel_count() const { return static_cast<size_t>(width_) * height_; }

  // Creates the pass (zero-filled) if missing; returns it.
  Pass& add_pass(std::string_view name, int channels);
  bool has_pass(std::string_view name) const { return passes_.count(std::string(name)) > 0; }
  const Pass& pass(std::string_view name) const;  // throws std::out_of_range naming the pass
  Pass& pass(std::string_view name);
  const std::map<std::string, Pass, std::less<>>& passes() const { return passes_; }

  RGB rgb(std::string_view name, int x, int y) const;
  void set_rgb(std::string_view name, int x, int y, const RGB& c);

 private:
  int width_ = 0, height_ = 0;
  std::map<std::string, Pass, std::less<>> passes_;
};

}  // namespace gp
