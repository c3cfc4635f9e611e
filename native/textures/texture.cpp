#include "textures/texture.h"

#include <algorithm>
#include <cmath>

namespace gp {

namespace {

// Texel index for wrap mode; -1 = outside (Clip).
int wrap_index(int i, int n, TextureWrap wrap) {
  switch (wrap) {
    case TextureWrap::Repeat: {
      const int m = i % n;
      return m < 0 ? m + n : m;
    }
    case TextureWrap::Extend: return std::clamp(i, 0, n - 1);
    case TextureWrap::Clip: return (i < 0 || i >= n) ? -1 : i;
  }
  return -1;
}

RGBA texel_or_zero(const TextureImage& img, int x, int y, TextureWrap wrap) {
  const int xi = wrap_index(x, img.width, wrap), yi = wrap_index(y, img.height, wrap);
  if (xi < 0 || yi < 0) return {RGB(0.0f), 0.0f};  // Clip: transparent black outside
  return img.texel(xi, yi);
}

// uv -> continuous texel coordinates, kept in a range where floor() is exact.
float texel_coordinate(float u, int n) {
  if (!std::isfinite(u)) return 0.0f;
  return std::clamp(u, -1e6f, 1e6f) * static_cast<float>(n);
}

}  // namespace

float srgb_eotf(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

RGBA TextureImage::lookup(Vec2 uv, TextureWrap wrap, TextureFilter filter) const {
  if (width <= 0 || height <= 0) return {RGB(1, 0, 1), 1.0f};
  const float x = texel_coordinate(uv.x, width), y = texel_coordinate(uv.y, height);
  if (filter == TextureFilter::Closest)
    return decoded(texel_or_zero(*this, static_cast<int>(std::floor(x)), static_cast<int>(std::floor(y)), wrap));
  const float fx = x - 0.5f, fy = y - 0.5f;
  if (filter == TextureFilter::Cubic) {
    // Uniform cubic B-spline weights of the four texels around (x, y) in each axis (Cycles'
    // SET_CUBIC_SPLINE_WEIGHTS): they sum to 1 and smooth; the image is not interpolated exactly.
    const float x0f = std::floor(fx), y0f = std::floor(fy);
    float wx[4], wy[4];
    auto weights = [](float t, float* w) {
      const float s = 1.0f - t;
      w[0] = s * s * s / 6.0f;
      w[1] = (3.0f * t * t * t - 6.0f * t * t + 4.0f) / 6.0f;
      w[2] = (3.0f * s * s * s - 6.0f * s * s + 4.0f) / 6.0f;
      w[3] = t * t * t / 6.0f;
    };
    weights(fx - x0f, wx);
    weights(fy - y0f, wy);
    const int x0 = static_cast<int>(x0f) - 1, y0 = static_cast<int>(y0f) - 1;
    RGBA sum{RGB(0.0f), 0.0f};
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const RGBA t = texel_or_zero(*this, x0 + i, y0 + j, wrap);
        const float w = wx[i] * wy[j];
        sum.rgb = sum.rgb + t.rgb * w;
        sum.a += t.a * w;
      }
    return decoded(sum);
  }
  // Bilinear between the four texel centres around (x, y).
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  const int x0 = static_cast<int>(x0f), y0 = static_cast<int>(y0f);
  const float wa = (1 - tx) * (1 - ty), wb = tx * (1 - ty), wc = (1 - tx) * ty, wd = tx * ty;
  if (wrap != TextureWrap::Clip) {
    // Every texel exists: each axis wrapped once, not per texel (the World's map takes this
    // path at every environment hit and light sample; the same sums as below).
    const size_t xa = wrap_index(x0, width, wrap), xb = wrap_index(x0 + 1, width, wrap);
    const size_t ya = wrap_index(y0, height, wrap), yb = wrap_index(y0 + 1, height, wrap);
    const float* r0 = &rgba[4 * ya * width];
    const float* r1 = &rgba[4 * yb * width];
    const float *a = r0 + 4 * xa, *b = r0 + 4 * xb, *c = r1 + 4 * xa, *d = r1 + 4 * xb;
    auto mix = [&](int k) { return a[k] * wa + b[k] * wb + c[k] * wc + d[k] * wd; };
    return decoded({RGB(mix(0), mix(1), mix(2)), mix(3)});
  }
  const RGBA a = texel_or_zero(*this, x0, y0, wrap), b = texel_or_zero(*this, x0 + 1, y0, wrap);
  const RGBA c = texel_or_zero(*this, x0, y0 + 1, wrap), d = texel_or_zero(*this, x0 + 1, y0 + 1, wrap);
  return decoded({a.rgb * wa + b.rgb * wb + c.rgb * wc + d.rgb * wd, a.a * wa + b.a * wb + c.a * wc + d.a * wd});
}

RGBA TextureImage::decoded(RGBA t) const {
  if (srgb_encoded)
    for (int c = 0; c < 3; ++c) t.rgb[c] = srgb_eotf(t.rgb[c]);
  return t;
}

RGB TextureRef::rgb(Vec2 uv) const {
  if (channel != TextureChannel::RGB) return RGB(value(uv));
  RGB c = lookup(uv).rgb * scale;
  if (square) c = c * c;
  return c;
}

float TextureRef::value(Vec2 uv) const {
  const RGBA t = lookup(uv);
  float v = 0;
  switch (channel) {
    case TextureChannel::R: v = t.rgb.r; break;
    case TextureChannel::G: v = t.rgb.g; break;
    case TextureChannel::B: v = t.rgb.b; break;
    case TextureChannel::A: v = t.a; break;
    case TextureChannel::RGB:
    case TextureChannel::Luminance: v = t.rgb.luminance(); break;
  }
  v *= scale;
  return square ? v * v : v;
}

Vec2 TextureRef::gradient(Vec2 uv) const {
  // One texel of the image, in the uv units before mapping (the mapping's diagonal scale).
  const float du = 1.0f / (image->width * std::max(1e-6f, std::abs(mapping[0][0]) + std::abs(mapping[0][1])));
  const float dv = 1.0f / (image->height * std::max(1e-6f, std::abs(mapping[1][0]) + std::abs(mapping[1][1])));
  return {(value(uv + Vec2(du, 0)) - value(uv - Vec2(du, 0))) / (2 * du),
          (value(uv + Vec2(0, dv)) - value(uv - Vec2(0, dv))) / (2 * dv)};
}

}  // namespace gp
