// Tests for native/io: EXR read/write, PNG display through OCIO and the built-in sRGB
// fallback, false-colour PNGs and image error metrics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <png.h>
#include <unistd.h>

#include "core/film.h"
#include "io/display.h"
#include "io/exr.h"
#include "io/metrics.h"

namespace fs = std::filesystem;

namespace {

// A fresh directory per test (CTest may run tests of this executable in parallel).
class IoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("gradphoton_io_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// Sets (or unsets) an environment variable for the scope of a test.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) ::setenv(name, value, 1);
    else ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) ::setenv(name_.c_str(), old_->c_str(), 1);
    else ::unsetenv(name_.c_str());
  }
 private:
  std::string name_;
  std::optional<std::string> old_;
};

struct Png {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
  const uint8_t* px(int x, int y) const { return &rgb[(size_t(y) * width + x) * 3]; }
};

Png read_png(const std::string& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str()))
    throw std::runtime_error("read_png " + path + ": " + image.message);
  image.format = PNG_FORMAT_RGB;
  Png out;
  out.width = int(image.width);
  out.height = int(image.height);
  out.rgb.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, out.rgb.data(), 0, nullptr))
    throw std::runtime_error("read_png " + path + ": " + image.message);
  return out;
}

// ---- A hand-made uncompressed EXR, so that reading is tested on files gradphoton did not write ----

struct RawChannel {
  std::string name;
  bool half = false;              // HALF (values must be one of the few below) or FLOAT
  std::vector<float> values;      // width * height, row 0 at the top
};

uint16_t to_half_bits(float v) {
  if (v == 0.0f) return std::signbit(v) ? 0x8000 : 0;
  if (v == 1.0f) return 0x3C00;
  if (v == 0.5f) return 0x3800;
  if (v == 0.25f) return 0x3400;
  if (v == 2.0f) return 0x4000;
  if (v == -1.0f) return 0xBC00;
  if (v == 65504.0f) return 0x7BFF;
  throw std::invalid_argument("to_half_bits: value not in the test table");
}

template <typename T>
void put(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // x86-64: little-endian like EXR
  s.append(b, sizeof(T));
}

void put_attr(std::string& s, const char* name, const char* type, const std::string& value) {
  s += name; s += '\0';
  s += type; s += '\0';
  put<int32_t>(s, int32_t(value.size()));
  s += value;
}

// Writes a single-part, scanline, NO_COMPRESSION EXR (OpenEXR file layout spec), optionally
// with a data window offset (origin) to check that it is handled.
void write_raw_exr(const std::string& path, int w, int h, std::vector<RawChannel> chans, int ox = 0, int oy = 0) {
  std::sort(chans.begin(), chans.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  std::string s;
  put<int32_t>(s, 20000630);
  put<int32_t>(s, 2);
  std::string chlist;
  for (const auto& c : chans) {
    chlist += c.name; chlist += '\0';
    put<int32_t>(chlist, c.half ? 1 : 2);
    chlist.append(4, '\0');  // pLinear + reserved
    put<int32_t>(chlist, 1);
    put<int32_t>(chlist, 1);
  }
  chlist += '\0';
  put_attr(s, "channels", "chlist", chlist);
  put_attr(s, "compression", "compression", std::string(1, '\0'));
  std::string box;
  put<int32_t>(box, ox); put<int32_t>(box, oy); put<int32_t>(box, ox + w - 1); put<int32_t>(box, oy + h - 1);
  put_attr(s, "dataWindow", "box2i", box);
  put_attr(s, "displayWindow", "box2i", box);
  put_attr(s, "lineOrder", "lineOrder", std::string(1, '\0'));
  std::string f; put<float>(f, 1.0f);
  put_attr(s, "pixelAspectRatio", "float", f);
  std::string v2; put<float>(v2, 0.0f); put<float>(v2, 0.0f);
  put_attr(s, "screenWindowCenter", "v2f", v2);
  put_attr(s, "screenWindowWidth", "float", f);
  s += '\0';
  size_t line_bytes = 0;
  for (const auto& c : chans) line_bytes += size_t(w) * (c.half ? 2 : 4);
  const size_t table = s.size();
  for (int y = 0; y < h; ++y) put<uint64_t>(s, uint64_t(table + 8 * h + y * (8 + line_bytes)));
  for (int y = 0; y < h; ++y) {
    put<int32_t>(s, oy + y);
    put<int32_t>(s, int32_t(line_bytes));
    for (const auto& c : chans)
      for (int x = 0; x < w; ++x) {
        const float v = c.values.at(size_t(y) * w + x);
        if (c.half) put<uint16_t>(s, to_half_bits(v));
        else put<float>(s, v);
      }
  }
  std::ofstream(path, std::ios::binary).write(s.data(), std::streamsize(s.size()));
}

// A minimal OCIO v2 config: scene_linear "Linear", display "sRGB" with views "Standard"
// (the sRGB curve as an ExponentWithLinearTransform) and "Raw".
std::string write_test_ocio_config(const fs::path& dir) {
  const std::string path = (dir / "config.ocio").string();
  std::ofstream(path) << R"(ocio_profile_version: 2

roles:
  default: Linear
  scene_linear: Linear

file_rules:
  - !<Rule> {name: Default, colorspace: default}

displays:
  sRGB:
    - !<View> {name: Standard, colorspace: sRGB}
    - !<View> {name: Raw, colorspace: Linear}

active_displays: [sRGB]
active_views: [Standard, Raw]

colorspaces:
  - !<ColorSpace>
    name: Linear
    family: linear
    bitdepth: 32f
    isdata: false

  - !<ColorSpace>
    name: sRGB
    family: display
    bitdepth: 32f
    from_scene_reference: !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055, direction: inverse}
)";
  return path;
}

