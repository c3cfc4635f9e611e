// PCG32 random numbers (O'Neill 2014). Every pixel of every pass seeds its own stream from
// (seed, pixel, pass), so images do not depend on the thread count or tile order.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/math.h"
#include "core/pixel_filter.h"

namespace gp {

// SplitMix64 finaliser: turns structured keys into well-spread seeds.
inline uint64_t mix_bits(uint64_t v) {
  v ^= v >> 31; v *= 0x7fb5d329728ea185ULL;
  v ^= v >> 27; v *= 0x81dadef4bc2dd44dULL;
  v ^= v >> 33;
  return v;
}

class Rng {
 public:
  Rng() { seed(0, 0); }
  Rng(uint64_t seq_index, uint64_t offset) { seed(seq_index, offset); }
  // Deterministic stream for (a, b, c): e.g. (user seed, pixel index, pass index).
  static Rng for_key(uint64_t a, uint64_t b, uint64_t c) {
    return Rng(mix_bits(a * 0x9E3779B97F4A7C15ULL ^ mix_bits(b + 0x632BE59BD9B4E019ULL)),
               mix_bits(c + 0xD1B54A32D192ED03ULL));
  }
  void seed(uint64_t seq_index, uint64_t offset) {
    state_ = 0u;
    inc_ = (seq_index << 1u) | 1u;
    next_u32();
    state_ += offset;
    next_u32();
  }
  uint32_t next_u32() {
    const uint64_t old = state_;
    state_ = old * 0x5851f42d4c957f2dULL + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }
  // Uniform in [0, 1): 24 random bits so the result is never rounded up to 1.
  float uniform() { return static_cast<float>(next_u32() >> 8) * 0x1p-24f; }

 private:
  uint64_t state_ = 0, inc_ = 1;
};

// The start of pixel (x, y)'s camera path in a pass, drawn alike by every method (so GPM's
// camera paths are SPPM's): the pixel's own stream Rng::for_key(seed, pixel, pass), which makes
// the image independent of the thread count, then a film position drawn from the pixel filter
// (core/pixel_filter.h; none: a box of one pixel) and a lens sample. With a filter wider than a
// pixel `film` may lie in a neighbouring pixel: the sample still counts in pixel (x, y), so
// whoever needs the pixel's cell uses (x, y), never floor(film).
struct PixelStart {
  Rng rng;
  Vec2 film, lens;
  float time = 0;  // shutter time of the camera ray (motion blur; camera.h start_pixel)
};
inline PixelStart start_pixel(uint64_t seed, size_t pixel, uint64_t pass, int x, int y,
                              const PixelFilter* filter = nullptr) {
  Rng rng = Rng::for_key(seed, pixel, pass);
  Vec2 film;
  if (!filter || filter->is_default_box()) {
    // Exactly the expression (and so the draw order) of the box-filtered start before filters
    // existed: a box of one pixel renders today's images bit for bit.
    film = Vec2(x + rng.uniform(), y + rng.uniform());
  } else {
    const float ux = rng.uniform();
    const float uy = rng.uniform();
    film = Vec2(filter->sample(static_cast<float>(x), ux), filter->sample(static_cast<float>(y), uy));
  }
  const Vec2 lens(rng.uniform(), rng.uniform());
  return {rng, film, lens, 0.0f};
}

}  // namespace gp
