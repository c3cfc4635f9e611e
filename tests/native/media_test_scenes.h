// What the tests of photon methods in media share (media_photon_test: ppm/sppm and the adaptive
// and spectral photons; msppm_media_test: msppm): the photon parameters they run with, pt's
// reference mean, and the closed fog room (a diffuse box with the camera inside, a point light,
// a World haze and a denser coloured smoke ball) whose haze and image size each test picks.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdint>
#include <string>
#include <vector>

#include "render_for_tests.h"

namespace gp {

// A photon method's parameters in media: `radius` is the cylinder's first radius too (the
// footprint of a tiny image is large).
inline Params media_photon_params(uint64_t seed, int64_t photons, double radius, int max_depth = 64) {
  Params p;
  p.set("seed", seed);
  p.set("photons", photons);
  p.set("radius", radius);
  p.set("max_depth", max_depth);
  return p;
}

// A path-tracing method's image (pt unless `method` says otherwise).
inline Film render_pt(const Scene& s, int passes, const std::string& method, uint64_t seed, int max_depth = 64) {
  Params p;
  p.set("seed", seed);
  p.set("max_depth", max_depth);
  return render(method, s, passes, p);
}

inline RGB pt_mean(const Scene& s, int passes, uint64_t seed) { return image_mean(render_pt(s, passes, "pt", seed)); }

// The median per channel of pt's means over `seeds` (a firefly of delta tracking in one run moves
// its mean; the median of means does not).
inline RGB pt_median(const Scene& s, int passes, const std::vector<uint64_t>& seeds, const std::string& method = "pt") {
  std::vector<RGB> runs;
  for (uint64_t seed : seeds) runs.push_back(image_mean(render_pt(s, passes, method, seed)));
  RGB m;
  for (int c = 0; c < 3; ++c) {
    std::vector<float> v;
    for (const RGB& r : runs) v.push_back(r[c]);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    m[c] = v[v.size() / 2];
  }
  return m;
}

// A method's image mean `m` within `tol` of pt's per channel; `what`: the scene and the method.
inline void expect_near_pt(const RGB& m, const RGB& pt, double tol, const std::string& what) {
  std::printf("%s / pt %.4f %.4f %.4f\n", what.c_str(), m.r / pt.r, m.g / pt.g, m.b / pt.b);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c] / pt[c], 1.0, tol) << what << " channel " << c << ": " << m[c] << " vs " << pt[c];
}

// A closed room (a two-sided diffuse box, the camera inside, a point light) filled with haze (a
// World medium; `haze` its JSON object) and a denser coloured, anisotropic smoke ball without
// surface. Closed, so that pt's reference is quiet: in an open room pt's paths wander off into
// the World's haze (512 spp of one were 2.5 % off its own mean).
inline std::string fog_room(const std::string& haze, int width, int height) {
  return R"({"camera": {"position": [0, -0.95, 1], "look_at": [0, 0, 0.9], "fov": 60, "width": )" +
         std::to_string(width) + R"(, "height": )" + std::to_string(height) + R"(},
 "media": {"haze": )" + haze + R"(,
           "smoke": {"sigma_a": [0.3, 0.5, 0.8], "sigma_s": [2.0, 1.5, 1.0], "g": 0.5}},
 "world_medium": "haze",
 "materials": {"wall": {"type": "diffuse", "color": [0.6, 0.55, 0.5]}, "smoke": {"type": "volume", "interior": "smoke"}},
 "lights": [{"type": "point", "position": [0.3, -0.2, 1.7], "intensity": 10}],
 "objects": [{"type": "box", "min": [-1, -1, 0], "max": [1, 1, 2], "material": "wall"},
             {"type": "sphere", "center": [-0.35, 0.3, 0.6], "radius": 0.4, "segments": 32, "material": "smoke"}]})";
}

}  // namespace gp
