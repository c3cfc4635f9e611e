// Loading image textures: each file is read once through OpenImageIO, converted to float RGBA
// in scene-linear Rec.709 through OpenColorIO (Blender's config, so "sRGB", "Non-Color",
// "Linear", ... mean what Blender's colour-space menu means), and shared by every material,
// and every scene alive at the time, that uses the same file in the same colour space.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "textures/texture.h"

namespace gp {

struct TextureLoad {
  std::shared_ptr<const TextureImage> image;  // never null: a missing file gives magenta
  std::string warning;                        // non-empty when something was approximated
};

// Loads (or shares) `path` in `colorspace` (a colour space of the OCIO config; "" = Blender's
// default: sRGB for 8- and 16-bit integer files, Linear for float files). A file that cannot be
// read is a 1 x 1 magenta image with missing = true and a warning, as Cycles renders it; an
// unknown colour space falls back to the default with a warning.
TextureLoad load_texture(const std::string& path, const std::string& colorspace);

// Converts RGBA pixels (alpha untouched) from `colorspace` to scene-linear Rec.709 in place.
// Data spaces ("Non-Color", "Raw") are left as they are. Throws std::runtime_error for a colour
// space the config does not know. Without any OCIO config, sRGB is decoded by its standard
// curve and the linear spaces pass through.
void convert_to_scene_linear(std::vector<float>& rgba, const std::string& colorspace);

// True for colour spaces whose values are data, never converted.
bool is_data_colorspace(const std::string& colorspace);

// Number of decoded images alive in the shared store (tests: "read once").
size_t texture_store_size();

}  // namespace gp
