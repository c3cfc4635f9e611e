// Where an OpenColorIO config comes from: Blender's own config, so colour spaces mean what they
// mean in Blender (display images in io/display, image textures in textures/).
#pragma once

#include <string>

namespace gp {

// Blender's config.ocio: /usr/share/blender/<version>/datafiles/colormanagement/config.ocio
// (newest version first) or /usr/share/blender/datafiles/colormanagement/config.ocio; empty
// when neither exists.
std::string find_blender_config();

// True for a path inside a Blender installation's datafiles/colormanagement/.
bool looks_like_blender(const std::string& path);

// The config to use when none is named: the OCIO environment variable if set and non-empty,
// else Blender's (find_blender_config), else empty (the built-in fallbacks).
std::string default_ocio_config();

}  // namespace gp
