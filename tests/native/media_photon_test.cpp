// Photon methods in participating media (issue 32, thesis §5.6): volume photons from the one
// photon walk (photon/photon_walk.h) and SPPM's beam radiance estimate with a progressive
// cylinder (progressive_photon.cpp volume_gather). Statistical tests at fixed seeds, each with its
// headroom stated; each was seen failing with the estimator broken (docs/photon-mapping.md lists
// what was broken and what failed).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <filesystem>
#include <vector>
#include <string>
#include <unistd.h>

#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "integrators/paths/medium_stack.h"
#include "integrators/photon/sppm.h"
#include "media/grid.h"
#include "media/vdb_file.h"
#include "media_test_scenes.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// A sphere of a scattering-only medium (albedo 1, coloured, anisotropic) in a uniform World: every
// ray sees the World's radiance (the volumetric white furnace). Only volume photons light the
// sphere's inside; what the camera sees of it is the beam estimate plus the World behind it seen
// through the sphere's transmittance.
TEST(MediaPhotons, AlbedoOneMediumInUniformEnvironmentIsInvisible) {
  const Scene s = scene_from(R"({"camera": {"position": [0, -4, 0], "look_at": [0, 0, 0], "fov": 30, "width": 16, "height": 16},
    "media": {"cloud": {"sigma_s": [0.5, 2.0, 4.0], "g": 0.6}},
    "materials": {"boundary": {"type": "volume", "interior": "cloud"}},
    "environment": {"color": [0.5, 1.0, 2.0], "strength": 1},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "segments": 48, "material": "boundary"}]})");
  for (const char* method : {"sppm", "ppm", "msppm"}) {
    bool finite = false;
    const RGB m = image_mean(render(method, s, 32, media_photon_params(3, 50000, 0.01)), &finite);
    EXPECT_TRUE(finite);
    std::printf("furnace: %s %.4f %.4f %.4f of the World\n", method, m.r / 0.5, m.g / 1.0, m.b / 2.0);
    // Measured 1.008, 1.014, 1.014 of the World (sppm); the noise of 32 passes and the
    // cylinder's remaining bias are about 1 %: 3 % headroom. Seen failing: without the
    // transmittance to the photon 1.15, 2.3, 4.1; 1 / (pi R) for 1 / (pi R^2) 0.66, 0.36; the
    // phase pdf dropped from the photons' phase sampling 0.92, 0.60.
    // PPM keeps its first pass's camera segments: 0.989, 0.970, 1.004, so 4 % for it.
    const double tol = std::string(method) == "ppm" ? 0.04 : 0.03;
    EXPECT_NEAR(m.r / 0.5, 1.0, tol) << method;
    EXPECT_NEAR(m.g / 1.0, 1.0, tol) << method;
    EXPECT_NEAR(m.b / 2.0, 1.0, tol) << method;
  }
}

// The fog room (media_test_scenes.h): a haze that scatters and absorbs, anisotropic.
const std::string kFogRoom = fog_room(R"({"sigma_a": 0.05, "sigma_s": 0.35, "g": 0.3})", 24, 18);

TEST(MediaPhotons, SppmAndPathTracingAgreeInFog) {
  const Scene s = scene_from(kFogRoom);
  const RGB pt = image_mean(render_pt(s, 1024, "pt", 5));
  const RGB sppm = image_mean(render("sppm", s, 48, media_photon_params(6, 100000, 0.02)));
  // pt's mean at 1024 spp moved 0.1 % between seeds, sppm's at 48 passes 0.4 % (seeds 7, 8:
  // 1.0016, 0.9982 of pt): the issue's 1 %.
  expect_near_pt(sppm, pt, 0.01, "fog room: sppm");
}

