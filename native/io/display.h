// Display images (8-bit sRGB PNG previews) through OpenColorIO, with a built-in sRGB fallback.
//
// Config resolution (DisplayOptions::config_path empty = auto):
//   1. the OCIO environment variable, if set and non-empty;
//   2. Blender's config: /usr/share/blender/<version>/datafiles/colormanagement/config.ocio
//      or /usr/share/blender/datafiles/colormanagement/config.ocio (newest version first);
//   3. the built-in transform: scene-linear Rec.709 -> sRGB OETF, clamp, 8-bit.
// config_path == "builtin" forces the built-in transform; any other non-empty value is a
// config file to load. With OCIO the source space is the config's scene_linear role (or its
// default role if it has none), transformed with a DisplayViewTransform to the chosen display
// and view. Empty view = the config's default view for the display, except for Blender's
// config (found in /usr/share/blender, or any path containing "datafiles/colormanagement/")
// where the default is "Filmic" if present, else "Standard".
//
// Exposure (stops) scales the linear values by 2^exposure before the transform. Scalar passes
// are shown as grey. Non-finite pixels are written as 0 (black). Failures throw
// std::runtime_error (naming the file / config) or std::invalid_argument for bad arguments.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/film.h"

namespace gp {

struct DisplayOptions {
  std::string config_path;  // empty = auto; "builtin" = built-in sRGB; else a config.ocio path
  std::string view;         // empty = default (Blender's config: "Filmic" if present, else "Standard")
  float exposure = 0;       // stops
  std::string display;      // empty = the config's default display
};

// What write_png would use, e.g. "OCIO /path/config.ocio, display sRGB, view Filmic" or
// "built-in sRGB". Throws like write_png when the config cannot be loaded.
std::string describe_display(const DisplayOptions& opts = {});

// The pass turned into display-referred 8-bit RGB, row-major, row 0 at the top
// (width * height * 3 bytes). Used by write_png; handy for previews elsewhere.
std::vector<uint8_t> to_display_rgb8(const Film& film, std::string_view pass = "combined",
                                     const DisplayOptions& opts = {});

void write_png(const std::string& path, const Film& film, std::string_view pass = "combined",
               const DisplayOptions& opts = {});

// False-colour image of non-negative values (e.g. per-pixel relative squared error):
// viridis-like map of clamp(v / vmax, 0, 1); vmax <= 0 or non-finite = the largest finite value.
// Non-finite values are shown in magenta. values.size() must be width * height.
void write_false_color_png(const std::string& path, const std::vector<float>& values, int width,
                           int height, float vmax);

// Writes 8-bit RGB rows (width * height * 3, row 0 at the top) to a PNG with libpng.
void write_png_rgb8(const std::string& path, const std::vector<uint8_t>& rgb, int width, int height);

}  // namespace gp
