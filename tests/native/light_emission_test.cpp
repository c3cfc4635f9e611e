// Photon emission of point and spot lights with a radius (LightSet::sample_le): the photons leave
// the disk of radius r through the light's centre perpendicular to their direction, as the rays of
// Cycles' sphere light along one direction do, with the power of the same light of radius 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/rng.h"
#include "scene/loader.h"

namespace gp {
namespace {

Scene light_scene(const std::string& light) {
  return load_scene_from_string(R"({"camera": {"position": [0, -3, 1], "look_at": [0, 0, 0]},
    "materials": {"white": {"type": "diffuse", "color": 0.5}},
    "lights": [)" + light + R"(],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "white"}]})",
                                ".", "light.json");
}

// Seeds 1, 2: for each light kind, n photons of the light of radius r and of radius 0 drawn with
// the same numbers. The offset o - centre of a uniform point of a disk of radius r has
// E|offset|^2 = r^2 / 2 and E offset = 0; with n = 20000 the mean of |offset|^2 / r^2 has a
// standard error of 0.29 / sqrt(n) = 0.002 (0.475 .. 0.525 is 12 sigma), |mean offset| about
// r sqrt(0.5 / n) = 0.005 r (bound 0.025 r, 5 sigma).
TEST(LightEmission, PhotonsOfALightWithARadiusLeaveItsDiskAcrossTheirDirection) {
  const float r = 0.1f;
  for (const char* kind : {R"("type": "point", "position": [0.2, 0, 1], "power": 100)",
                           R"("type": "spot", "position": [0.2, 0, 1], "look_at": [0.5, 0.3, 0], "spot_size": 60, "spot_blend": 0.4, "power": 100)"}) {
    const Scene wide = light_scene(std::string("{") + kind + R"(, "radius": 0.1})");
    const Scene point = light_scene(std::string("{") + kind + "}");
    const Vec3 centre(0.2f, 0, 1);
    for (uint64_t seed : {1, 2}) {
      Rng rng(seed, 7);
      const int n = 20000;
      double sum_r2 = 0, worst_perp = 0, worst_out = 0;
      Vec3 sum_offset(0.0f);
      int emitted = 0;
      for (int i = 0; i < n; ++i) {
        const float us = rng.uniform();
        const Vec2 up(rng.uniform(), rng.uniform()), ud(rng.uniform(), rng.uniform());
        const auto a = wide.light_set().sample_le(us, up, ud);
        const auto b = point.light_set().sample_le(us, up, ud);
        ASSERT_EQ(a.has_value(), b.has_value());
        if (!a) continue;
        ++emitted;
        // The direction and power are the radius-0 light's; only the origin moves.
        for (int k = 0; k < 3; ++k) {
          EXPECT_EQ(a->d[k], b->d[k]);
          EXPECT_EQ(a->power[k], b->power[k]);
          EXPECT_EQ(b->o[k], centre[k]);
        }
        const Vec3 off = a->o - centre;
        worst_perp = std::max(worst_perp, static_cast<double>(std::abs(dot(off, a->d))));
        worst_out = std::max(worst_out, static_cast<double>(length(off)) - r);
        sum_r2 += length_squared(off) / (r * r);
        sum_offset = sum_offset + off;
      }
      ASSERT_GT(emitted, n / 2) << kind;
      EXPECT_LT(worst_perp, 1e-6) << kind;  // in the plane across the direction
      EXPECT_LT(worst_out, 1e-6) << kind;   // within the disk
      const double mean_r2 = sum_r2 / emitted;
      EXPECT_NEAR(mean_r2, 0.5, 0.025) << kind << " seed " << seed;
      EXPECT_LT(length(sum_offset) / emitted, 0.025 * r) << kind << " seed " << seed;
      std::printf("LIGHT EMISSION %s seed %llu: mean |offset|^2 / r^2 = %.4f (0.5), |mean offset| / r = %.4f\n",
                  kind[9] == 'p' ? "point" : "spot", static_cast<unsigned long long>(seed), mean_r2,
                  length(sum_offset) / emitted / r);
    }
  }
}

}  // namespace
}  // namespace gp
