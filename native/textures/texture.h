// Image textures as materials use them: a decoded image (float RGBA, scene-linear Rec.709 for
// colour data) and a reference from a material input to one, with the lookup Cycles does:
// bilinear (or closest) filtering, Blender's wrap modes (Repeat, Extend, Clip) and the 2D part
// of a Mapping node. Loading and sharing images is texture_store's job.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/math.h"

namespace gp {

// Blender's Image Texture extension modes.
enum class TextureWrap { Repeat, Extend, Clip };
// Cubic: Cycles' uniform cubic B-spline over 4 x 4 texels (kernel/device/cpu/image.h), which
// Cycles' CPU kernel also uses for Smart.
enum class TextureFilter { Linear, Closest, Cubic };

struct RGBA {
  RGB rgb;
  float a = 1.0f;
};

// A decoded image: width x height RGBA floats, row 0 at the bottom so that Blender's uv
// (0, 0) is the first texel (image files store the top row first).
struct TextureImage {
  std::string path;     // for messages
  std::string colorspace;
  int width = 0, height = 0;
  std::vector<float> rgba;  // 4 * width * height
  bool missing = false;     // the file could not be read: magenta, as Cycles renders it
  RGBA mean;                // average texel, linear (constant stand-ins: spectral modes, fallbacks)
  // 8-bit sRGB images keep their encoded texels and are decoded after filtering, as Cycles
  // does (it filters such images before the conversion; filtering linear values renders
  // edges between contrasting texels a few percent brighter).
  bool srgb_encoded = false;

  RGBA texel(int x, int y) const {
    const float* p = &rgba[4 * (static_cast<size_t>(y) * width + x)];
    return {RGB(p[0], p[1], p[2]), p[3]};
  }
  // Filtered value at uv (texel centres at (i + 1/2) / width, as Cycles), linear.
  RGBA lookup(Vec2 uv, TextureWrap wrap, TextureFilter filter) const;
  RGBA decoded(RGBA t) const;  // a stored texel value as linear (srgb_encoded)
  size_t bytes() const { return rgba.size() * sizeof(float); }
};

// The sRGB transfer function's decoding (IEC 61966-2-1).
float srgb_eotf(float v);

// Which value of an image a scalar input takes: one channel, or the luminance of the colour
// (how Blender converts a Color output linked to a float input).
enum class TextureChannel { RGB, R, G, B, A, Luminance };

// A material input driven by an image texture: the image at the hit's uv through a 2D affine
// uv transform (Mapping node), then value = scale * v (+ squared when `square`, which turns a
// Blender roughness texture into GGX alpha). An empty reference (no image) is a constant input.
struct TextureRef {
  std::shared_ptr<const TextureImage> image;
  TextureChannel channel = TextureChannel::RGB;
  TextureWrap wrap = TextureWrap::Repeat;
  TextureFilter filter = TextureFilter::Linear;
  // uv' = M uv + t (row-major 2 x 3), identity by default.
  float mapping[2][3] = {{1, 0, 0}, {0, 1, 0}};
  float scale = 1.0f;
  bool square = false;

  explicit operator bool() const { return image != nullptr; }
  Vec2 map(Vec2 uv) const {
    return {mapping[0][0] * uv.x + mapping[0][1] * uv.y + mapping[0][2],
            mapping[1][0] * uv.x + mapping[1][1] * uv.y + mapping[1][2]};
  }
  RGBA lookup(Vec2 uv) const { return image->lookup(map(uv), wrap, filter); }
  RGB rgb(Vec2 uv) const;      // colour inputs (channel RGB; a scalar channel as grey)
  float value(Vec2 uv) const;  // scalar inputs
  // Derivatives of value() in uv by central differences one texel apart (bump mapping).
  Vec2 gradient(Vec2 uv) const;
};

}  // namespace gp
