#include "io/display.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include <OpenColorIO/OpenColorIO.h>
#include <png.h>

#include "io/ocio_config.h"

namespace OCIO = OCIO_NAMESPACE;
namespace fs = std::filesystem;

namespace gp {

namespace {

// The resolved display pipeline.
struct Resolved {
  std::string config_path;  // empty = built-in sRGB
  OCIO::ConstConfigRcPtr config;
  std::string source, display, view;
};

Resolved resolve(const DisplayOptions& opts) {
  Resolved r;
  std::string path = opts.config_path;
  bool blender = false;
  if (path == "builtin") return r;
  if (path.empty()) {
    const char* env = std::getenv("OCIO");
    if (env && *env) {
      path = env;
    } else {
      path = find_blender_config();
      blender = !path.empty();
    }
  }
  if (path.empty()) return r;  // built-in
  blender = blender || looks_like_blender(path);

  try {
    r.config = OCIO::Config::CreateFromFile(path.c_str());
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot load OCIO config '" + path + "': " + e.what());
  }
  r.config_path = path;
  const auto& cfg = r.config;

  for (const char* role : {OCIO::ROLE_SCENE_LINEAR, OCIO::ROLE_DEFAULT}) {
    if (auto cs = cfg->getColorSpace(role)) { r.source = cs->getName(); break; }
  }
  if (r.source.empty())
    throw std::runtime_error("OCIO config '" + path + "' has neither a scene_linear nor a default role");

  r.display = opts.display.empty() ? std::string(cfg->getDefaultDisplay()) : opts.display;
  const int nviews = cfg->getNumViews(r.display.c_str());
  if (r.display.empty() || nviews <= 0)
    throw std::runtime_error("OCIO config '" + path + "' has no display '" + r.display + "' with views");
  std::vector<std::string> views;
  for (int i = 0; i < nviews; ++i) views.emplace_back(cfg->getView(r.display.c_str(), i));
  auto has_view = [&](const std::string& v) { return std::find(views.begin(), views.end(), v) != views.end(); };

  if (!opts.view.empty()) {
    if (!has_view(opts.view)) {
      std::string list;
      for (const auto& v : views) list += (list.empty() ? "" : ", ") + v;
      throw std::runtime_error("OCIO config '" + path + "': display '" + r.display + "' has no view '" +
                               opts.view + "' (views: " + list + ")");
    }
    r.view = opts.view;
  } else if (blender && has_view("Filmic")) {
    r.view = "Filmic";
  } else if (blender && has_view("Standard")) {
    r.view = "Standard";
  } else {
    r.view = cfg->getDefaultView(r.display.c_str());
  }
  return r;
}

float srgb_oetf(float v) {
  if (!(v > 0.0f)) return 0.0f;  // also NaN
  if (v >= 1.0f) return 1.0f;
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

uint8_t quantise(float v) {
  if (!std::isfinite(v) || v <= 0.0f) return 0;
  if (v >= 1.0f) return 255;
  return static_cast<uint8_t>(std::lround(v * 255.0f));
}

}  // namespace

std::string describe_display(const DisplayOptions& opts) {
  const Resolved r = resolve(opts);
  if (r.config_path.empty()) return "built-in sRGB";
  return "OCIO " + r.config_path + ", display " + r.display + ", view " + r.view;
}

std::vector<uint8_t> to_display_rgb8(const Film& film, std::string_view pass_name, const DisplayOptions& opts) {
  const Pass& p = film.pass(pass_name);
  const size_t n = film.pixel_count();
  if ((p.channels != 1 && p.channels != 3) || p.data.size() != n * p.channels)
    throw std::invalid_argument("pass '" + std::string(pass_name) + "' does not match the film size");
  if (!std::isfinite(opts.exposure)) throw std::invalid_argument("exposure must be finite");

  const float scale = std::exp2(opts.exposure);
  std::vector<float> rgb(n * 3);
  for (size_t i = 0; i < n; ++i) {
    float c[3];
    if (p.channels == 1) c[0] = c[1] = c[2] = p.data[i];
    else for (int k = 0; k < 3; ++k) c[k] = p.data[i * 3 + k];
    const bool finite = std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]);
    for (int k = 0; k < 3; ++k) {
      const float v = finite ? c[k] * scale : 0.0f;
      rgb[i * 3 + k] = std::isfinite(v) ? v : 0.0f;  // scale may overflow to inf
    }
  }