// Murky water in a glass sphere under an area light over a diffuse floor: photons refract into the
// water, scatter there and leave through the glass (the volume stack through glass); camera
// segments through the water gather them. (An area light, not a point light: pt finds light
// through smooth glass only by BSDF sampling, so it cannot be the reference under a delta light.)
const char* kMurkyGlass = R"({"camera": {"position": [0, -3, 1.2], "look_at": [0, 0, 0.5], "fov": 35, "width": 24, "height": 18},
    "media": {"water": {"sigma_a": [0.4, 0.15, 0.1], "sigma_s": 1.2, "g": 0.4}},
    "materials": {"floor": {"type": "diffuse", "color": 0.6},
                  "lamp": {"type": "emission", "emission": 1, "strength": 8, "two_sided": true},
                  "glass": {"type": "dielectric", "ior": 1.33, "roughness": 0, "color": [1, 1, 1], "interior": "water"}},
    "environment": {"color": [0.05, 0.05, 0.08]},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "floor"},
                {"type": "quad", "center": [0.2, -0.3, 2.4], "u": [0.5, 0, 0], "v": [0, 0.5, 0], "material": "lamp"},
                {"type": "sphere", "center": [0, 0, 0.6], "radius": 0.55, "segments": 48, "material": "glass"}]})";

TEST(MediaPhotons, AMediumInsideGlassMatchesPathTracing) {
  const Scene s = scene_from(kMurkyGlass);
  const RGB pt = image_mean(render_pt(s, 1024, "pt", 7));
  const RGB sppm = image_mean(render("sppm", s, 48, media_photon_params(8, 100000, 0.02)));
  // pt finds the light through the glass by BSDF sampling only, so its own noise is larger than
  // in the fog room: 1.5 %.
  expect_near_pt(sppm, pt, 0.015, "murky glass: sppm");
}

TEST(MediaPhotons, SpectralSppmAndSpectralPathTracingAgreeInFog) {
  // The photons and eye paths at sampled wavelengths (SpectralPhotonPower, SpectralEye) against spt-hero.
  const Scene s = scene_from(kFogRoom);
  // The reference: the median luminance of four spt-hero runs of 256 passes (seeds 9-12). The
  // chromatic smoke gives spt-hero rare bright samples (one blue firefly moved a single 1024-pass
  // run by 2 %); a median of runs is robust to one such run and costs the same.
  std::vector<RGB> runs;
  for (uint64_t seed = 9; seed < 13; ++seed) {
    Params pt;
    pt.set("seed", seed);
    pt.set("max_depth", 64);
    runs.push_back(image_mean(render("spt-hero", s, 256, pt)));
  }
  std::sort(runs.begin(), runs.end(), [](const RGB& a, const RGB& b) { return a.luminance() < b.luminance(); });
  const RGB spt = (runs[1] + runs[2]) * 0.5f;
  Params p = media_photon_params(10, 100000, 0.02);
  p.set("spectral", std::string("spectral"));
  Stats stats;
  const RGB sppm = image_mean(render("sppm", s, 96, p, &stats));
  ASSERT_EQ(stats.extra.count("spectral wavelengths"), 1u);  // spectral photons were used
  std::printf("fog room: spectral sppm / spt-hero %.4f (luminance)\n", sppm.luminance() / spt.luminance());
  // Colour noise of 4 wavelengths per path on top of the RGB test's: 2 % headroom on luminance.
  // SPPM's radius bias still shows at 48 passes (0.979 of the median reference; 96: 0.986).
  EXPECT_NEAR(sppm.luminance() / spt.luminance(), 1.0, 0.02) << sppm.luminance() << " vs " << spt.luminance();
}

