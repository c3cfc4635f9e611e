#include "io/exr.h"

#include <algorithm>
#include <exception>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include <ImathBox.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include "core/memory.h"

namespace gp {

namespace {

[[noreturn]] void fail(const std::string& what, const std::string& path, const std::string& why) {
  throw std::runtime_error(what + " '" + path + "': " + why);
}

// Splits "a.b.R" into {"a.b", "R"}; "R" into {"", "R"}.
std::pair<std::string, std::string> split_channel(const std::string& name) {
  const auto dot = name.rfind('.');
  if (dot == std::string::npos) return {"", name};
  return {name.substr(0, dot), name.substr(dot + 1)};
}

}  // namespace

void write_exr(const std::string& path, const Film& film, const std::map<std::string, std::string>& attributes) {
  const int w = film.width(), h = film.height();
  if (w <= 0 || h <= 0) fail("cannot write EXR", path, "film is empty (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  if (film.passes().empty()) fail("cannot write EXR", path, "film has no passes");

  static const char* kRGB[3] = {"R", "G", "B"};
  try {
    Imf::Header header(w, h);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.lineOrder() = Imf::INCREASING_Y;
    header.insert("software", Imf::StringAttribute("gradphoton"));
    for (const auto& [name, value] : attributes) header.insert(name, Imf::StringAttribute(value));
    Imf::FrameBuffer fb;
    for (const auto& [name, pass] : film.passes()) {
      const size_t expected = film.pixel_count() * static_cast<size_t>(pass.channels);
      if ((pass.channels != 1 && pass.channels != 3) || pass.data.size() != expected)
        fail("cannot write EXR", path,
             "pass '" + name + "' has " + std::to_string(pass.data.size()) + " values for " +
                 std::to_string(pass.channels) + " channels, expected " + std::to_string(expected));
      const size_t xs = sizeof(float) * pass.channels;
      const size_t ys = xs * static_cast<size_t>(w);
      // OpenEXR's FrameBuffer wants non-const pointers but only reads when writing.
      char* base = reinterpret_cast<char*>(const_cast<float*>(pass.data.data()));
      for (int c = 0; c < pass.channels; ++c) {
        const std::string ch = name + "." + (pass.channels == 1 ? std::string("V") : std::string(kRGB[c]));
        header.channels().insert(ch, Imf::Channel(Imf::FLOAT));
        fb.insert(ch, Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
      }
    }
    Imf::OutputFile out(path.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(h);
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    if (msg.find(path) != std::string::npos) throw;
    fail("cannot write EXR", path, msg);
  } catch (const std::exception& e) {
    fail("cannot write EXR", path, e.what());
  }
}

namespace {

constexpr int64_t kMaxSide = int64_t(1) << 20;

// The film an EXR becomes holds every channel as a float; a few header bytes can ask for
// terabytes (found by fuzz_exr), so the size is checked against the memory budget first.
void check_film_size(const std::string& path, int64_t w, int64_t h, int64_t channels) {
  const double bytes = double(w) * double(h) * sizeof(float) * double(std::max<int64_t>(1, channels));
  if (const double budget = memory_budget_bytes(); budget > 0 && bytes > budget)
    fail("cannot read EXR", path,
         fmt::format("{}x{} pixels with their channels need {:.2f} GB, more than the {:.2f} GB available "
                     "(GRADPHOTON_MEMORY_LIMIT_MB sets the limit)", w, h, bytes / 1e9, budget / 1e9));
}

// OpenEXR allocates an attribute's value at the size its header claims before reading it, so
// a 1 kB file claiming a 2 GB string takes 2 GB (found by fuzz_exr). The header is walked here
// first, the way OpenEXR 3.1 reads it (Header::readFrom: fixed-size types read their size
// whatever the header claims, a channel list is parsed, strings, vectors, unknown types and
// preview images read what they claim): what is read must fit in the file. Anything else
// malformed is left to OpenEXR's own, clear errors.
void check_header_sizes(const std::string& path, uintmax_t file_size) {
  static const std::map<std::string, int64_t> kFixed = {
      {"box2i", 16}, {"box2f", 16}, {"chromaticities", 32}, {"compression", 1}, {"double", 8}, {"envmap", 1},
      {"float", 4}, {"int", 4}, {"keycode", 28}, {"lineOrder", 1}, {"m33f", 36}, {"m33d", 72}, {"m44f", 64},
      {"m44d", 128}, {"rational", 8}, {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8}, {"v2f", 8}, {"v2d", 16},
      {"v3i", 12}, {"v3f", 12}, {"v3d", 24}, {"deepImageState", 1}};
  std::ifstream in(path, std::ios::binary);
  char magic[8];
  if (!in.read(magic, 8)) return;
  if (!(magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01)) return;  // OpenEXR says why
  auto read_string = [&](std::string& out) {
    out.clear();
    for (char c; in.get(c);) {
      if (c == 0) return true;
      if (out.size() >= 256) return false;
      out += c;
    }
    return false;
  };
  auto read_int = [&](int64_t& v) {
    unsigned char b[4];
    if (!in.read(reinterpret_cast<char*>(b), 4)) return false;
    v = int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
    return true;
  };
  auto check = [&](const std::string& name, int64_t bytes) {
    const int64_t at = static_cast<int64_t>(in.tellg());
    if (bytes < 0 || at < 0 || bytes > static_cast<int64_t>(file_size) - at)  // no at + bytes: it may overflow
      fail("cannot read EXR", path,
           fmt::format("header attribute '{}' needs {} bytes but the file ends {} bytes later (truncated or corrupt)",
                       name, bytes, static_cast<int64_t>(file_size) - at));
    in.seekg(bytes, std::ios::cur);
  };
  std::string name, type, channel;
  int64_t channels = 0, height = 0;
  int compression = -1;
  bool tiled = (static_cast<unsigned char>(magic[5]) & 0x02) != 0, multipart = (static_cast<unsigned char>(magic[6]) & 0x10) != 0;
  bool ended = false;
  while (read_string(name)) {
    if (name.empty()) {
      ended = true;
      break;
    }
    int64_t size = 0;
    if (!read_string(type) || !read_int(size)) return;
    if (name == "dataWindow" && type == "box2i") {
      // OpenEXR sizes its line buffers by the data window as it opens the file (a 345-byte
      // file took 12 s under ASan in fuzz_exr): refuse an impossible one before that.
      int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
      if (!read_int(x0) || !read_int(y0) || !read_int(x1) || !read_int(y1)) return;
      const int64_t w = x1 - x0 + 1, h = y1 - y0 + 1;
      if (w <= 0 || h <= 0 || w > kMaxSide || h > kMaxSide)
        fail("cannot read EXR", path, fmt::format("bad data window ({}x{} pixels)", w, h));
      check_film_size(path, w, h, channels);
      height = h;
    } else if (name == "compression" && type == "compression") {
      char c = 0;
      if (!in.get(c)) return;
      compression = static_cast<unsigned char>(c);
    } else if (auto f = kFixed.find(type); f != kFixed.end()) {
      check(name, f->second);
    } else if (type == "chlist") {
      while (read_string(channel) && !channel.empty()) {
        check(name, 16);
        ++channels;
      }
    } else if (type == "preview") {
      int64_t w = 0, h = 0;
      if (!read_int(w) || !read_int(h)) return;
      // 4 bytes per pixel; w * h < 2^62 (both int32), but 4 w h may not fit an int64 (fuzz_exr).
      check(name, w < 0 || h < 0 ? -1 : w * h > INT64_MAX / 4 ? INT64_MAX : 4 * w * h);
    } else {
      check(name, size);  // string, stringvector, floatvector and unknown (opaque) types
    }
    if (!in) return;
    if (name == "tiles") tiled = true;
  }
  // A scanline file's offset table (8 bytes per chunk of 1 to 256 lines, by compression) comes
  // right after the header: a file too short for it is truncated, and is refused before a
  // film of its data window is allocated (a 760-byte file asking for 256 MB, fuzz_exr).
  static const int kLinesPerChunk[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};  // NONE .. DWAB
  if (ended && !tiled && !multipart && height > 0 && compression >= 0 && compression < 10) {
    const int64_t chunks = (height + kLinesPerChunk[compression] - 1) / kLinesPerChunk[compression];
    const int64_t at = static_cast<int64_t>(in.tellg());
    if (at >= 0 && at + 8 * chunks > static_cast<int64_t>(file_size))
      fail("cannot read EXR", path,
           fmt::format("{} scanlines need an offset table of {} bytes but the file ends {} bytes after the header "
                       "(truncated or corrupt)", height, 8 * chunks, static_cast<int64_t>(file_size) - at));
  }
}

void check_readable(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail("cannot read EXR", path, "no such file");
  if (std::filesystem::is_directory(path, ec)) fail("cannot read EXR", path, "is a directory");
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec) check_header_sizes(path, size);
}

}  // namespace

std::map<std::string, std::string> read_exr_attributes(const std::string& path) {
  check_readable(path);
  try {
    Imf::InputFile in(path.c_str());
    std::map<std::string, std::string> out;
    for (auto it = in.header().begin(); it != in.header().end(); ++it)
      if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) out[it.name()] = s->value();
    return out;
  } catch (const std::exception& e) {
    fail("cannot read EXR", path, e.what());
  }
}

Film read_exr(const std::string& path) {
  check_readable(path);
  try {
    Imf::InputFile in(path.c_str());
    const Imf::Header& header = in.header();
    const Imath::Box2i dw = header.dataWindow();
    const int64_t w64 = int64_t(dw.max.x) - dw.min.x + 1, h64 = int64_t(dw.max.y) - dw.min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > kMaxSide || h64 > kMaxSide)
      fail("cannot read EXR", path, "bad data window");
    const int w = int(w64), h = int(h64);
    size_t channels = 0;
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) ++channels;
    check_film_size(path, w, h, static_cast<int64_t>(channels));

    // Group channels into layers by the prefix before the last '.'.
    std::map<std::string, std::vector<std::string>> layers;  // layer -> suffixes
    for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
      const Imf::Channel& ch = it.channel();
      if (ch.xSampling != 1 || ch.ySampling != 1)
        fail("cannot read EXR", path, std::string("subsampled channel '") + it.name() + "' is not supported");
      auto [layer, suffix] = split_channel(it.name());
      layers[layer].push_back(suffix);
    }
    if (layers.empty()) fail("cannot read EXR", path, "no channels");

