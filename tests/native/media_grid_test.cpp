// Heterogeneous media over OpenVDB grids (media/grid.h, media/vdb_file.h, the tracking in
// media/medium.cpp): the loader's round trip and its errors (missing, corrupt, wrong grid), the
// majorant grid bounding every lookup, a constant-density grid rendering as the homogeneous
// medium, an albedo-1 grid in a uniform World (furnace), Beer-Lambert through a slab whose
// density varies (camera rays: delta/ratio tracking; shadow rays: ratio tracking), and
// blackbody emission from a temperature grid.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <cmath>
#include <tuple>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "core/rng.h"
#include "core/spectrum.h"
#include "media/grid.h"
#include "media/medium.h"
#include "media/vdb_file.h"
#include "render_for_tests.h"
#include "scene/loader.h"

namespace gp {
namespace {

std::string temp_path(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("gradphoton_grid_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// An n^3 grid whose cells fill the box [-h, h]^3 (voxel i's cell [i, i + 1] of index space, as
// Cycles reads grids: media/grid.cpp).
VoxelGrid box_grid(const std::string& name, int n, float h, int channels = 1) {
  VoxelGrid g;
  g.name = name;
  g.channels = channels;
  g.size = {n, n, n};
  g.data.assign(size_t(n) * n * n * channels, 0.0f);
  const float v = 2 * h / n;
  for (int i = 0; i < 3; ++i) {
    g.index_to_object.m[i][i] = v;
    g.index_to_object.m[i][3] = -h;
  }
  return g;
}
template <class F>
void fill(VoxelGrid& g, F&& f) {  // f(i, j, k) -> value (every channel)
  size_t at = 0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        for (int c = 0; c < g.channels; ++c) g.data[at++] = f(i, j, k);
}

// ---- The file ----

TEST(VdbFile, WrittenGridsReadBackWithTransformAndBackground) {
  VoxelGrid d = box_grid("density", 6, 1.0f);
  fill(d, [](int i, int j, int k) { return 0.1f * i + 0.01f * j + 0.001f * k + 0.5f; });
  d.lo = {-2, 3, 1};
  VoxelGrid c = box_grid("color", 6, 1.0f, 3);
  fill(c, [](int i, int, int) { return 0.25f * i; });
  const std::string file = temp_path("roundtrip.vdb");
  write_vdb(file, {&d, &c});
  const auto names = vdb_grid_names(file);
  ASSERT_EQ(names.size(), 2u);
  EXPECT_EQ(names[0].name, "density");
  const auto r = read_vdb_grid(file, "density");
  ASSERT_EQ(r->channels, 1);
  EXPECT_EQ(r->lo, d.lo);
  EXPECT_EQ(r->size, d.size);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(r->index_to_object.m[i][j], d.index_to_object.m[i][j], 1e-6);
  EXPECT_FLOAT_EQ(r->at(-2 + 3, 3 + 2, 1 + 1), 0.5f + 0.3f + 0.02f + 0.001f);
  EXPECT_EQ(r->at(100, 0, 0), 0.0f);  // background
  // Trilinear between voxel centres.
  float v;
  r->lookup(Vec3(-2 + 2.5f, 3 + 2, 1 + 1), &v);
  EXPECT_NEAR(v, 0.5f + 0.25f + 0.02f + 0.001f, 1e-6);
  const auto rc = read_vdb_grid(file, "color");
  // (Voxels of value 0, the background, are inactive: the box starts at i = 1.)
  EXPECT_EQ(rc->channels, 3);
  EXPECT_FLOAT_EQ(rc->at(4, 0, 0, 2), 1.0f);
}

TEST(VdbFile, MissingCorruptAndWrongGridsAreErrorsNamingTheFile) {
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const VdbError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string missing = temp_path("no-such-file.vdb");
  EXPECT_NE(message([&] { read_vdb_grid(missing, "density"); }).find("no-such-file.vdb"), std::string::npos);
  // Corrupt: random bytes, and a valid file cut short.
  const std::string junk = temp_path("junk.vdb");
  std::ofstream(junk, std::ios::binary) << "this is not an OpenVDB file at all, just some bytes";
  const std::string m1 = message([&] { read_vdb_grid(junk, "density"); });
  EXPECT_NE(m1.find("junk.vdb"), std::string::npos) << m1;
  VoxelGrid d = box_grid("density", 8, 1.0f);
  fill(d, [](int i, int j, int k) { return 1.0f + i + j + k; });
  const std::string good = temp_path("good.vdb"), cut = temp_path("cut.vdb");
  write_vdb(good, {&d});
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  for (size_t len : {bytes.size() / 2, bytes.size() - 7, size_t(40)}) {
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, len);
    const std::string m = message([&] { read_vdb_grid(cut, "density"); });
    EXPECT_NE(m.find("cut.vdb"), std::string::npos) << "cut at " << len << ": " << m;
  }
  // A grid that is not there: the message lists those that are.
  const std::string m2 = message([&] { read_vdb_grid(good, "flame"); });
  EXPECT_NE(m2.find("no grid named 'flame'"), std::string::npos) << m2;
  EXPECT_NE(m2.find("'density'"), std::string::npos) << m2;
  // Through the scene format: the error names the scene file's key and the .vdb file.
  try {
    scene_from(R"({"media": {"smoke": {"sigma_s": 1, "grid": {"file": ")" + missing + R"(", "density_grid": "density"}}}})");
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("/media/smoke/grid/density_grid"), std::string::npos) << w;
    EXPECT_NE(w.find("no-such-file.vdb"), std::string::npos) << w;
  }
}

TEST(VdbFile, HostileLengthsAreErrorsWithoutGiantAllocations) {
  // Lengths and counts in the archive's header, descriptors and a grid's metadata set far beyond
  // the file: each a VdbError naming the file and what was wrong, before OpenVDB allocates for
  // it (a name length of 0xF0000000 had the loader fill 4 GB: util/Name.h readString).
  VoxelGrid d = box_grid("density", 8, 1.0f);
  fill(d, [](int i, int j, int k) { return 1.0f + i + j + k; });
  const std::string good = temp_path("hostile-source.vdb"), bad = temp_path("hostile.vdb");
  write_vdb(good, {&d});
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  // The layout write_vdb gives (file version 224, grid offsets): header and UUID to byte 57, the
  // file's metadata count at 57, the grid count at 61, the name's length at 65, the type's at 76,
  // the instance parent's at 96, the grid's, block's and end's positions at 100, 108, 116; the
  // grid at 124: its compression flags, then its metadata count at 128 and first name at 132.
  auto u32_at = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, bytes.data() + at, 4);
    return v;
  };
  ASSERT_EQ(u32_at(61), 1u);
  ASSERT_EQ(u32_at(65), 7u);                          // "density"
  ASSERT_EQ(bytes.substr(69, 7), "density");
  ASSERT_EQ(u32_at(100), 124u);                       // (low half of the grid's position)
  ASSERT_GT(u32_at(128), 0u);                         // the grid's metadata entries
  struct Patch {
    size_t at;
    uint64_t value;
    int width;
    const char* says;
  };
  const Patch patches[] = {{65, 0xF0000000u, 4, "a grid name of 4026531840 bytes"},
                           {61, 0x40000000u, 4, "a grid count of 1073741824"},
                           {57, 0xFFFFFFF0u, 4, "the file's metadata claims 4294967280 entries"},
                           {100, bytes.size() + 100, 8, "grid 'density' placed at bytes"},
                           {132, 0xF0000000u, 4, "grid 'density''s metadata (a name) of 4026531840 bytes"}};
  rusage before{};
  getrusage(RUSAGE_SELF, &before);
  for (const Patch& p : patches) {
    std::string b = bytes;
    std::memcpy(b.data() + p.at, &p.value, p.width);
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << b;
    try {
      read_vdb_grid(bad, "density");
      ADD_FAILURE() << "no error for " << p.says;
    } catch (const VdbError& e) {
      const std::string w = e.what();
      EXPECT_NE(w.find("hostile.vdb"), std::string::npos) << w;
      EXPECT_NE(w.find(p.says), std::string::npos) << w;
    }
  }
  rusage after{};
  getrusage(RUSAGE_SELF, &after);
  // The peak resident set grew by less than 256 MB (ru_maxrss in kB); it was 4 GB.
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 256 * 1024);
}