// ---- Lights inside a mesh's medium ----
// The media around a point (paths/medium_stack.h): a glass sphere of water inside a fog box,
// both closed; a point light in the water is inside both, and so are its photons' first segments.
TEST(MediaPhotons, TheMediaAroundAPointAreFoundByRays) {
  const Scene s = scene_from(R"({"camera": {"position": [0, -5, 1], "look_at": [0, 0, 1], "width": 8, "height": 8},
    "media": {"fog": {"sigma_s": 0.5}, "water": {"sigma_a": 0.3}, "haze": {"sigma_s": 0.01}},
    "world_medium": "haze",
    "materials": {"fog": {"type": "volume", "interior": "fog"},
                  "glass": {"type": "dielectric", "ior": 1.33, "interior": "water"}},
    "lights": [{"type": "point", "position": [0, 0, 1], "intensity": 5},
               {"type": "point", "position": [0.9, 0, 1], "intensity": 5},
               {"type": "point", "position": [3, 0, 1], "intensity": 5}],
    "objects": [{"type": "box", "min": [-1, -1, 0], "max": [1, 1, 2], "material": "fog"},
                {"type": "sphere", "center": [0, 0, 1], "radius": 0.5, "segments": 32, "material": "glass"}]})");
  const auto media_of = [](const MediumStack& st) {
    std::vector<int> m;
    for (int i = 0; i < st.size(); ++i) m.push_back(st[i].medium);
    std::sort(m.begin(), m.end());
    return m;
  };
  const int fog = 0, water = 1, haze = 2;
  EXPECT_EQ(media_of(medium_stack_at(s, Vec3(0, 0, 1))), (std::vector<int>{fog, water, haze}));
  EXPECT_EQ(media_of(medium_stack_at(s, Vec3(0.9f, 0, 1))), (std::vector<int>{fog, haze}));
  EXPECT_EQ(media_of(medium_stack_at(s, Vec3(3, 0, 1))), (std::vector<int>{haze}));
  // Once per light (LightSet order: the scene's lights as given).
  const LightMedia lights(s);
  EXPECT_EQ(media_of(lights.of(0)), (std::vector<int>{fog, water, haze}));
  EXPECT_EQ(media_of(lights.of(1)), (std::vector<int>{fog, haze}));
  EXPECT_EQ(media_of(lights.of(2)), (std::vector<int>{haze}));
}

// A point light inside a box of murky ink (sigma_a 0.3, sigma_s 0.7) 2 m above a diffuse floor
// (albedo 0.6), the box's bottom 1.5 m below the light; the camera under the box looks down at
// the floor. Direct light under the light: L = (a / pi) (I / h^2) exp(-sigma_t 1.5), pt's shadow
// rays entering the box through its bottom. The light the ink scatters onto the floor is what
// sppm's photons carry (its direct light is next-event estimation's): they must start in the box.
const char* kLampInInk = R"({"camera": {"position": [0, 0, 0.45], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": %s, "width": 16, "height": 16},
    "media": {"ink": {"sigma_a": 0.3, "sigma_s": 0.7}},
    "materials": {"floor": {"type": "diffuse", "color": 0.6}, "ink": {"type": "volume", "interior": "ink"}},
    "lights": [{"type": "point", "position": [0, 0, 2], "intensity": 8}],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [8, 0, 0], "v": [0, 8, 0], "material": "floor"},
                {"type": "box", "min": [-1.5, -1.5, 0.5], "max": [1.5, 1.5, 3], "material": "ink"}]})";

std::string lamp_in_ink(const char* fov) {
  std::string s = kLampInInk;
  s.replace(s.find("%s"), 2, fov);
  return s;
}

TEST(MediaPhotons, ALightInsideAMediumStartsItsPhotonsThere) {
  // pt's direct light under the light (a 2 degree field, max_depth 2): the analytic value.
  const RGB centre = image_mean(render_pt(scene_from(lamp_in_ink("2")), 4, "pt", 1, 2));
  const double exact = 0.6 / M_PI * 8.0 / 4.0 * std::exp(-1.0 * 1.5);
  EXPECT_NEAR(centre.g / exact, 1.0, 0.005) << centre.g << " vs " << exact;
  // sppm against pt over a wide field (the floor within 0.45 m of the centre), all bounces.
  const Scene s = scene_from(lamp_in_ink("90"));
  // 2048 passes: at 512 one rare long path in the ink (a pixel at 7x the median) moved pt's mean
  // by 4 % (seed 2, the Sobol pattern: sppm / pt 0.960), more than the tolerance below.
  const RGB pt = image_mean(render_pt(s, 2048, "pt", 2));
  const RGB sppm = image_mean(render("sppm", s, 32, media_photon_params(3, 100000, 0.05)));
  std::printf("lamp in ink: pt direct / exact %.4f; sppm / pt %.4f\n", centre.g / exact, sppm.g / pt.g);
  // Measured 0.992 (1.003 against pt at another seed); photons started in the World's medium
  // (the bug): 0.452, the light the ink scatters onto the floor missing.
  EXPECT_NEAR(sppm.g / pt.g, 1.0, 0.015);
}