    // Decide which pass every channel goes to: (pass name, channels, channel index).
    struct Target { std::string pass; int channels; int index; };
    std::map<std::string, Target> targets;  // full channel name -> target
    auto full = [](const std::string& layer, const std::string& s) {
      return layer.empty() ? s : layer + "." + s;
    };
    for (const auto& entry : layers) {
      // Not a structured binding: clang 14 (the fuzz build) cannot capture one in a lambda.
      const std::string& layer = entry.first;
      const std::vector<std::string>& suffixes = entry.second;
      auto has = [&](const char* s) { return std::find(suffixes.begin(), suffixes.end(), s) != suffixes.end(); };
      const std::string layer_pass = layer.empty() ? std::string(pass::kCombined) : layer;
      std::vector<std::string> used;
      const char* const* triple = nullptr;
      static const char* kRGB[3] = {"R", "G", "B"};
      static const char* kXYZ[3] = {"X", "Y", "Z"};
      if (has("R") && has("G") && has("B")) triple = kRGB;
      else if (has("X") && has("Y") && has("Z")) triple = kXYZ;
      if (triple) {
        for (int c = 0; c < 3; ++c) {
          targets[full(layer, triple[c])] = {layer_pass, 3, c};
          used.push_back(triple[c]);
        }
      } else if (suffixes.size() == 1) {
        targets[full(layer, suffixes[0])] = {layer.empty() ? suffixes[0] : layer, 1, 0};
        continue;
      }
      for (const auto& s : suffixes)
        if (std::find(used.begin(), used.end(), s) == used.end())
          targets[full(layer, s)] = {full(layer, s), 1, 0};
    }

    Film film(w, h);
    Imf::FrameBuffer fb;
    for (const auto& [chname, t] : targets) {
      if (film.has_pass(t.pass) && film.pass(t.pass).channels != t.channels)
        fail("cannot read EXR", path, "channel '" + chname + "' clashes with pass '" + t.pass + "'");
      Pass& p = film.add_pass(t.pass, t.channels);
      const size_t xs = sizeof(float) * t.channels;
      fb.insert(chname, Imf::Slice::Make(Imf::FLOAT, p.data.data() + t.index, dw, xs, xs * size_t(w)));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return film;
  } catch (const std::runtime_error& e) {
    const std::string msg = e.what();
    if (msg.find(path) != std::string::npos) throw;
    fail("cannot read EXR", path, msg);
  } catch (const std::exception& e) {
    fail("cannot read EXR", path, e.what());
  }
}

}  // namespace gp