TEST(VdbFile, EveryLengthInTheTreeIsCheckedBeforeOpenVdbReadsIt) {
  // Every 4-byte position of a written file (two grids: float and vec3, blosc-compressed trees
  // with delayed-load metadata) patched with a huge or a negative 64-bit value: each either loads
  // or is a VdbError naming the file, and none reaches OpenVDB's allocation of a length read from
  // the file (a std::bad_alloc in this build, an abort under AddressSanitizer: OpenVDB's
  // bloscFromStream took a blosc chunk's size from the file) nor its copy of an uncompressed
  // chunk of the file's length into a node's buffer.
  VoxelGrid d = box_grid("density", 8, 1.0f), c = box_grid("color", 8, 1.0f, 3);
  fill(d, [](int i, int j, int k) { return 1.0f + i + 2 * j + 3 * k; });
  fill(c, [](int i, int j, int k) { return 0.25f * (i + j + k); });
  const std::string good = temp_path("sweep-source.vdb");
  write_vdb(good, {&d, &c});
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const uint64_t patterns[] = {0x7FFFFFFFFFFFFFF0ULL, 0xFFFFFFFFFFFF0000ULL};
  int loaded = 0, refused = 0;
  for (size_t at = 0; at + 8 <= bytes.size(); at += 4)
    for (uint64_t v : patterns) {
      std::string b = bytes;
      std::memcpy(b.data() + at, &v, 8);
      try {
        for (const char* name : {"density", "color"}) read_vdb_grid_from_memory(b, name, "'sweep.vdb'");
        ++loaded;
      } catch (const VdbError& e) {
        const std::string w = e.what();
        ++refused;
        ASSERT_NE(w.find("sweep.vdb"), std::string::npos) << "at " << at << ": " << w;
        ASSERT_EQ(w.find("more memory than there is"), std::string::npos) << "at " << at << ": " << w;
      }
    }
  EXPECT_GT(refused, 100);
  RecordProperty("loaded", loaded);
}