gp::Film make_grey_row(const std::vector<float>& values) {
  gp::Film film(int(values.size()), 1);
  auto& p = film.add_pass("combined", 3);
  for (size_t i = 0; i < values.size(); ++i) p.data[i * 3] = p.data[i * 3 + 1] = p.data[i * 3 + 2] = values[i];
  return film;
}

const float kNaN = std::numeric_limits<float>::quiet_NaN();
const float kInf = std::numeric_limits<float>::infinity();

}  // namespace

// ================================ EXR ================================

TEST_F(IoTest, ExrRoundTripIsExact) {
  const int w = 7, h = 5;  // non-square, odd: catches swapped axes and strides
  gp::Film film(w, h);
  auto& combined = film.add_pass("combined", 3);
  auto& primal = film.add_pass("primal", 3);
  auto& error = film.add_pass("error", 1);
  uint32_t state = 12345;
  auto next = [&] {  // LCG: reproducible, values over many magnitudes and both signs
    state = state * 1664525u + 1013904223u;
    const float u = float(state >> 8) / float(1u << 24);
    return (u - 0.3f) * std::exp2(float(int(state % 40u)) - 20.0f);
  };
  for (auto* p : {&combined, &primal, &error})
    for (float& v : p->data) v = next();
  combined.data[0] = 0.0f;
  combined.data[1] = 1e-40f;  // denormal
  combined.data[2] = 3.0e38f;
  error.data.back() = kInf;

  const std::string file = path("round trip.exr");
  gp::write_exr(file, film);
  const gp::Film back = gp::read_exr(file);

  ASSERT_EQ(back.width(), w);
  ASSERT_EQ(back.height(), h);
  ASSERT_EQ(back.passes().size(), 3u);
  for (const auto& [name, pass] : film.passes()) {
    ASSERT_TRUE(back.has_pass(name)) << name;
    const auto& b = back.pass(name);
    ASSERT_EQ(b.channels, pass.channels) << name;
    ASSERT_EQ(b.data.size(), pass.data.size()) << name;
    for (size_t i = 0; i < pass.data.size(); ++i)
      ASSERT_EQ(std::memcmp(&b.data[i], &pass.data[i], sizeof(float)), 0)
          << name << "[" << i << "]: " << b.data[i] << " != " << pass.data[i];
  }
  // Row 0 is the top: pixel (x=6, y=0) of combined.
  EXPECT_EQ(back.rgb("combined", 6, 0).g, combined.data[6 * 3 + 1]);
}