// An emissive quad inside a fog-filled Volume box over a floor: photons start in the fog, scatter
// there and light the floor through it; sppm against pt (a long reference).
TEST(MediaPhotons, AnEmitterInsideAVolumeBoxMatchesPathTracing) {
  const Scene s = scene_from(R"({"camera": {"position": [0, -4, 1.3], "look_at": [0, 0, 0.8], "fov": 40, "width": 24, "height": 18},
    "media": {"murk": {"sigma_a": [0.2, 0.1, 0.05], "sigma_s": 1.2, "g": 0.3}},
    "materials": {"floor": {"type": "diffuse", "color": 0.6}, "murk": {"type": "volume", "interior": "murk"},
                  "lamp": {"type": "emission", "emission": 1, "strength": 8, "two_sided": true}},
    "environment": {"color": [0.02, 0.02, 0.03]},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                {"type": "box", "min": [-0.6, -0.6, 0.3], "max": [0.6, 0.6, 1.5], "material": "murk"},
                {"type": "quad", "center": [0.1, 0.0, 0.9], "u": [0.4, 0, 0], "v": [0, 0.4, 0], "material": "lamp"}]})");
  const RGB pt = image_mean(render_pt(s, 2048, "pt", 3));
  const RGB sppm = image_mean(render("sppm", s, 48, media_photon_params(2, 100000, 0.02)));
  // Measured against pt at 4096 passes: 1.003 (seeds 2 and 7); pt at 1024 passes moves 0.9 %
  // between seeds: 1.5 %.
  expect_near_pt(sppm, pt, 0.015, "emitter in a volume box: sppm");
}

// ---- Adaptive Markov chain photons (thesis ch. 8) in media ----
// A lit cloud that only media show: a point light above a sphere of anisotropic fog, a black
// World and a floor out of the camera's view. No measurement point sees any photon, so every
// pixel is the beam radiance estimate; a visibility V(u) of the measurement points alone finds
// no visible path at all (a black image), one blind to the floor's photons' scattering on into
// the cloud leaves that light out.
const char* kLitCloud = R"({"camera": {"position": [0, -4, 1.2], "look_at": [0, 0, 1.2], "fov": 40, "width": 20, "height": 16},
  "media": {"fog": {"sigma_a": [0.1, 0.15, 0.2], "sigma_s": [0.8, 0.6, 0.4], "g": 0.3}},
  "materials": {"floor": {"type": "diffuse", "color": 0.7}, "fog": {"type": "volume", "interior": "fog"}},
  "lights": [{"type": "point", "position": [0.3, 0, 2.6], "intensity": 20}],
  "objects": [{"type": "quad", "center": [0, 2, -3], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
              {"type": "sphere", "center": [0, 0, 1.2], "radius": 1, "segments": 32, "material": "fog"}]})";

TEST(MediaPhotons, AdaptivePhotonsSeeTheVolumePhotons) {
  const Scene s = scene_from(kLitCloud);
  const RGB pt = image_mean(render_pt(s, 512, "pt", 15));
  Stats stats;
  bool finite = false;
  Params p = media_photon_params(16, 20000, 0.03);
  p.set("chains", 16);
  const RGB ad = image_mean(render("sppm-adaptive", s, 48, p, &stats), &finite);
  EXPECT_TRUE(finite);
  ASSERT_GT(stats.extra.at("volume photons stored"), 0.0);
  std::printf("lit cloud: sppm-adaptive / pt %.4f %.4f %.4f (V_c %.3f)\n", ad.r / pt.r, ad.g / pt.g, ad.b / pt.b,
              stats.extra.at("V_c"));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ad[c] / pt[c], 1.0, 0.03) << "channel " << c << ": " << ad[c] << " vs " << pt[c];
}