// ---- The majorant grid ----

TEST(GridMedium, MajorantBoundsEveryLookupAlongRays) {
  // A noisy density and colour grid, rays through it in every direction: at every point the
  // walk passes, the block's majorant is at least the coefficients there.
  auto d = std::make_shared<VoxelGrid>(box_grid("density", 21, 1.0f));
  Rng noise = Rng::for_key(1, 2, 3);
  fill(*d, [&](int, int, int) { return noise.uniform() < 0.3f ? 4 * noise.uniform() : 0.0f; });
  auto c = std::make_shared<VoxelGrid>(box_grid("color", 21, 1.0f, 3));
  fill(*c, [&](int, int, int) { return 1.5f * noise.uniform(); });
  Affine object;  // rotated and moved, as a Volume object
  object.m[0][0] = 0.0f, object.m[0][1] = -2.0f, object.m[1][0] = 2.0f, object.m[1][1] = 0.0f, object.m[2][2] = 0.5f;
  object.m[0][3] = 1, object.m[1][3] = -3, object.m[2][3] = 0.2f;
  GridMediumParams p;
  p.density = 3.0f;
  p.color = RGB(0.9f, 0.5f, 0.2f);
  p.absorption_color = RGB(0.1f, 0.4f, 0.9f);
  const GridMedium g(d, c, nullptr, object, p);
  Medium m;
  m.grid = std::shared_ptr<const GridMedium>(&g, [](const GridMedium*) {});
  const MediumChannels ch = rgb_channels(m);
  Rng rng = Rng::for_key(4, 5, 6);
  int checked = 0, violations = 0;
  for (int r = 0; r < 200; ++r) {
    const Vec3 o = g.world_bounds().center() + Vec3(rng.uniform() - 0.5f, rng.uniform() - 0.5f, rng.uniform() - 0.5f) * 8;
    const Vec3 dir = normalize(g.world_bounds().center() - o + Vec3(rng.uniform(), rng.uniform(), rng.uniform()) - Vec3(0.5f));
    const Affine& w2i = g.world_to_index();
    g.walk(w2i.point(o), w2i.vector(dir), 0.0f, 20.0f, [&](float a, float b, const GridMedium::Bound& bound) {
      const float maj = grid_majorant(ch, 3, bound);
      for (int s = 0; s < 8; ++s) {
        const float t = a + (b - a) * (s + rng.uniform()) / 8;
        PointCoefficients pc;
        add_grid_point(ch, 3, o + dir * t, false, pc);
        for (int k = 0; k < 3; ++k) {
          if (pc.sigma_t[k] > maj && violations < 3) {
            const Vec3 ix = g.world_to_index().point(o + dir * t);
            ADD_FAILURE() << "t " << t << " in [" << a << ", " << b << ") idx " << ix.x << " " << ix.y << " " << ix.z << " sigma " << pc.sigma_t[k] << " maj " << maj;
          }
          violations += pc.sigma_t[k] > maj;
        }
        ++checked;
      }
      return true;
    });
  }
  EXPECT_GT(checked, 5000);
  EXPECT_EQ(violations, 0);
}

