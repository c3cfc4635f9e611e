// Multisampled PPM in participating media (issue 32; msppm.h "Participating media"): camera paths
// through media with their transmittance, next-event estimation through the shared shadow test,
// volume photons from the one photon walk gathered by the beam radiance estimate (beam_estimate.h)
// at the camera path's segments before its first mergeable vertex, surface photons that scattered
// in a medium gathered only at that vertex. Means against pt, per channel, at fixed seeds with
// the headroom stated; each test was seen failing with the transmittance dropped (the report of
// the msppm branch and docs/photon-mapping.md list what failed).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "media_test_scenes.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// A closed room (a two-sided diffuse box, the camera inside, a point light) filled with haze (a
// World medium, anisotropic) and a denser coloured smoke ball: the surfaces see the haze's
// transmittance (camera segments, shadow rays, photons), the haze and the smoke in-scatter
// (beams), and the walls are lit by light the haze scattered (surface photons with a medium
// vertex). Closed, so that pt's reference is quiet.
const std::string kHazeRoom = fog_room(R"({"sigma_a": 0.1, "sigma_s": 0.4, "g": 0.3})", 20, 15);

TEST(MsppmMedia, AgreesWithPathTracingInFog) {
  const Scene s = scene_from(kHazeRoom);
  const RGB pt = pt_mean(s, 1024, 5);
  Stats stats;
  bool finite = false;
  const RGB m = image_mean(render("msppm", s, 32, media_photon_params(6, 50000, 0.02), &stats), &finite);
  EXPECT_TRUE(finite);
  EXPECT_GT(stats.extra["volume photons stored"], 0.0);
  // Measured 0.993, 0.994, 0.994 of pt; pt at 1024 spp and msppm at 32 passes each move under
  // 1 % between seeds: 2 % headroom.
  expect_near_pt(m, pt, 0.02, "haze room: msppm");
}

// A cube of coloured murk (a Volume material's interior) over a diffuse floor under an area light,
// in a dim World: the floor sees the cube's shadow (shadow rays through it), the camera the cube's
// in-scattering and the floor through it, light the murk scattered onto the floor.
const char* kMurkCube = R"({"camera": {"position": [0, -4, 1.6], "look_at": [0, 0, 0.5], "fov": 40, "width": 20, "height": 15},
    "media": {"murk": {"sigma_a": [0.1, 0.3, 0.6], "sigma_s": [1.5, 1.2, 0.9], "g": 0.2}},
    "materials": {"floor": {"type": "diffuse", "color": 0.6}, "murk": {"type": "volume", "interior": "murk"},
                  "lamp": {"type": "emission", "emission": 1, "strength": 10, "two_sided": true}},
    "environment": {"color": [0.03, 0.03, 0.04]},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                {"type": "box", "min": [-0.5, -0.5, 0.2], "max": [0.5, 0.5, 1.2], "material": "murk"},
                {"type": "quad", "center": [0.4, -0.3, 2.2], "u": [0.6, 0, 0], "v": [0, 0.6, 0], "material": "lamp"}]})";

TEST(MsppmMedia, AgreesWithPathTracingOnAMediumCube) {
  const Scene s = scene_from(kMurkCube);
  const RGB pt = pt_mean(s, 4096, 11);
  bool finite = false;
  const RGB m = image_mean(render("msppm", s, 64, media_photon_params(10, 50000, 0.02)), &finite);
  EXPECT_TRUE(finite);
  // Measured 0.993, 0.996, 0.999 of pt (seed 9: 0.988, 0.987, 0.990; pt at 4096 spp moves 0.3 %
  // between seeds, sppm at 32 passes is 0.994 of it): 2 % headroom. Seen failing: with the
  // volume boundaries kept as delta vertices of the paths while shadow rays pass them (next-event
  // estimation counted on top of the photons) 1.064, 1.067, 1.068.
  expect_near_pt(m, pt, 0.02, "murk cube: msppm");
}

}  // namespace
}  // namespace gp
