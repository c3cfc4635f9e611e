// What the integrator tests share: a scene of scenes/ at a test's size or from a JSON string, a
// method run for a fixed number of passes and developed (the CLI's progressive loop without a
// progress sink), the mean of an image (or of a quadrant), the photon methods' parameters, and
// the textured-quad scene with its image files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "core/film.h"
#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "scene/loader.h"

namespace gp {

// scenes/<name>.json with its camera resized to width x height.
inline Scene test_scene(const std::string& name, int width, int height) {
  Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/" + name + ".json");
  s.camera.width = width;
  s.camera.height = height;
  return s;
}

inline Scene cornell_box(int width, int height) { return test_scene("cornell-box", width, height); }

// A scene written in the test, as a scene file's JSON.
inline Scene scene_from(const std::string& json) { return load_scene_from_string(json, ".", "test.json"); }

// The mean of the combined pass; `finite` (if given) says whether every pixel was finite.
inline RGB image_mean(const Film& f, bool* finite = nullptr) {
  double s[3] = {0, 0, 0};
  bool ok = true;
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) {
      const RGB c = f.rgb(pass::kCombined, x, y);
      ok &= c.is_finite();
      for (int k = 0; k < 3; ++k) s[k] += c[k];
    }
  if (finite) *finite = ok;
  const double n = double(f.width()) * f.height();
  return RGB(float(s[0] / n), float(s[1] / n), float(s[2] / n));
}

inline Film render(const std::string& method, const Scene& scene, int passes, const Params& params,
                   Stats* stats = nullptr) {
  auto integ = make_integrator(method, scene, params);
  run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  Film film;
  integ->develop(film);
  if (stats) *stats = integ->stats();
  return film;
}

// render() with seed 1 unless `params` sets one, arguments in the spectral tests' order.
inline Film render_with_seed(const Scene& scene, const std::string& method, int passes, Params params = Params()) {
  if (!params.has("seed")) params.set("seed", 1);
  return render(method, scene, passes, params);
}

inline Params photon_params(int64_t photons, uint64_t seed = 1, int threads = 0) {
  Params p;
  p.set("photons", photons);
  p.set("seed", seed);
  p.set("threads", threads);
  return p;
}

// An 8-bit binary PPM (OpenImageIO reads it; 8-bit files default to sRGB), rows top first.
inline std::string write_ppm(const std::string& name, int w, int h, const std::vector<uint8_t>& rgb_top_first) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("gradphoton_texture_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream f(p, std::ios::binary);
  f << "P6\n" << w << " " << h << "\n255\n";
  f.write(reinterpret_cast<const char*>(rgb_top_first.data()), static_cast<std::streamsize>(rgb_top_first.size()));
  return p.string();
}

// A unit quad (uv 0..1) facing +z seen from above, with material `mat`, under a constant white
// environment: a diffuse surface there has radiance = its albedo.
inline std::string furnace_scene(const std::string& material_json, const std::string& extra_objects = "") {
  return R"({"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 16, "height": 16},
    "materials": {"m": )" + material_json + R"(},
    "objects": [{"type": "mesh", "positions": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                 "indices": [[0, 1, 2], [0, 2, 3]], "uvs": [[0, 0], [1, 0], [1, 1], [0, 1]], "material": "m"})" +
         extra_objects + R"(],
    "environment": {"color": [1, 1, 1], "strength": 1}})";
}

inline RGB quadrant_mean(const Film& f, int qx, int qy) {
  // Quadrant (qx, qy) of the image, qy = 0 at the top; a margin keeps clear of the texel edges.
  double s[3] = {0, 0, 0};
  int n = 0;
  const int h = f.height() / 2, w = f.width() / 2;
  for (int y = qy * h + 2; y < (qy + 1) * h - 2; ++y)
    for (int x = qx * w + 2; x < (qx + 1) * w - 2; ++x, ++n) {
      const RGB c = f.rgb(pass::kCombined, x, y);
      for (int k = 0; k < 3; ++k) s[k] += c[k];
    }
  return RGB(float(s[0] / n), float(s[1] / n), float(s[2] / n));
}

}  // namespace gp