// ---- Whole paths ----

Film render_pt(const Scene& s, int passes, const std::string& method = "pt", uint64_t seed = 1, int max_depth = 256) {
  Params p;
  p.set("seed", seed);
  p.set("max_depth", max_depth);
  return render(method, s, passes, p);
}

// A grid medium filling the box [-1, 1]^3 of a scene, written to `file`.
std::string write_grids(const std::string& file, const std::vector<const VoxelGrid*>& grids) {
  const std::string path = temp_path(file);
  write_vdb(path, grids);
  return path;
}

std::string fog_scene(const std::string& medium) {
  return std::string("{") + R"("camera": {"position": [0, -5, 1], "look_at": [0, 0, 0.3], "fov": 35, "width": 16, "height": 12},
    "media": {"fog": )" + medium + R"(},
    "materials": {"floor": {"type": "diffuse", "color": 0.6}, "fog": {"type": "volume", "interior": "fog"}},
    "environment": {"color": [0.2, 0.3, 0.5]},
    "lights": [{"type": "point", "position": [1, -1, 3], "intensity": 30}],
    "objects": [{"type": "quad", "center": [0, 0, -1.2], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                {"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "fog"}]})";
}

TEST(GridMediaPathTracing, ConstantDensityGridRendersAsTheHomogeneousMedium) {
  // The same coefficients, once homogeneous and once as a grid of constant density 2 (background
  // 2 too, so the box is uniform to its faces) at coefficients halved: means agree within noise,
  // in RGB and in hero wavelengths.
  VoxelGrid d = box_grid("density", 8, 1.0f);
  fill(d, [](int, int, int) { return 2.0f; });
  d.background[0] = 2.0f;
  const std::string file = write_grids("constant.vdb", {&d});
  const Scene hom = scene_from(fog_scene(R"({"sigma_a": [0.2, 0.4, 0.1], "sigma_s": [1.2, 0.8, 1.6], "g": 0.3, "emission": 0.1})"));
  const Scene grid = scene_from(fog_scene(R"({"sigma_a": [0.1, 0.2, 0.05], "sigma_s": [0.6, 0.4, 0.8], "g": 0.3, "emission": 0.1,
      "grid": {"file": ")" + file + R"(", "density_grid": "density"}})"));
  ASSERT_TRUE(grid.media[0].grid);
  for (const char* method : {"pt", "spt-hero"}) {
    const RGB a = image_mean(render_pt(hom, 96, method, 2, 64));
    bool finite = false;
    const RGB b = image_mean(render_pt(grid, 96, method, 3, 64), &finite);
    EXPECT_TRUE(finite);
    // Both at a few per mille of noise (96 spp over 192 pixels); 2 % headroom per channel.
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(b[k] / a[k], 1.0, 0.02) << method << " channel " << k << ": " << a[k] << " vs " << b[k];
  }
}

TEST(GridMediaPathTracing, AlbedoOneGridInUniformEnvironmentIsInvisible) {
  // A blob of varying density (zero at the box's faces), scattering only, under a uniform
  // World: every ray sees the World's radiance (the furnace). Also with a colour grid of
  // white (Principled Volume's colour 1: no absorption). A dropped null-collision weight or a
  // wrong majorant breaks it.
  VoxelGrid d = box_grid("density", 16, 1.0f);
  fill(d, [](int i, int j, int k) {
    const float x = (i - 7.5f) / 8, y = (j - 7.5f) / 8, z = (k - 7.5f) / 8;
    return std::max(0.0f, 6.0f * (1 - (x * x + y * y + z * z)) * (0.6f + 0.4f * std::sin(9.0f * x)));
  });
  VoxelGrid c = box_grid("color", 16, 1.0f, 3);
  fill(c, [](int, int, int) { return 1.0f; });
  const std::string file = write_grids("blob.vdb", {&d, &c});
  const std::string scene_head = std::string("{") + R"("camera": {"position": [0, -4, 0], "look_at": [0, 0, 0], "fov": 30, "width": 16, "height": 16},
    "materials": {"boundary": {"type": "volume", "interior": "cloud"}},
    "environment": {"color": [0.5, 1.0, 2.0], "strength": 1},
    "objects": [{"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "boundary"}],
    "media": {"cloud": )";
  for (const std::string medium :
       {R"({"sigma_s": [0.5, 2.0, 4.0], "g": 0.6, "grid": {"file": ")" + file + R"(", "density_grid": "density"}})",
        R"({"sigma_s": 1, "g": -0.3, "grid": {"file": ")" + file +
            R"(", "density_grid": "density", "color_grid": "color", "density": 1.5, "absorption_color": [0.2, 0.5, 0.9]}})"}) {
    const Scene s = scene_from(scene_head + medium + "}}");
    // Measured spread of one render's mean (16 seeds, the first medium): pt at 48 spp 0.8 % of
    // the red channel, spt-hero 2.6 % (its wavelengths see different densities); spt-hero runs
    // 4x the samples (1.3 %). Bounds: 2 % for pt, 5 % for spt-hero (about 4 standard deviations).
    for (const auto& [method, passes, bound] : {std::tuple{"pt", 48, 0.02}, std::tuple{"spt-hero", 192, 0.05}}) {
      bool finite = false;
      const RGB m = image_mean(render_pt(s, passes, method), &finite);
      EXPECT_TRUE(finite);
      EXPECT_NEAR(m.r, 0.5, 0.5 * bound) << method << " " << medium;
      EXPECT_NEAR(m.g, 1.0, 1.0 * bound) << method << " " << medium;
      EXPECT_NEAR(m.b, 2.0, 2.0 * bound) << method << " " << medium;
    }
  }
}

// A purely absorbing slab z in [0.5, 0.9] over x, y in [-3, 3] whose density grows linearly
// with height (exact under trilinear interpolation): optical depth = sigma_a x mean density x 0.4.
std::string ramp_slab_file() {
  VoxelGrid d;
  d.name = "density";
  d.size = {2, 2, 9};
  d.data.resize(2 * 2 * 9);
  // Voxel centres (index i + 1/2) at z = 0.5 + k 0.05 (k = 0..8), x, y at +-3 (linear:
  // interpolation is exact).
  for (int i = 0; i < 3; ++i) d.index_to_object.m[i][i] = i < 2 ? 6.0f : 0.05f;
  d.index_to_object.m[0][3] = d.index_to_object.m[1][3] = -6.0f;
  d.index_to_object.m[2][3] = 0.5f - 0.025f;
  fill(d, [](int, int, int k) { return 0.5f + 0.25f * k; });  // 0.5 at z 0.5 up to 2.5 at 0.9: mean 1.5
  return write_grids("ramp.vdb", {&d});
}

TEST(GridMediaPathTracing, BeerLambertThroughAVaryingSlabOnCameraAndShadowRays) {
  const std::string file = ramp_slab_file();
  const std::string medium = R"({"sigma_a": [0.5, 1.0, 2.0], "grid": {"file": ")" + file + R"(", "density_grid": "density"}})";
  const float sigma[3] = {0.5f, 1.0f, 2.0f};
  {
    // An emitter of radiance 1 seen through the slab.
    const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8},
      "media": {"ink": )" + medium + R"(},
      "materials": {"light": {"type": "emission", "emission": 1, "strength": 1}, "slab": {"type": "volume", "interior": "ink"}},
      "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "light"},
                  {"type": "box", "min": [-3, -3, 0.5], "max": [3, 3, 0.9], "material": "slab"}]})");
    const RGB m = image_mean(render_pt(s, 256));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], std::exp(-sigma[c] * 1.5f * 0.4f), 0.01) << "camera, channel " << c;
  }
  {
    // Only the shadow ray crosses the slab (a point light over a diffuse plane, direct light).
    const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 0.45], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8},
      "media": {"ink": )" + medium + R"(},
      "materials": {"grey": {"type": "diffuse", "color": 0.5}, "slab": {"type": "volume", "interior": "ink"}},
      "lights": [{"type": "point", "position": [0, 0, 2], "intensity": 8}],
      "objects": [{"type": "quad", "center": [0, 0, 0], "u": [5, 0, 0], "v": [0, 5, 0], "material": "grey"},
                  {"type": "box", "min": [-3, -3, 0.5], "max": [3, 3, 0.9], "material": "slab"}]})");
    const RGB m = image_mean(render_pt(s, 256, "pt", 1, 2));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(m[c], 0.5 / M_PI * 8.0 / 4.0 * std::exp(-sigma[c] * 1.5f * 0.4f), 4e-3) << "shadow, channel " << c;
  }
}