// ---- Grid (OpenVDB) media ----
// A smoke blob of varying density (zero at its box's faces) in a 16^3 grid filling the box
// [-h, h]^3 about `centre`, written to a temporary .vdb.
std::string blob_vdb(const std::string& name, float h, const Vec3& centre) {
  const auto dir = std::filesystem::temp_directory_path() / ("gradphoton_media_photon_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  VoxelGrid d;
  d.name = "density";
  const int n = 16;
  d.size = {n, n, n};
  const float v = 2 * h / n;
  for (int i = 0; i < 3; ++i) {
    d.index_to_object.m[i][i] = v;
    d.index_to_object.m[i][3] = centre[i] - h;
  }
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const float x = (i - 7.5f) / 8, y = (j - 7.5f) / 8, z = (k - 7.5f) / 8;
        d.data.push_back(std::max(0.0f, 4.0f * (1 - (x * x + y * y + z * z)) * (0.6f + 0.4f * std::sin(9.0f * x))));
      }
  write_vdb(path, {&d});
  return path;
}

// The fog room's smoke ball as a grid: a blob of coloured smoke (the grid's density times sigma)
// and, overlapping part of it, a ball of homogeneous mist: camera segments through the grid alone,
// through the mist alone, and through both (a mixture: the phase at a photon is the media's
// shares of the scattering at its point).
std::string grid_fog_room() {
  const std::string file = blob_vdb("blob.vdb", 0.45f, Vec3(-0.35f, 0.3f, 0.6f));
  return std::string("{") + R"("camera": {"position": [0, -0.95, 1], "look_at": [0, 0, 0.9], "fov": 60, "width": 24, "height": 18},
 "media": {"mist": {"sigma_a": 0.1, "sigma_s": 0.8, "g": 0.5},
           "smoke": {"sigma_a": [0.3, 0.5, 0.8], "sigma_s": [2.0, 1.5, 1.0], "g": -0.4,
                     "grid": {"file": ")" + file + R"(", "density_grid": "density"}}},
 "materials": {"wall": {"type": "diffuse", "color": [0.6, 0.55, 0.5]}, "smoke": {"type": "volume", "interior": "smoke"},
               "mist": {"type": "volume", "interior": "mist"}},
 "lights": [{"type": "point", "position": [0.3, -0.2, 1.7], "intensity": 10}],
 "objects": [{"type": "box", "min": [-1, -1, 0], "max": [1, 1, 2], "material": "wall"},
             {"type": "box", "min": [-0.8, -0.15, 0.15], "max": [0.1, 0.75, 1.05], "material": "smoke"},
             {"type": "sphere", "center": [0.1, 0.3, 0.9], "radius": 0.45, "segments": 32, "material": "mist"}]})";
}

TEST(MediaPhotons, SppmAndPathTracingAgreeInAGridMedium) {
  // Photons fly through the grid by delta tracking, surface photons and NEE take its
  // transmittance, eye segments through it gather volume photons weighted by the ratio-tracked
  // transmittance to each and by the phase mixture at the photon.
  const Scene s = scene_from(grid_fog_room());
  ASSERT_TRUE(s.has_grid_media());
  // pt's reference: the median of 5 runs' means (256 spp each). Its delta-tracked coloured smoke
  // has rare fireflies: one run of 1024 spp (seed 13) came out 5.5 % above three others (seeds
  // 3, 21, 22, which agree within 0.5 %); the median of means is robust to one such run.
  const RGB pt = pt_median(s, 256, {31, 32, 33, 34, 35});
  // msppm (its camera paths through the grid, the same walk and beam gather): msppm_media_test.cpp.
  for (const char* method : {"sppm", "msppm"}) {
    Stats stats;
    bool finite = false;
    const RGB m = image_mean(render(method, s, 48, media_photon_params(14, 100000, 0.02), &stats), &finite);
    EXPECT_TRUE(finite);
    EXPECT_GT(stats.extra.at("volume photons stored"), 0.0);
    // The issue asks for 1 % on homogeneous media (the fog room above); the grid adds the noise
    // of the tracking estimators to both: 2 % headroom.
    expect_near_pt(m, pt, 0.02, std::string("grid fog room: ") + method);
  }
}

