// What the integrator tests share: a scene of scenes/ at a test's size or from a JSON string, a
// method run for a fixed number of passes and developed (the CLI's progressive loop without a
// progress sink), the mean of an image, and the photon methods' parameters.
#pragma once

#include <cstdint>
#include <string>

#include "core/film.h"
#include "integrators/integrator.h"
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

}  // namespace gp