TEST(GridMediaPathTracing, BlackbodyEmissionFromATemperatureGrid) {
  // Principled Volume with only blackbody emission (no density: nothing absorbs), temperature
  // 1500 K x a grid of 2 at its voxels: L = thickness x sigma_SB 1e-6 / pi x T^4 x colour(T).
  VoxelGrid t = box_grid("temperature", 4, 1.0f);
  fill(t, [](int, int, int) { return 2.0f; });
  t.background[0] = 2.0f;
  const std::string file = write_grids("hot.vdb", {&t});
  const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8},
    "media": {"fire": {"grid": {"file": ")" + file + R"(", "temperature_grid": "temperature", "temperature": 1500, "blackbody_intensity": 1}}},
    "materials": {"fire": {"type": "volume", "interior": "fire"}},
    "objects": [{"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "fire"}]})");
  const RGB m = image_mean(render_pt(s, 32));
  const float T = 3000.0f;
  const RGB expected = blackbody_rec709(T) * (2.0f * 5.670373e-8f * 1e-6f / float(M_PI) * T * T * T * T);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c] / expected[c], 1.0, 0.02) << "channel " << c << " " << m[c] << " vs " << expected[c];
}


TEST(GridMediaPathTracing, EmissionThroughAnAbsorbingFlameGridIsTheAnalyticIntegral) {
  // A smoke domain's fire as Cycles reads it: the flame grid f = 0.6 mapped voxel by voxel to a
  // temperature 1.5 + 0.6 x (3 - 1.5) = 2.4 (x the Temperature socket's 1000 K: 2400 K), and a
  // black smoke (colour 0: absorption only) of density grid 0.5 x Density 2: sigma_a = 1. Along
  // the 2 m box: L = e / sigma_a x (1 - exp(-2 sigma_a)), e = sigma_SB 1e-6 / pi x T^4 x colour(T).
  // (Without a colour grid the medium's sigma_a is the coefficient at grid density 1, Principled
  // Volume's Density included, as the exporter writes it: 2.)
  VoxelGrid flame = box_grid("flame", 4, 1.0f), density = box_grid("density", 4, 1.0f);
  fill(flame, [](int, int, int) { return 0.6f; });
  fill(density, [](int, int, int) { return 0.5f; });
  flame.background[0] = 0.6f;
  density.background[0] = 0.5f;
  const std::string file = write_grids("fire.vdb", {&flame, &density});
  const Scene s = scene_from(std::string("{") + R"("camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 2, "width": 8, "height": 8},
    "media": {"fire": {"sigma_a": 2, "grid": {"file": ")" + file + R"(", "density_grid": "density", "temperature_grid": "flame",
      "flame_temperature": [1.5, 3.0], "temperature": 1000, "blackbody_intensity": 1}}},
    "materials": {"fire": {"type": "volume", "interior": "fire"}},
    "objects": [{"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1], "material": "fire"}]})");
  const RGB m = image_mean(render_pt(s, 64));
  const float T = 2400.0f, sigma_a = 1.0f;
  const RGB e = blackbody_rec709(T) * (5.670373e-8f * 1e-6f / float(M_PI) * T * T * T * T);
  const RGB expected = e * ((1.0f - std::exp(-2.0f * sigma_a)) / sigma_a);
  // (Ratio tracking's noise on a constant medium: a few tenths of a percent at 64 samples; 2 %
  // headroom. A flame read without the mapping (T = 600 K) is 256x darker; emission without the
  // absorption 1.16x brighter.)
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c] / expected[c], 1.0, 0.02) << "channel " << c << " " << m[c] << " vs " << expected[c];
}