// A smoke domain's coloured smoke (scene format smoke_color_grids: the cache's colour grids
// premultiplied by its density, unpremultiplied after interpolation, as Cycles reads them): a
// red blob, deeper on one side, in a grey room under a point light, optically thin
// enough that single scattering carries most of its colour.
std::string coloured_smoke_room() {
  const auto dir = std::filesystem::temp_directory_path() / ("gradphoton_media_photon_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "coloured-smoke.vdb").string();
  const int n = 12;
  const float h = 0.5f;
  auto grid = [&](const char* name) {
    VoxelGrid g;
    g.name = name;
    g.size = {n, n, n};
    for (int i = 0; i < 3; ++i) {
      g.index_to_object.m[i][i] = 2 * h / n;
      g.index_to_object.m[i][3] = (i == 2 ? 0.9f : 0.0f) - h;
    }
    return g;
  };
  VoxelGrid d = grid("density"), r = grid("color_r"), gr = grid("color_g"), b = grid("color_b");
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const float x = (i - 5.5f) / 6, y = (j - 5.5f) / 6, z = (k - 5.5f) / 6;
        const float dens = std::max(0.0f, 2.0f * (1 - (x * x + y * y + z * z)));
        d.data.push_back(dens);
        r.data.push_back(dens * (0.7f + 0.25f * x));  // deep red where x > 0, pinker where x < 0
        gr.data.push_back(dens * 0.35f);
        b.data.push_back(dens * (0.3f - 0.25f * x));
      }
  write_vdb(file, {&d, &r, &gr, &b});
  return std::string("{") + R"("camera": {"position": [0, -1.9, 1.0], "look_at": [0, 0, 0.9], "fov": 55, "width": 20, "height": 15},
 "media": {"smoke": {"sigma_s": 1, "g": 0.2, "grid": {"file": ")" + file + R"(", "density_grid": "density", "density": 1.5,
           "absorption_color": [0.3, 0.3, 0.3], "smoke_color_grids": ["color_r", "color_g", "color_b", "density"]}}},
 "materials": {"wall": {"type": "diffuse", "color": 0.6}, "smoke": {"type": "volume", "interior": "smoke"}},
 "lights": [{"type": "point", "position": [0.2, -0.5, 1.8], "intensity": 6}],
 "objects": [{"type": "box", "min": [-1.2, -2, 0], "max": [1.2, 1.2, 2], "material": "wall"},
             {"type": "box", "min": [-0.5, -0.5, 0.4], "max": [0.5, 0.5, 1.4], "material": "smoke"}]})";
}