TEST_F(IoTest, ExrWritesLayeredChannelNames) {
  // Pass names with dots (Blender style) are written as layer.R/G/B and layer.V and come
  // back under the same names.
  gp::Film film(2, 2);
  film.add_pass("ViewLayer.Combined", 3).data = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  film.add_pass("a.b", 1).data = {0.5f, 0.25f, 2, -1};
  const std::string file = path("layers.exr");
  gp::write_exr(file, film);
  // The file must hold exactly the names "ViewLayer.Combined.R/G/B" and "a.b.V"; the EXR header
  // stores names as NUL-terminated strings, so look for them in the bytes.
  std::ifstream in(file, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Each channel entry is name, NUL, int32 pixel type (2 = FLOAT).
  const std::string float_type("\x02\0\0\0", 4);
  for (const char* name : {"ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "a.b.V"})
    EXPECT_NE(bytes.find(std::string(name) + '\0' + float_type), std::string::npos) << name;
  // compression attribute: name, type, int32 size 1, value 3 = ZIP_COMPRESSION.
  EXPECT_NE(bytes.find(std::string("compression\0compression\0\x01\0\0\0\x03", 29)), std::string::npos);
  const gp::Film back = gp::read_exr(file);
  ASSERT_TRUE(back.has_pass("ViewLayer.Combined"));
  ASSERT_TRUE(back.has_pass("a.b"));
  EXPECT_EQ(back.pass("ViewLayer.Combined").data, film.pass("ViewLayer.Combined").data);
  EXPECT_EQ(back.pass("a.b").data, film.pass("a.b").data);
}

TEST_F(IoTest, ExrReadsUnlayeredHalfRgbAsCombined) {
  const int w = 3, h = 2;
  const std::vector<float> r = {0, 0.5f, 1, 2, 0.25f, -1};
  const std::vector<float> g = {1, 1, 1, 0, 0, 65504};
  const std::vector<float> b = {0.25f, 0.5f, 2, 1, 0, 0};
  const std::vector<float> a = {1, 1, 1, 1, 0.5f, 0};
  const std::string file = path("plain.exr");
  write_raw_exr(file, w, h, {{"R", true, r}, {"G", true, g}, {"B", true, b}, {"A", true, a}}, 10, -4);
  const gp::Film film = gp::read_exr(file);
  ASSERT_EQ(film.width(), w);
  ASSERT_EQ(film.height(), h);
  ASSERT_TRUE(film.has_pass("combined"));
  const auto& p = film.pass("combined");
  ASSERT_EQ(p.channels, 3);
  for (int i = 0; i < w * h; ++i) {
    EXPECT_EQ(p.data[i * 3 + 0], r[i]) << i;
    EXPECT_EQ(p.data[i * 3 + 1], g[i]) << i;
    EXPECT_EQ(p.data[i * 3 + 2], b[i]) << i;
  }
  ASSERT_TRUE(film.has_pass("A"));  // leftover channel of the unlayered layer
  EXPECT_EQ(film.pass("A").channels, 1);
  EXPECT_EQ(film.pass("A").data, a);
  EXPECT_EQ(film.passes().size(), 2u);
}

TEST_F(IoTest, ExrReadsBlenderMultilayerNames) {
  const int w = 2, h = 2;
  const std::vector<float> r = {1, 2, 3, 4}, g = {5, 6, 7, 8}, b = {9, 10, 11, 12}, a = {1, 1, 0, 1};
  const std::vector<float> z = {10, 20, 30, 40}, nx = {0, 1, 0, 1}, ny = {1, 0, 0, 0}, nz = {0, 0, 1, 0};
  const std::string file = path("blender.exr");
  write_raw_exr(file, w, h,
                {{"ViewLayer.Combined.R", false, r}, {"ViewLayer.Combined.G", false, g},
                 {"ViewLayer.Combined.B", false, b}, {"ViewLayer.Combined.A", false, a},
                 {"ViewLayer.Depth.Z", false, z}, {"ViewLayer.Normal.X", true, nx},
                 {"ViewLayer.Normal.Y", true, ny}, {"ViewLayer.Normal.Z", true, nz}});
  const gp::Film film = gp::read_exr(file);
  ASSERT_TRUE(film.has_pass("ViewLayer.Combined"));
  EXPECT_EQ(film.pass("ViewLayer.Combined").channels, 3);
  EXPECT_EQ(film.rgb("ViewLayer.Combined", 1, 1).r, 4.0f);
  EXPECT_EQ(film.rgb("ViewLayer.Combined", 1, 1).g, 8.0f);
  EXPECT_EQ(film.rgb("ViewLayer.Combined", 0, 1).b, 11.0f);
  ASSERT_TRUE(film.has_pass("ViewLayer.Combined.A"));
  EXPECT_EQ(film.pass("ViewLayer.Combined.A").data, a);
  ASSERT_TRUE(film.has_pass("ViewLayer.Depth"));
  EXPECT_EQ(film.pass("ViewLayer.Depth").channels, 1);
  EXPECT_EQ(film.pass("ViewLayer.Depth").data, z);
  ASSERT_TRUE(film.has_pass("ViewLayer.Normal"));
  EXPECT_EQ(film.pass("ViewLayer.Normal").channels, 3);
  EXPECT_EQ(film.rgb("ViewLayer.Normal", 1, 0).r, 1.0f);
  EXPECT_EQ(film.rgb("ViewLayer.Normal", 0, 1).b, 1.0f);
  EXPECT_EQ(film.passes().size(), 4u);
}

TEST_F(IoTest, ExrErrorsNameTheFile) {
  auto expect_error_naming = [](const std::string& file) {
    try {
      gp::read_exr(file);
      ADD_FAILURE() << "no exception for " << file;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
  };
  expect_error_naming(path("does_not_exist.exr"));

  const std::string garbage = path("garbage.exr");
  std::ofstream(garbage) << "this is not an OpenEXR file, just some text long enough to be read";
  expect_error_naming(garbage);

  // A real EXR cut short.
  gp::Film film(16, 16);
  film.add_pass("combined", 3).data.assign(16 * 16 * 3, 0.5f);
  const std::string good = path("good.exr");
  gp::write_exr(good, film);
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string cut = path("truncated.exr");
  std::ofstream(cut, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size() / 3));
  expect_error_naming(cut);

  // Writing into a missing directory.
  const std::string bad_out = path("no/such/dir/out.exr");
  try {
    gp::write_exr(bad_out, film);
    ADD_FAILURE() << "no exception writing " << bad_out;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(bad_out), std::string::npos) << e.what();
  }
  EXPECT_THROW(gp::write_exr(path("empty.exr"), gp::Film(4, 4)), std::runtime_error);  // no passes
}

// ================================ PNG ================================

TEST_F(IoTest, PngBuiltinSrgbValues) {
  gp::DisplayOptions opts;
  opts.config_path = "builtin";
  EXPECT_EQ(gp::describe_display(opts), "built-in sRGB");

  // 0, 1, 0.18, 2 (clamped), -1 (clamped), 0.001 (linear toe: 12.92 * 0.001 * 255 = 3.29), NaN, Inf.
  gp::Film film = make_grey_row({0, 1, 0.18f, 2, -1, 0.001f, kNaN, kInf});
  film.pass("combined").data[0] = 1.0f;  // pixel 0 = (1, 0, 0): channels stay separate
  const std::string file = path("builtin.png");
  gp::write_png(file, film, "combined", opts);
  const Png png = read_png(file);
  ASSERT_EQ(png.width, 8);
  ASSERT_EQ(png.height, 1);
  EXPECT_EQ(png.px(0, 0)[0], 255);
  EXPECT_EQ(png.px(0, 0)[1], 0);
  EXPECT_EQ(png.px(0, 0)[2], 0);
  const int expected[8] = {-1, 255, 118, 255, 0, 3, 0, 0};
  for (int x = 1; x < 8; ++x)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(png.px(x, 0)[c], expected[x]) << "x=" << x << " c=" << c;

  // Exposure: +1 stop turns 0.09 into 0.18.
  opts.exposure = 1.0f;
  gp::write_png(file, make_grey_row({0.09f}), "combined", opts);
  EXPECT_EQ(read_png(file).px(0, 0)[1], 118);
}

TEST_F(IoTest, PngScalarPassIsGreyAndSizeIsRight) {
  gp::Film film(5, 3);
  auto& e = film.add_pass("error", 1);
  e.data[0] = 1.0f;             // (0,0) white
  e.data[2 * 5 + 4] = 0.18f;    // bottom-right
  e.data[1 * 5 + 2] = kNaN;
  gp::DisplayOptions opts;
  opts.config_path = "builtin";
  const std::string file = path("scalar.png");
  gp::write_png(file, film, "error", opts);
  const Png png = read_png(file);
  ASSERT_EQ(png.width, 5);
  ASSERT_EQ(png.height, 3);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(png.px(0, 0)[c], 255);
    EXPECT_EQ(png.px(4, 2)[c], 118);
    EXPECT_EQ(png.px(2, 1)[c], 0);
    EXPECT_EQ(png.px(1, 0)[c], 0);
  }
  EXPECT_THROW(gp::write_png(file, film, "no_such_pass", opts), std::invalid_argument);
}

TEST_F(IoTest, PngThroughOcioConfig) {
  const std::string config = write_test_ocio_config(dir_);
  gp::DisplayOptions opts;
  opts.config_path = config;
  EXPECT_EQ(gp::describe_display(opts), "OCIO " + config + ", display sRGB, view Standard");

  const gp::Film film = make_grey_row({0, 1, 0.18f, 4, kNaN, -kInf, 0.5f, kInf});
  const std::string file = path("ocio.png");
  gp::write_png(file, film, "combined", opts);
  Png png = read_png(file);
  ASSERT_EQ(png.width, 8);
  ASSERT_EQ(png.height, 1);
  const int expected[8] = {0, 255, 118, 255, 0, 0, 188, 0};  // 0.5 -> 0.7354 * 255 = 187.5
  for (int x = 0; x < 8; ++x)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(png.px(x, 0)[c], expected[x], x == 6 ? 1 : 0) << "x=" << x;

  opts.view = "Raw";  // identity: 0.5 -> 127.5 -> 128
  EXPECT_EQ(gp::describe_display(opts), "OCIO " + config + ", display sRGB, view Raw");
  gp::write_png(file, film, "combined", opts);
  png = read_png(file);
  EXPECT_EQ(png.px(6, 0)[0], 128);
  EXPECT_EQ(png.px(2, 0)[0], 46);  // 0.18 * 255 = 45.9
  EXPECT_EQ(png.px(4, 0)[0], 0);
  EXPECT_EQ(png.px(7, 0)[0], 0);

  opts.view = "NoSuchView";
  EXPECT_THROW(gp::write_png(file, film, "combined", opts), std::runtime_error);
  opts.view.clear();
  opts.config_path = path("missing.ocio");
  try {
    gp::describe_display(opts);
    ADD_FAILURE() << "missing config accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(opts.config_path), std::string::npos) << e.what();
  }
}

TEST_F(IoTest, PngAutoConfigUsesOcioEnvironmentVariable) {
  const std::string config = write_test_ocio_config(dir_);
  {
    ScopedEnv env("OCIO", config.c_str());
    EXPECT_EQ(gp::describe_display({}), "OCIO " + config + ", display sRGB, view Standard");
    gp::write_png(path("env.png"), make_grey_row({0.18f}));
    EXPECT_EQ(read_png(path("env.png")).px(0, 0)[0], 118);
  }
  {
    ScopedEnv env("OCIO", nullptr);
    const std::string d = gp::describe_display({});
    // Without OCIO: Blender's config if installed, else the built-in transform.
    if (d != "built-in sRGB") {
      EXPECT_EQ(d.rfind("OCIO /usr/share/blender/", 0), 0u) << d;
      EXPECT_NE(d.find("view Filmic"), std::string::npos) << d;
    }
  }
}

TEST_F(IoTest, BlenderConfigDefaultsToFilmic) {
  // A config in Blender's layout (datafiles/colormanagement/) is treated as Blender's: the default view is
  // "Filmic" when the display has it, although "Standard" is listed first.
  const fs::path bdir = dir_ / "blender" / "3.4" / "datafiles" / "colormanagement";
  fs::create_directories(bdir);
  std::string text;
  {
    std::ifstream in(write_test_ocio_config(dir_));
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string raw_view = "    - !<View> {name: Raw, colorspace: Linear}\n";
  ASSERT_NE(text.find(raw_view), std::string::npos);
  text.replace(text.find(raw_view), raw_view.size(), "    - !<View> {name: Filmic, colorspace: Linear}\n" + raw_view);
  text.replace(text.find("[Standard, Raw]"), 15, "[Standard, Filmic, Raw]");
  const std::string blender_config = (bdir / "config.ocio").string();
  const std::string plain_config = (dir_ / "plain.ocio").string();
  std::ofstream(blender_config) << text;
  std::ofstream(plain_config) << text;

  gp::DisplayOptions opts;
  opts.config_path = blender_config;
  EXPECT_EQ(gp::describe_display(opts), "OCIO " + blender_config + ", display sRGB, view Filmic");
  gp::write_png(path("filmic.png"), make_grey_row({0.5f}), "combined", opts);
  EXPECT_EQ(read_png(path("filmic.png")).px(0, 0)[0], 128);  // our stand-in "Filmic" is the identity
  opts.config_path = plain_config;
  EXPECT_EQ(gp::describe_display(opts), "OCIO " + plain_config + ", display sRGB, view Standard");
}

TEST_F(IoTest, RealBlenderConfigIfInstalled) {
  ScopedEnv env("OCIO", nullptr);
  const std::string d = gp::describe_display({});
  if (d == "built-in sRGB") GTEST_SKIP() << "Blender's OCIO config is not installed";
  const gp::Film film = make_grey_row({0, 0.18f, 1, kNaN});
  gp::DisplayOptions opts;
  opts.view = "Standard";
  auto px = gp::to_display_rgb8(film, "combined", opts);
  EXPECT_EQ(px[0], 0);
  EXPECT_NEAR(px[3], 118, 1);
  EXPECT_EQ(px[6], 255);
  EXPECT_EQ(px[9], 0);
  opts.view = "Filmic";  // Filmic puts scene middle grey near display 0.5
  px = gp::to_display_rgb8(film, "combined", opts);
  EXPECT_NEAR(px[3], 128, 3);
  EXPECT_LT(px[6], 230);  // Filmic compresses highlights: 1.0 is not white
  EXPECT_EQ(px[9], 0);
}

TEST_F(IoTest, FalseColorPng) {
  const std::vector<float> values = {0, 0.5f, 1, 7, kNaN, -1};
  const std::string file = path("false.png");
  gp::write_false_color_png(file, values, 3, 2, 1.0f);
  const Png png = read_png(file);
  ASSERT_EQ(png.width, 3);
  ASSERT_EQ(png.height, 2);
  auto eq = [](const uint8_t* p, int r, int g, int b) { return p[0] == r && p[1] == g && p[2] == b; };
  EXPECT_TRUE(eq(png.px(0, 0), 0x44, 0x01, 0x54));  // viridis low end
  EXPECT_TRUE(eq(png.px(1, 0), 0x21, 0x90, 0x8C));  // middle
  EXPECT_TRUE(eq(png.px(2, 0), 0xFD, 0xE7, 0x25));  // top
  EXPECT_TRUE(eq(png.px(0, 1), 0xFD, 0xE7, 0x25));  // clamped above vmax
  EXPECT_TRUE(eq(png.px(1, 1), 255, 0, 255));       // non-finite: magenta
  EXPECT_TRUE(eq(png.px(2, 1), 0x44, 0x01, 0x54));  // clamped below 0
  EXPECT_THROW(gp::write_false_color_png(file, values, 4, 2, 1.0f), std::invalid_argument);
}

// ================================ metrics ================================

TEST(IoMetrics, ScalarByHand) {
  // 2x1 scalar: A = {1, 3}, R = {1, 2}.
  gp::Pass a{1, {1, 3}}, r{1, {1, 2}};
  const gp::DiffResult d = gp::diff_images(a, r, 2, 1);
  // relMSE = (0 / (1 + 0.001) + 1 / (4 + 0.001)) / 2
  EXPECT_NEAR(d.rel_mse, 0.5 / 4.001, 1e-12);
  EXPECT_NEAR(d.rmse, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(d.mean_ratio, 4.0 / 3.0, 1e-12);
  EXPECT_EQ(d.pixels, 2u);
  EXPECT_EQ(d.nonfinite, 0u);
  ASSERT_EQ(d.per_pixel_rel_se.size(), 2u);
  EXPECT_FLOAT_EQ(d.per_pixel_rel_se[0], 0.0f);
  EXPECT_FLOAT_EQ(d.per_pixel_rel_se[1], float(1.0 / 4.001));
}

TEST(IoMetrics, RgbByHand) {
  // 1x2 RGB: pixel 0 A = (0.5, 1, 0), R = (1, 1, 0); pixel 1 A = (2, 2, 2), R = (1, 1, 1).
  gp::Pass a{3, {0.5f, 1, 0, 2, 2, 2}}, r{3, {1, 1, 0, 1, 1, 1}};
  const gp::DiffResult d = gp::diff_images(a, r, 1, 2);
  const double p0 = 0.25 / 1.001;      // only the red channel differs
  const double p1 = 3.0 * 1.0 / 1.001;
  EXPECT_NEAR(d.rel_mse, (p0 + p1) / 6.0, 1e-12);
  EXPECT_NEAR(d.rmse, std::sqrt((0.25 + 3.0) / 6.0), 1e-12);
  EXPECT_NEAR(d.mean_ratio, 7.5 / 5.0, 1e-12);
  EXPECT_NEAR(d.per_pixel_rel_se[0], p0 / 3.0, 1e-7);
  EXPECT_NEAR(d.per_pixel_rel_se[1], p1 / 3.0, 1e-7);
  // Identical images: zero error, ratio 1.
  const gp::DiffResult same = gp::diff_images(r, r, 1, 2);
  EXPECT_EQ(same.rel_mse, 0.0);
  EXPECT_EQ(same.rmse, 0.0);
  EXPECT_EQ(same.mean_ratio, 1.0);
}

TEST(IoMetrics, NonFiniteCountedAndExcluded) {
  gp::Pass a{1, {kNaN, 2, kInf}}, r{1, {1, 1, 1}};
  const gp::DiffResult d = gp::diff_images(a, r, 3, 1);
  EXPECT_EQ(d.pixels, 3u);
  EXPECT_EQ(d.nonfinite, 2u);
  EXPECT_NEAR(d.rel_mse, 1.0 / 1.001, 1e-12);
  EXPECT_NEAR(d.rmse, 1.0, 1e-12);
  EXPECT_NEAR(d.mean_ratio, 2.0, 1e-12);
  EXPECT_TRUE(std::isinf(d.per_pixel_rel_se[0]));
  EXPECT_TRUE(std::isfinite(d.per_pixel_rel_se[1]));
  EXPECT_TRUE(std::isinf(d.per_pixel_rel_se[2]));
}

TEST(IoMetrics, MismatchThrows) {
  gp::Pass rgb{3, std::vector<float>(12, 1.0f)}, grey{1, std::vector<float>(4, 1.0f)};
  EXPECT_THROW(gp::diff_images(rgb, grey, 2, 2), std::invalid_argument);
  EXPECT_THROW(gp::diff_images(rgb, rgb, 3, 2), std::invalid_argument);  // 12 values, not 18
  gp::Pass short_rgb{3, std::vector<float>(9, 1.0f)};
  try {
    gp::diff_images(short_rgb, rgb, 2, 2);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("size mismatch"), std::string::npos) << e.what();
  }
}