TEST(GridMedium, SmokeColourIsUnpremultipliedAfterInterpolationAsCyclesReadsIt) {
  // A smoke domain's colour grids [r, g, b, density] (scene format smoke_color_grids): between
  // two voxels of density 1 and 3 and red 0.2 and 1.0, Cycles' colour is (0.2 x 1 + 1.0 x 3) /
  // (1 + 3) = 0.8 half way, not the mean red 0.6; the majorant bounds it.
  VoxelGrid r = box_grid("color_r", 2, 1.0f), g = box_grid("color_g", 2, 1.0f), b = box_grid("color_b", 2, 1.0f),
            d = box_grid("density", 2, 1.0f);
  fill(r, [](int i, int, int) { return i == 0 ? 0.2f : 1.0f; });
  fill(g, [](int, int, int) { return 0.5f; });
  fill(b, [](int, int, int) { return 0.25f; });
  fill(d, [](int i, int, int) { return i == 0 ? 1.0f : 3.0f; });
  const std::string file = write_grids("smoke-colour.vdb", {&r, &g, &b, &d});
  const Scene s = scene_from(R"({"media": {"smoke": {"sigma_s": 1, "grid": {"file": ")" + file +
                             R"(", "density_grid": "density", "smoke_color_grids": ["color_r", "color_g", "color_b", "density"]}}}})");
  ASSERT_EQ(s.media.size(), 1u);
  const GridMedium& m = *s.media[0].grid;
  ASSERT_TRUE(m.has_color_grid());
  // Index space of lookups: voxel centres at integers 0 and 1 (grid.h).
  const RGB half = m.color_at(Vec3(0.5f, 0.5f, 0.5f)), first = m.color_at(Vec3(0.0f, 0.0f, 0.0f));
  EXPECT_NEAR(half.r, 0.8f, 1e-5f);
  EXPECT_NEAR(half.g, 0.5f, 1e-5f);
  EXPECT_NEAR(half.b, 0.25f, 1e-5f);
  EXPECT_NEAR(first.r, 0.2f, 1e-5f);
  EXPECT_NEAR(m.density_at(Vec3(0.5f, 0.5f, 0.5f)), 2.0f, 1e-5f);
  EXPECT_GE(m.global_bound().color.r, 1.0f);
  // A wrong list is an error naming the key.
  try {
    scene_from(R"({"media": {"smoke": {"sigma_s": 1, "grid": {"file": ")" + file + R"(", "smoke_color_grids": ["color_r"]}}}})");
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("smoke_color_grids"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace gp
