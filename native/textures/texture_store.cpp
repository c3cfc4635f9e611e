#include "textures/texture_store.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>

#include "io/ocio_config.h"

namespace OCIO = OCIO_NAMESPACE;
namespace fs = std::filesystem;

namespace gp {

namespace {

// ---- Colour spaces ----

OCIO::ConstConfigRcPtr ocio_config() {
  static const OCIO::ConstConfigRcPtr config = []() -> OCIO::ConstConfigRcPtr {
    const std::string path = default_ocio_config();
    if (path.empty()) return nullptr;
    try {
      return OCIO::Config::CreateFromFile(path.c_str());
    } catch (const std::exception&) {
      return nullptr;  // the built-in fallback below
    }
  }();
  return config;
}

bool is_linear_rec709(const std::string& cs) {
  return cs == "Linear" || cs == "Linear Rec.709" || cs == "scene_linear" || cs == "linear";
}

// ---- The shared store ----

struct Key {
  std::string path, colorspace;
  fs::file_time_type mtime;
  uintmax_t size;
  bool operator<(const Key& o) const {
    return std::tie(path, colorspace, mtime, size) < std::tie(o.path, o.colorspace, o.mtime, o.size);
  }
};

std::mutex g_store_mutex;
std::map<Key, std::weak_ptr<const TextureImage>> g_store;

std::shared_ptr<const TextureImage> magenta(const std::string& path) {
  auto img = std::make_shared<TextureImage>();
  img->path = path;
  img->width = img->height = 1;
  img->rgba = {1.0f, 0.0f, 1.0f, 1.0f};
  img->mean = {RGB(1, 0, 1), 1.0f};
  img->missing = true;
  return img;
}

// Reads the file into float RGBA, bottom row first. Throws std::runtime_error.
std::shared_ptr<TextureImage> read_image(const std::string& path, bool* is_float, bool* is_byte) {
  OIIO::ImageSpec hints;
  hints.attribute("oiio:UnassociatedAlpha", 1);  // colours as stored (Blender's "Straight" alpha)
  auto in = OIIO::ImageInput::open(path, &hints);
  if (!in) throw std::runtime_error(OIIO::geterror());
  const OIIO::ImageSpec& spec = in->spec();
  const int w = spec.width, h = spec.height, nc = spec.nchannels;
  if (w <= 0 || h <= 0 || nc <= 0) throw std::runtime_error("empty image");
  if (static_cast<double>(w) * h > 1 << 28) throw std::runtime_error(fmt::format("image too large ({} x {})", w, h));
  *is_float = spec.format.is_floating_point();
  *is_byte = spec.format == OIIO::TypeDesc::UINT8;
  std::vector<float> pixels(static_cast<size_t>(w) * h * nc);
  if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, pixels.data())) throw std::runtime_error(in->geterror());
  auto img = std::make_shared<TextureImage>();
  img->path = path;
  img->width = w;
  img->height = h;
  img->rgba.resize(static_cast<size_t>(w) * h * 4);
  // Grey (1 or 2 channels) spreads to RGB; a second channel of grey, or a fourth, is alpha.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float* s = &pixels[(static_cast<size_t>(h - 1 - y) * w + x) * nc];
      float* d = &img->rgba[(static_cast<size_t>(y) * w + x) * 4];
      const bool grey = nc < 3;
      for (int c = 0; c < 3; ++c) d[c] = grey ? s[0] : s[c];
      d[3] = nc == 2 ? s[1] : (nc >= 4 ? s[3] : 1.0f);
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(d[c])) d[c] = 0.0f;  // NaN/Inf in a file never reaches a pass
    }
  return img;
}

}  // namespace

bool is_data_colorspace(const std::string& cs) { return cs == "Non-Color" || cs == "Raw" || cs == "data"; }

void convert_to_scene_linear(std::vector<float>& rgba, const std::string& colorspace) {
  if (is_data_colorspace(colorspace) || rgba.empty()) return;
  if (auto config = ocio_config()) {
    if (!config->getColorSpace(colorspace.c_str()))
      throw std::runtime_error(fmt::format("unknown colour space '{}'", colorspace));
    auto proc = config->getProcessor(colorspace.c_str(), OCIO::ROLE_SCENE_LINEAR);
    OCIO::PackedImageDesc desc(rgba.data(), static_cast<long>(rgba.size() / 4), 1, 4);
    proc->getDefaultCPUProcessor()->apply(desc);
    return;
  }
  if (is_linear_rec709(colorspace)) return;
  if (colorspace != "sRGB") throw std::runtime_error(fmt::format("unknown colour space '{}' (no OCIO config)", colorspace));
  for (size_t i = 0; i < rgba.size(); i += 4)
    for (int c = 0; c < 3; ++c) rgba[i + c] = srgb_eotf(rgba[i + c]);
}

TextureLoad load_texture(const std::string& path, const std::string& colorspace) {
  std::error_code ec;
  const fs::path abs = fs::weakly_canonical(fs::absolute(path, ec), ec);
  Key key{abs.string(), colorspace, fs::last_write_time(abs, ec), 0};
  key.size = ec ? 0 : fs::file_size(abs, ec);
  if (ec || !fs::is_regular_file(abs, ec))
    return {magenta(path), fmt::format("image texture '{}' not found (rendered magenta)", path)};
  std::lock_guard lock(g_store_mutex);  // one reader per file: concurrent loads wait, then share
  if (auto it = g_store.find(key); it != g_store.end())
    if (auto shared = it->second.lock()) return {shared, ""};
  TextureLoad out;
  bool is_float = false, is_byte = false;
  std::shared_ptr<TextureImage> img;
  try {
    img = read_image(abs.string(), &is_float, &is_byte);
  } catch (const std::exception& e) {
    return {magenta(path), fmt::format("image texture '{}' cannot be read ({}; rendered magenta)", path, e.what())};
  }
  std::string cs = colorspace.empty() ? (is_float ? "Linear" : "sRGB") : colorspace;
  try {
    if (is_byte && cs == "sRGB") img->srgb_encoded = true;  // decoded after filtering (lookup)
    else convert_to_scene_linear(img->rgba, cs);
  } catch (const std::exception& e) {
    cs = is_float ? "Linear" : "sRGB";
    out.warning = fmt::format("image texture '{}': {}, read as {}", path, e.what(), cs);
    convert_to_scene_linear(img->rgba, cs);
  }
  img->colorspace = cs;
  double sum[4] = {0, 0, 0, 0};
  for (size_t i = 0; i < img->rgba.size(); ++i) sum[i % 4] += img->srgb_encoded && i % 4 != 3 ? srgb_eotf(img->rgba[i]) : img->rgba[i];
  const double n = static_cast<double>(img->width) * img->height;
  img->mean = {RGB(float(sum[0] / n), float(sum[1] / n), float(sum[2] / n)), float(sum[3] / n)};
  for (auto it = g_store.begin(); it != g_store.end();) it = it->second.expired() ? g_store.erase(it) : std::next(it);
  out.image = img;
  g_store[key] = out.image;
  return out;
}

size_t texture_store_size() {
  std::lock_guard lock(g_store_mutex);
  size_t n = 0;
  for (const auto& [k, v] : g_store) n += !v.expired();
  return n;
}

}  // namespace gp
