// Helpers of the World's tests (environment_map_test, background_test): maps made from a
// function of direction, written as float images, and the chi-square of a World's direction
// sampler (lights/background.h) against its own density: samples binned in equal-solid-angle
// cells (z, phi), expected counts by quadrature of pdf().
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "chi2.h"
#include "core/rng.h"
#include "lights/background.h"
#include "lights/environment_map.h"
#include "textures/texture.h"

namespace gp {

// A map from a function of the texel centre's direction (equirectangular, +Z up), row 0 at the
// bottom as TextureImage keeps it.
template <typename F>
inline std::shared_ptr<TextureImage> map_image(int w, int h, F&& f) {
  auto img = std::make_shared<TextureImage>();
  img->width = w;
  img->height = h;
  img->rgba.resize(size_t(w) * h * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Vec3 d = EnvironmentMap::equirectangular_direction(Vec2((x + 0.5f) / w, (y + 0.5f) / h));
      const RGB c = f(d, x, y);
      float* p = &img->rgba[4 * (size_t(y) * w + x)];
      p[0] = c.r, p[1] = c.g, p[2] = c.b, p[3] = 1;
    }
  return img;
}

// A portable float map (OpenImageIO reads it): rows bottom first, as TextureImage.
inline std::string write_pfm(const std::string& name, const TextureImage& img) {
  namespace fs = std::filesystem;
  // One folder per process: ctest runs tests in parallel, and a file rewritten under another
  // test (a new modification time) is a new image to the texture store, its bakes not shared.
  const fs::path dir = fs::temp_directory_path() / ("gradphoton_environment_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream f(p, std::ios::binary);
  f << "PF\n" << img.width << " " << img.height << "\n-1.0\n";
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const RGB c = img.texel(x, y).rgb;
      f.write(reinterpret_cast<const char*>(&c.r), 4);
      f.write(reinterpret_cast<const char*>(&c.g), 4);
      f.write(reinterpret_cast<const char*>(&c.b), 4);
    }
  return p.string();
}

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