  const Resolved r = resolve(opts);
  std::vector<uint8_t> out(n * 3);
  if (r.config_path.empty()) {
    for (size_t i = 0; i < n * 3; ++i) out[i] = quantise(srgb_oetf(rgb[i]));
    return out;
  }
  if (n > 0) {
    try {
      auto t = OCIO::DisplayViewTransform::Create();
      t->setSrc(r.source.c_str());
      t->setDisplay(r.display.c_str());
      t->setView(r.view.c_str());
      auto proc = r.config->getProcessor(t);
      auto cpu = proc->getDefaultCPUProcessor();
      OCIO::PackedImageDesc img(rgb.data(), film.width(), film.height(), 3);
      cpu->apply(img);
    } catch (const std::exception& e) {
      throw std::runtime_error("OCIO display transform failed (config '" + r.config_path + "', display '" +
                               r.display + "', view '" + r.view + "'): " + e.what());
    }
  }
  for (size_t i = 0; i < n; ++i) {
    // A non-finite result anywhere in the pixel (or a non-finite input, zeroed above) gives black.
    const bool finite = std::isfinite(rgb[i * 3]) && std::isfinite(rgb[i * 3 + 1]) && std::isfinite(rgb[i * 3 + 2]);
    for (int k = 0; k < 3; ++k) out[i * 3 + k] = finite ? quantise(rgb[i * 3 + k]) : 0;
  }
  // Input NaN/Inf pixels are written as 0 even when the view maps black to something else.
  for (size_t i = 0; i < n; ++i) {
    bool finite = true;
    for (int k = 0; k < p.channels; ++k) finite = finite && std::isfinite(p.data[i * p.channels + k]);
    if (!finite) out[i * 3] = out[i * 3 + 1] = out[i * 3 + 2] = 0;
  }
  return out;
}

void write_png_rgb8(const std::string& path, const std::vector<uint8_t>& rgb, int width, int height) {
  if (width <= 0 || height <= 0)
    throw std::invalid_argument("cannot write PNG '" + path + "': empty image");
  if (rgb.size() != size_t(width) * size_t(height) * 3)
    throw std::invalid_argument("cannot write PNG '" + path + "': buffer size does not match " +
                                std::to_string(width) + "x" + std::to_string(height));
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  const int ok = png_image_write_to_file(&image, path.c_str(), 0, rgb.data(), width * 3, nullptr);
  const std::string msg = image.message;
  png_image_free(&image);
  if (!ok || PNG_IMAGE_FAILED(image)) throw std::runtime_error("cannot write PNG '" + path + "': " + msg);
}

void write_png(const std::string& path, const Film& film, std::string_view pass_name, const DisplayOptions& opts) {
  if (!film.has_pass(pass_name))
    throw std::invalid_argument("cannot write PNG '" + path + "': film has no pass '" + std::string(pass_name) + "'");
  write_png_rgb8(path, to_display_rgb8(film, pass_name, opts), film.width(), film.height());
}

void write_false_color_png(const std::string& path, const std::vector<float>& values, int width, int height,
                           float vmax) {
  if (width <= 0 || height <= 0 || values.size() != size_t(width) * size_t(height))
    throw std::invalid_argument("cannot write false-colour PNG '" + path + "': " + std::to_string(values.size()) +
                                " values for " + std::to_string(width) + "x" + std::to_string(height));
  if (!(vmax > 0.0f) || !std::isfinite(vmax)) {
    vmax = 0.0f;
    for (float v : values) if (std::isfinite(v)) vmax = std::max(vmax, v);
    if (!(vmax > 0.0f)) vmax = 1.0f;
  }
  // Viridis at 9 evenly spaced points (viridisLite::viridis(9)), linearly interpolated.
  static const uint8_t kMap[9][3] = {{0x44, 0x01, 0x54}, {0x47, 0x2D, 0x7B}, {0x3B, 0x52, 0x8B},
                                     {0x2C, 0x72, 0x8E}, {0x21, 0x90, 0x8C}, {0x27, 0xAD, 0x81},
                                     {0x5D, 0xC8, 0x63}, {0xAA, 0xDC, 0x32}, {0xFD, 0xE7, 0x25}};
  std::vector<uint8_t> rgb(values.size() * 3);
  for (size_t i = 0; i < values.size(); ++i) {
    uint8_t* o = &rgb[i * 3];
    const float v = values[i];
    if (!std::isfinite(v)) { o[0] = 255; o[1] = 0; o[2] = 255; continue; }  // magenta
    const float t = std::clamp(v / vmax, 0.0f, 1.0f) * 8.0f;
    const int k = std::min(static_cast<int>(t), 7);
    const float f = t - static_cast<float>(k);
    for (int c = 0; c < 3; ++c)
      o[c] = static_cast<uint8_t>(std::lround(kMap[k][c] + (float(kMap[k + 1][c]) - float(kMap[k][c])) * f));
  }
  write_png_rgb8(path, rgb, width, height);
}

}  // namespace gp