TEST(MediaPhotons, SmokeColourGridsInSppmAndTheSpectralMethodsMatchPathTracing) {
  // The colour grids reach every method that renders grids: SPPM's photons and eye segments
  // (RGB), and spt / spt-hero's wavelengths (the colour through the primaries' upsampling,
  // MediumSpectra). Each per channel against pt's median of three runs. Measured (load ~15):
  // sppm / pt 0.995 0.995 0.996; spt (512 passes) 0.998 1.010 1.023; spt-hero 1.015 1.008 1.008.
  // Bounds: sppm 2 %; the spectral methods 4 %, their per-channel difference from RGB including
  // the spectral product of a chromatic medium (HeroWavelengthsInChromaticFogMatchRgb...: 3 %).
  // Seen failing with the smoke's colour dropped from the photons' scattering weight (sppm 0.88 /
  // 1.04 / 1.07) and with the primaries' spectra swapped red for blue (spt 0.88 / 1.01 / 1.15,
  // spt-hero 0.91 / 1.01 / 1.13).
  const Scene s = scene_from(coloured_smoke_room());
  ASSERT_TRUE(s.has_grid_media());
  ASSERT_TRUE(s.media[0].grid->has_color_grid());
  const RGB pt = pt_median(s, 128, {41, 42, 43});
  ASSERT_GT(pt.r, 1.1f * pt.b) << "the smoke's red side is not seen";  // the scene shows its colour
  Stats stats;
  bool finite = false;
  const RGB sppm = image_mean(render("sppm", s, 32, media_photon_params(15, 50000, 0.02), &stats), &finite);
  EXPECT_TRUE(finite);
  const RGB spt = pt_median(s, 512, {44, 45, 46}, "spt");
  const RGB hero = pt_median(s, 128, {47, 48, 49}, "spt-hero");
  std::printf("coloured smoke: pt %.4f %.4f %.4f; sppm / pt %.4f %.4f %.4f; spt / pt %.4f %.4f %.4f; spt-hero / pt %.4f %.4f %.4f\n",
              pt.r, pt.g, pt.b, sppm.r / pt.r, sppm.g / pt.g, sppm.b / pt.b, spt.r / pt.r, spt.g / pt.g, spt.b / pt.b,
              hero.r / pt.r, hero.g / pt.g, hero.b / pt.b);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(sppm[c] / pt[c], 1.0, 0.02) << "sppm channel " << c;
    EXPECT_NEAR(spt[c] / pt[c], 1.0, 0.04) << "spt channel " << c;
    EXPECT_NEAR(hero[c] / pt[c], 1.0, 0.04) << "spt-hero channel " << c;
  }
}

TEST(MediaPhotons, MemoryStaysFlatOverManyPassesWithVolumePhotons) {
  // Homogeneous media with uniform photons, a grid medium, and the adaptive sampler's chains
  // (their pools of volume photons counted in memory_bytes).
  struct Case {
    std::string scene, method;
  };
  for (const Case& c : {Case{kFogRoom, "sppm"}, Case{grid_fog_room(), "sppm"}, Case{kFogRoom, "sppm-adaptive"}}) {
    Scene s = scene_from(c.scene);
    s.camera.width = 8;
    s.camera.height = 6;
    Params p = media_photon_params(11, 2000, 0.05);
    if (c.method == "sppm-adaptive") p.set("chains", 8);
    auto integ = make_integrator(c.method, s, p);
    auto* sppm = dynamic_cast<ProgressivePhotonMapping*>(integ.get());
    ASSERT_NE(sppm, nullptr);
    size_t at_100 = 0;
    for (int pass = 1; pass <= 1000; ++pass) {
      integ->iterate(nullptr);
      if (pass == 100) at_100 = sppm->memory_bytes();
    }
    const double stored = integ->stats().extra.at("volume photons stored");
    EXPECT_GT(stored, 1000.0 * 100) << c.method << (s.has_grid_media() ? " (grid)" : "");  // volume photons every pass
    // Capacities follow the largest pass so far, not the passes' sum: at most a few per cent more
    // after 900 further passes (the photon counts of a pass vary), never growing with the count.
    EXPECT_LE(sppm->memory_bytes(), at_100 * 1.1) << c.method << (s.has_grid_media() ? " (grid)" : "") << ": " << at_100;
  }
}

TEST(MediaPhotons, ErrorEstimateIsNotAvailableWithMedia) {
  const Scene s = scene_from(kFogRoom);
  auto integ = make_integrator("sppm", s, media_photon_params(12, 2000, 0.05));
  integ->iterate(nullptr);
  integ->iterate(nullptr);
  EXPECT_LT(integ->estimated_error(), 0);  // run_progressive refuses --target-error alone
  EXPECT_THROW(run_progressive(*integ, StopRule{0, 0, 0.1}, nullptr), ParamError);
}

}  // namespace
}  // namespace gp
