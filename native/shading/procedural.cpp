#include "shading/procedural.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "shading/hash.h"

// The vector lanes of hash.h are inline only (no ABI crosses a call): GCC's note on 32-byte
// vectors without AVX does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

// The entry points of the lane-parallel textures (snoise, voronoi) are also built for AVX2 and
// chosen when the program loads (GCC's target_clones, an ifunc): the eight lanes of a cell in one
// instruction instead of two SSE2 ones. AVX2 brings no FMA (nothing is contracted), so each float
// operation is the same IEEE single one in either build: the same bits. What they call is
// inlined into them (GP_INLINE), so that it is built for the clone's target too.
// (-DGRADPHOTON_NO_TARGET_CLONES builds the default lanes alone: how the SSE2 path is tested on
// an AVX2 machine, docs/benchmarks.md.)
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(GRADPHOTON_NO_TARGET_CLONES)
#define GP_AVX2_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define GP_AVX2_CLONES
#endif
#define GP_INLINE inline __attribute__((always_inline))

namespace gp::shading {

namespace {

constexpr float kPiF = 3.14159265358979323846f;

// ---- Perlin noise (kernel/svm/noise.h, the non-SSE formulas) ----

float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
float negate_if(float v, uint32_t c) { return c ? -v : v; }
float lerp(float a, float b, float t) { return (1.0f - t) * a + t * b; }
float floorfrac(float x, int* i) {
  const float f = std::floor(x);
  *i = static_cast<int>(f);
  return x - f;
}

float grad1(uint32_t hash, float x) {
  const uint32_t h = hash & 15;
  const float g = static_cast<float>(1 + (h & 7));
  return negate_if(g, h & 8) * x;
}
// The corners' hashes and gradients are computed together over vector lanes (hash.h's *_v), as
// Cycles' SSE/AVX noise does: the same integer operations, selections and sign flips lane by lane
// and the same one or two float additions per corner, so every value is the scalar formula's
// bit for bit (tested against a scalar transcription in shading_procedural_test.cpp).
using u32x4 = uint32_t __attribute__((vector_size(16)));
using i32x4 = int32_t __attribute__((vector_size(16)));
using f32x4 = float __attribute__((vector_size(16)));

// All ones where h < k, else zero, for h and k below 2^31 (the gradient indices): by the sign of
// h - k, as GCC would split a comparison of 8 lanes into scalar ones without AVX.
template <class U>
GP_INLINE U below(const U& h, uint32_t k) {
  return U{} - ((h - k) >> 31);
}
// All ones where a < b (floats; Chebychev's max as std::max takes it).
GP_INLINE u32x8 below_f(const f32x8& a, const f32x8& b) { return (u32x8)(a < b); }
// m ? a : b lane by lane, on the bits (m: all ones or zero per lane).
template <class U, class F>
GP_INLINE U select_bits(const U& m, const F& a, const F& b) {
  return (m & (U)a) | (~m & (U)b);
}

// grad2 of noise.h over four corners: u = h < 4 ? x : y, v = 2 (h < 4 ? y : x), signs by h & 1, h & 2.
GP_INLINE f32x4 grad2_v(u32x4 hash, f32x4 x, f32x4 y) {
  const u32x4 h = hash & 7u;
  const u32x4 lt4 = below(h, 4);
  const u32x4 u = select_bits<u32x4>(lt4, x, y);
  const f32x4 v = 2.0f * (f32x4)select_bits<u32x4>(lt4, y, x);
  return (f32x4)(u ^ ((h & 1u) << 31)) + (f32x4)((u32x4)v ^ ((h & 2u) << 30));
}
// grad3: u = h < 8 ? x : y, v = h < 4 ? y : (h == 12 || h == 14 ? x : z), signs by h & 1, h & 2.
// The tests read the bits of h directly: h < 8 is bit 3 clear, h < 4 bits 2 and 3 clear, h == 12 or
// 14 is h & 13 == 12; bit 0 shifted to the sign is u's flip, bit 1 v's.
GP_INLINE f32x8 grad3_v(const u32x8& hash, const f32x8& x, const f32x8& y, const f32x8& z) {
  const u32x8 lt8 = (u32x8)((i32x8)(hash << 28) >> 31);  // all ones where bit 3 is set (h >= 8)
  const u32x8 u = select_bits<u32x8>(lt8, y, x);
  const u32x8 is12or14 = (u32x8)((hash & 13u) == 12u);
  const u32x8 lt4 = (u32x8)((hash & 12u) == 0u);
  const u32x8 v = select_bits<u32x8>(lt4, (u32x8)y, select_bits<u32x8>(is12or14, x, z));
  return (f32x8)(u ^ (hash << 31)) + (f32x8)(v ^ ((hash << 30) & 0x80000000u));
}
// grad4: u = h < 24 ? x : y, v = h < 16 ? y : z, s = h < 8 ? z : w, signs by h & 1, 2, 4.
GP_INLINE f32x8 grad4_v(const u32x8& hash, const f32x8& x, const f32x8& y, const f32x8& z, const f32x8& w) {
  const u32x8 h = hash & 31u;
  const u32x8 u = select_bits<u32x8>(below(h, 24), x, y);
  const u32x8 v = select_bits<u32x8>(below(h, 16), y, z);
  const u32x8 s = select_bits<u32x8>(below(h, 8), z, w);
  return (f32x8)(u ^ ((h & 1u) << 31)) + (f32x8)(v ^ ((h & 2u) << 30)) + (f32x8)(s ^ ((h & 4u) << 29));
}

float perlin_1d(float x) {
  int X;
  const float fx = floorfrac(x, &X);
  return lerp(grad1(hash_uint(X), fx), grad1(hash_uint(X + 1), fx - 1.0f), fade(fx));
}
float bi_mix(float v0, float v1, float v2, float v3, float x, float y) {
  const float x1 = 1.0f - x;
  return (1.0f - y) * (v0 * x1 + v1 * x) + y * (v2 * x1 + v3 * x);
}
// Corner k of a cell is (k & 1, k >> 1 & 1, k >> 2 & 1, k >> 3 & 1): the order of bi_mix and tri_mix.
constexpr u32x8 kCornerX = {0, 1, 0, 1, 0, 1, 0, 1}, kCornerY = {0, 0, 1, 1, 0, 0, 1, 1},
                kCornerZ = {0, 0, 0, 0, 1, 1, 1, 1};
constexpr f32x8 kCornerXf = {0, 1, 0, 1, 0, 1, 0, 1}, kCornerYf = {0, 0, 1, 1, 0, 0, 1, 1},
                kCornerZf = {0, 0, 0, 0, 1, 1, 1, 1};
GP_INLINE float perlin_2d(float x, float y) {
  int X, Y;
  const float fx = floorfrac(x, &X), fy = floorfrac(y, &Y);
  const u32x4 dx = {0, 1, 0, 1}, dy = {0, 0, 1, 1};
  const f32x4 dxf = {0, 1, 0, 1}, dyf = {0, 0, 1, 1};
  const u32x4 h = hash_uint2_v(static_cast<uint32_t>(X) + dx, static_cast<uint32_t>(Y) + dy);
  const f32x4 g = grad2_v(h, fx - dxf, fy - dyf);
  return bi_mix(g[0], g[1], g[2], g[3], fade(fx), fade(fy));
}
// tri_mix of a cell's eight corner values over vector lanes: the fades of x, y, z (and w) at once,
// then the three levels of the trilinear mix as pair sums of weighted lanes. Each level forms the
// scalar formula's products (x1 * v0, x * v1, ...) and adds each pair once, and a sum of two is
// the same whichever is first: the bits of tri_mix(v, fade(fx), fade(fy), fade(fz)).
struct Fades {
  f32x4 t, t1;  // fade(f) and 1 - fade(f) per coordinate
};
GP_INLINE Fades fades(float fx, float fy, float fz, float fw) {
  const f32x4 f = {fx, fy, fz, fw};
  const f32x4 t = f * f * f * (f * (f * 6.0f - 15.0f) + 10.0f);  // fade
  return {t, 1.0f - t};
}
GP_INLINE float tri_mix_v(const f32x8& g, const Fades& w) {
  const f32x8 mx = g * __builtin_shufflevector(w.t1, w.t, 0, 4, 0, 4, 0, 4, 0, 4);  // v0 * x1, v1 * x, ...
  const f32x4 a = __builtin_shufflevector(mx, mx, 0, 2, 4, 6) + __builtin_shufflevector(mx, mx, 1, 3, 5, 7);
  const f32x4 my = a * __builtin_shufflevector(w.t1, w.t, 1, 5, 1, 5);  // y1 * a0, y * a1, y1 * a2, y * a3
  return w.t1[2] * (my[0] + my[1]) + w.t[2] * (my[2] + my[3]);
}
GP_INLINE float perlin_3d(float x, float y, float z) {
  int X, Y, Z;
  const float fx = floorfrac(x, &X), fy = floorfrac(y, &Y), fz = floorfrac(z, &Z);
  const u32x8 h = hash_uint3_v(static_cast<uint32_t>(X) + kCornerX, static_cast<uint32_t>(Y) + kCornerY,
                               static_cast<uint32_t>(Z) + kCornerZ);
  const f32x8 g = grad3_v(h, fx - kCornerXf, fy - kCornerYf, fz - kCornerZf);
  return tri_mix_v(g, fades(fx, fy, fz, 0.0f));
}
// perlin_3d at three points (the Noise Texture's channels at one octave): the floors, their
// int conversions, the fractions and the fades of the three points' coordinates in 8 + 4 lanes
// instead of one coordinate at a time (per lane floorf, the conversion, x - floor(x) and fade, as
// floorfrac and fades), then each point's corners as perlin_3d. A point's lanes: (x, y, z, w).
GP_INLINE void perlin_3d_x3(const f32x4 (&q)[3], float* out) {
  const f32x8 a = __builtin_shufflevector(q[0], q[1], 0, 1, 2, 3, 4, 5, 6, 7);
  const f32x4 b = q[2];
  f32x8 fa;
  f32x4 fb;
  for (int l = 0; l < 8; ++l) fa[l] = std::floor(a[l]);
  for (int l = 0; l < 4; ++l) fb[l] = std::floor(b[l]);
  const i32x8 ia = __builtin_convertvector(fa, i32x8);
  const i32x4 ib = __builtin_convertvector(fb, i32x4);
  const f32x8 ra = a - fa;
  const f32x4 rb = b - fb;
  const f32x8 ta = ra * ra * ra * (ra * (ra * 6.0f - 15.0f) + 10.0f);  // fade
  const f32x4 tb = rb * rb * rb * (rb * (rb * 6.0f - 15.0f) + 10.0f);
  const f32x8 ta1 = 1.0f - ta;
  const f32x4 tb1 = 1.0f - tb;
  auto corners = [](const i32x4& i, const f32x4& r, const Fades& w) {
    const u32x8 h = hash_uint3_v(static_cast<uint32_t>(i[0]) + kCornerX, static_cast<uint32_t>(i[1]) + kCornerY,
                                 static_cast<uint32_t>(i[2]) + kCornerZ);
    const f32x8 g = grad3_v(h, r[0] - kCornerXf, r[1] - kCornerYf, r[2] - kCornerZf);
    return tri_mix_v(g, w);
  };
  out[0] = corners(__builtin_shufflevector(ia, ia, 0, 1, 2, 3), __builtin_shufflevector(ra, ra, 0, 1, 2, 3),
                   Fades{__builtin_shufflevector(ta, ta, 0, 1, 2, 3), __builtin_shufflevector(ta1, ta1, 0, 1, 2, 3)});
  out[1] = corners(__builtin_shufflevector(ia, ia, 4, 5, 6, 7), __builtin_shufflevector(ra, ra, 4, 5, 6, 7),
                   Fades{__builtin_shufflevector(ta, ta, 4, 5, 6, 7), __builtin_shufflevector(ta1, ta1, 4, 5, 6, 7)});
  out[2] = corners(ib, rb, Fades{tb, tb1});
}
GP_INLINE float perlin_4d(float x, float y, float z, float w) {
  int X, Y, Z, W;
  const float fx = floorfrac(x, &X), fy = floorfrac(y, &Y), fz = floorfrac(z, &Z), fw = floorfrac(w, &W);
  const u32x8 kx = static_cast<uint32_t>(X) + kCornerX, ky = static_cast<uint32_t>(Y) + kCornerY,
              kz = static_cast<uint32_t>(Z) + kCornerZ;
  const f32x8 px = fx - kCornerXf, py = fy - kCornerYf, pz = fz - kCornerZf;
  const f32x8 g0 = grad4_v(hash_uint4_v(kx, ky, kz, u32x8{} + static_cast<uint32_t>(W)), px, py, pz, f32x8{} + fw);
  const f32x8 g1 = grad4_v(hash_uint4_v(kx, ky, kz, u32x8{} + (static_cast<uint32_t>(W) + 1u)), px, py, pz,
                           f32x8{} + (fw - 1.0f));
  const Fades t = fades(fx, fy, fz, fw);
  return t.t1[3] * tri_mix_v(g0, t) + t.t[3] * tri_mix_v(g1, t);  // lerp(.., .., fade(fw))
}

float ensure_finite(float v) { return std::isfinite(v) ? v : 0.0f; }

Vec4 scaled(const Vec4& p, float s) {
  Vec4 r;
  for (int i = 0; i < 4; ++i) r[i] = p[i] * s;
  return r;
}
Vec4 added(const Vec4& p, const Vec4& q) {
  Vec4 r;
  for (int i = 0; i < 4; ++i) r[i] = p[i] + q[i];
  return r;
}

// noisetex.h's seeds: offsets in [100, 200] that decorrelate the distortion and colour channels.
// They depend on the seed (0 to 5) and the dimensions alone: computed once.
Vec4 random_offset_of(float seed, int dims) {
  Vec4 r;
  if (dims == 1) {
    r[0] = 100.0f + hash_float_to_float(seed) * 100.0f;
  } else {
    for (int i = 0; i < dims; ++i) r[i] = 100.0f + hash_float2_to_float(seed, static_cast<float>(i)) * 100.0f;
  }
  return r;
}
constexpr int kOffsetSeeds = 6;
struct RandomOffsets {
  Vec4 table[5][kOffsetSeeds];
  RandomOffsets() {
    for (int dims = 1; dims <= 4; ++dims)
      for (int seed = 0; seed < kOffsetSeeds; ++seed) table[dims][seed] = random_offset_of(static_cast<float>(seed), dims);
  }
};
const RandomOffsets kRandomOffsets;
const Vec4& random_offset(int seed, int dims) { return kRandomOffsets.table[dims][seed]; }

}  // namespace

namespace {
GP_INLINE float snoise_in(const Vec4& p, int dims) {
  switch (dims) {
    case 1: return 0.2500f * ensure_finite(perlin_1d(p[0]));
    case 2: return 0.6616f * ensure_finite(perlin_2d(p[0], p[1]));
    case 3: return 0.9820f * ensure_finite(perlin_3d(p[0], p[1], p[2]));
    default: return 0.8344f * ensure_finite(perlin_4d(p[0], p[1], p[2], p[3]));
  }
}
GP_INLINE float unoise_in(const Vec4& p, int dims) { return 0.5f * snoise_in(p, dims) + 0.5f; }  // unoise

// Cycles 3.4's fractal_noise_Nd: octaves clamped to [0, 16], roughness to [0, 1].
GP_INLINE float fractal_noise_in(const Vec4& p, int dims, float octaves, float roughness) {
  float fscale = 1.0f, amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
  octaves = std::clamp(octaves, 0.0f, 16.0f);
  roughness = std::clamp(roughness, 0.0f, 1.0f);
  const int n = static_cast<int>(octaves);
  for (int i = 0; i <= n; ++i) {
    const float t = unoise_in(scaled(p, fscale), dims);
    sum += t * amp;
    maxamp += amp;
    amp *= roughness;
    fscale *= 2.0f;
  }
  const float rmd = octaves - std::floor(octaves);
  if (rmd != 0.0f) {
    const float t = unoise_in(scaled(p, fscale), dims);
    const float sum2 = (sum + t * amp) / (maxamp + amp);
    return (1.0f - rmd) * (sum / maxamp) + rmd * sum2;
  }
  return sum / maxamp;
}
}  // namespace

GP_AVX2_CLONES float snoise(const Vec4& p, int dims) { return snoise_in(p, dims); }

GP_AVX2_CLONES float fractal_noise(const Vec4& p, int dims, float octaves, float roughness) {
  return fractal_noise_in(p, dims, octaves, roughness);
}

namespace {
// fractal_noise_in of three points (the Noise Texture's value and colour channels) in one loop:
// each channel's sums are formed as there, octave by octave; the octaves' bookkeeping and the
// loop's constants are shared (three separate loops each set up their constants again).
// unoise_in of three points scaled by fscale (scaled()), the 3D ones together (perlin_3d_x3).
template <int dims>
GP_INLINE void unoise_x3(const Vec4 (&p)[3], float fscale, float* t) {
  if constexpr (dims == 3) {
    f32x4 q[3];
    for (int c = 0; c < 3; ++c) q[c] = f32x4{p[c][0], p[c][1], p[c][2], p[c][3]} * fscale;
    float v[3];
    perlin_3d_x3(q, v);
    for (int c = 0; c < 3; ++c) t[c] = 0.5f * (0.9820f * ensure_finite(v[c])) + 0.5f;  // unoise_in, 3D
  } else {
    for (int c = 0; c < 3; ++c) t[c] = unoise_in(scaled(p[c], fscale), dims);
  }
}

template <int dims>
GP_INLINE void fractal_noise_x3(const Vec4 (&p)[3], float octaves, float roughness, float* out) {
  float fscale = 1.0f, amp = 1.0f, maxamp = 0.0f, sum[3] = {0.0f, 0.0f, 0.0f};
  octaves = std::clamp(octaves, 0.0f, 16.0f);
  roughness = std::clamp(roughness, 0.0f, 1.0f);
  const int n = static_cast<int>(octaves);
  for (int i = 0; i <= n; ++i) {
    float t[3];
    unoise_x3<dims>(p, fscale, t);
    for (int c = 0; c < 3; ++c) sum[c] += t[c] * amp;
    maxamp += amp;
    amp *= roughness;
    fscale *= 2.0f;
  }
  const float rmd = octaves - std::floor(octaves);
  float t[3];
  if (rmd != 0.0f) unoise_x3<dims>(p, fscale, t);
  for (int c = 0; c < 3; ++c) {
    if (rmd != 0.0f) {
      const float sum2 = (sum[c] + t[c] * amp) / (maxamp + amp);
      out[c] = (1.0f - rmd) * (sum[c] / maxamp) + rmd * sum2;
    } else {
      out[c] = sum[c] / maxamp;
    }
  }
}
}  // namespace

namespace {
// The Noise Texture for a dimension count known at compile time (each octave's perlin_Nd
// chosen once, not per octave).
template <int dims>
GP_INLINE void noise_texture_d(const Vec4& co, float detail, float roughness, float distortion, bool want_color,
                               float* value, Vec3* color) {
  Vec4 p = co;
  if (distortion != 0.0f) {
    Vec4 d;
    for (int i = 0; i < dims; ++i) d[i] = snoise_in(added(p, random_offset(i, dims)), dims) * distortion;
    p = added(p, d);
  }
  if (!want_color) {
    *value = fractal_noise_in(p, dims, detail, roughness);
    return;
  }
  // Colour channels 2 and 3 at the seeds after the distortion's (noisetex.h).
  const int s = dims == 1 ? 1 : dims;
  const Vec4 q[3] = {p, added(p, random_offset(s, dims)), added(p, random_offset(s + 1, dims))};
  float v[3];
  fractal_noise_x3<dims>(q, detail, roughness, v);
  *value = v[0];
  *color = Vec3(v[0], v[1], v[2]);
}
}  // namespace

GP_AVX2_CLONES void noise_texture(const Vec4& co, int dims, float detail, float roughness, float distortion, bool want_color,
                   float* value, Vec3* color) {
  switch (dims) {
    case 1: return noise_texture_d<1>(co, detail, roughness, distortion, want_color, value, color);
    case 2: return noise_texture_d<2>(co, detail, roughness, distortion, want_color, value, color);
    case 3: return noise_texture_d<3>(co, detail, roughness, distortion, want_color, value, color);
    default: return noise_texture_d<4>(co, detail, roughness, distortion, want_color, value, color);
  }
}

GP_AVX2_CLONES float musgrave(MusgraveType type, const Vec4& co, int dims, float H, float lacunarity, float octaves, float offset,
               float gain) {
  Vec4 p = co;
  const float pwHL = std::pow(lacunarity, -H);
  const int n = static_cast<int>(octaves);
  const float rmd = octaves - std::floor(octaves);
  switch (type) {
    case MusgraveType::FBM: {
      float value = 0.0f, pwr = 1.0f;
      for (int i = 0; i < n; ++i) {
        value += snoise_in(p, dims) * pwr;
        pwr *= pwHL;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f) value += rmd * snoise_in(p, dims) * pwr;
      return value;
    }
    case MusgraveType::MultiFractal: {
      float value = 1.0f, pwr = 1.0f;
      for (int i = 0; i < n; ++i) {
        value *= (pwr * snoise_in(p, dims) + 1.0f);
        pwr *= pwHL;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f) value *= (rmd * pwr * snoise_in(p, dims) + 1.0f);
      return value;
    }
    case MusgraveType::HeteroTerrain: {
      float pwr = pwHL;
      float value = offset + snoise_in(p, dims);
      p = scaled(p, lacunarity);
      for (int i = 1; i < n; ++i) {
        value += (snoise_in(p, dims) + offset) * pwr * value;
        pwr *= pwHL;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f) value += rmd * ((snoise_in(p, dims) + offset) * pwr * value);
      return value;
    }
    case MusgraveType::HybridMultiFractal: {
      float pwr = pwHL;
      float value = snoise_in(p, dims) + offset;
      float weight = gain * value;
      p = scaled(p, lacunarity);
      for (int i = 1; weight > 0.001f && i < n; ++i) {
        weight = std::min(weight, 1.0f);
        const float signal = (snoise_in(p, dims) + offset) * pwr;
        pwr *= pwHL;
        value += weight * signal;
        weight *= gain * signal;
        p = scaled(p, lacunarity);
      }
      if (rmd != 0.0f && weight > 0.001f) {
        weight = std::min(weight, 1.0f);
        value += rmd * weight * ((snoise_in(p, dims) + offset) * pwr);
      }
      return value;
    }
    case MusgraveType::RidgedMultiFractal: {
      float pwr = pwHL;
      float signal = offset - std::abs(snoise_in(p, dims));
      signal *= signal;
      float value = signal;
      for (int i = 1; i < n; ++i) {
        p = scaled(p, lacunarity);
        const float weight = std::clamp(signal * gain, 0.0f, 1.0f);
        signal = offset - std::abs(snoise_in(p, dims));
        signal *= signal;
        signal *= weight;
        value += signal * pwr;
        pwr *= pwHL;
      }
      return value;
    }
  }
  return 0.0f;
}

// ---- Voronoi (voronoi.h), one template over 1 to 4 dimensions ----

// GCC 12 warns, with the 3D F1 search below in the file, that voronoi()'s inlined 2D and 4D
// searches read a VP<2> as a VP<3> (and a VP<3> at index 3): every access is VP<N>'s own loop
// over i < N; the bit-for-bit tests of every dimension count read the values. A false positive
// of its array-bounds analysis across the dimension switch.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Warray-bounds"

namespace {

template <int N>
struct VP {
  float v[N];
  float& operator[](int i) { return v[i]; }
  float operator[](int i) const { return v[i]; }
  VP operator+(const VP& o) const { VP r; for (int i = 0; i < N; ++i) r[i] = v[i] + o[i]; return r; }
  VP operator-(const VP& o) const { VP r; for (int i = 0; i < N; ++i) r[i] = v[i] - o[i]; return r; }
  VP operator*(float s) const { VP r; for (int i = 0; i < N; ++i) r[i] = v[i] * s; return r; }
};
template <int N>
float vdot(const VP<N>& a, const VP<N>& b) {
  float s = 0;
  for (int i = 0; i < N; ++i) s += a[i] * b[i];
  return s;
}
template <int N>
float vlen(const VP<N>& a) { return std::sqrt(vdot(a, a)); }
template <int N>
VP<N> vmix(const VP<N>& a, const VP<N>& b, float t) { return a * (1.0f - t) + b * t; }

// The cell's feature point in [0, 1)^N (hash_floatN_to_floatN).
template <int N>
VP<N> cell_hash(const VP<N>& k) {
  VP<N> r;
  if constexpr (N == 1) r[0] = hash_float_to_float(k[0]);
  else if constexpr (N == 2) {
    r[0] = hash_float2_to_float(k[0], k[1]);
    r[1] = hash_float3_to_float(k[0], k[1], 1.0f);
  } else if constexpr (N == 3) {
    const Vec3 h = hash_float3_to_float3(Vec3(k[0], k[1], k[2]));
    r[0] = h.x, r[1] = h.y, r[2] = h.z;
  } else {
    r[0] = hash_float4_to_float(k[0], k[1], k[2], k[3]);
    r[1] = hash_float4_to_float(k[3], k[0], k[1], k[2]);
    r[2] = hash_float4_to_float(k[2], k[3], k[0], k[1]);
    r[3] = hash_float4_to_float(k[1], k[2], k[3], k[0]);
  }
  return r;
}
template <int N>
Vec3 cell_color(const VP<N>& k) {
  if constexpr (N == 1) return hash_float_to_float3(k[0]);
  else if constexpr (N == 2) return hash_float2_to_float3(k[0], k[1]);
  else if constexpr (N == 3) return hash_float3_to_float3(Vec3(k[0], k[1], k[2]));
  else return hash_float4_to_float3(k[0], k[1], k[2], k[3]);
}
template <int N>
GP_INLINE float metric_distance(const VP<N>& a, const VP<N>& b, VoronoiMetric metric, float exponent) {
  if constexpr (N == 1) return std::abs(b[0] - a[0]);
  else {
    switch (metric) {
      case VoronoiMetric::Euclidean: return vlen(a - b);
      case VoronoiMetric::Manhattan: {
        float s = 0;
        for (int i = 0; i < N; ++i) s += std::abs(a[i] - b[i]);
        return s;
      }
      case VoronoiMetric::Chebychev: {
        float s = 0;
        for (int i = 0; i < N; ++i) s = std::max(s, std::abs(a[i] - b[i]));
        return s;
      }
      case VoronoiMetric::Minkowski: {
        float s = 0;
        for (int i = 0; i < N; ++i) s += std::pow(std::abs(a[i] - b[i]), exponent);
        return std::pow(s, 1.0f / exponent);
      }
    }
    return 0.0f;
  }
}

// Cells offset by -r..r in every dimension, x varying fastest (Cycles' loop nesting: the last
// dimension outermost), which decides ties and the order smooth F1 blends in.
template <int N>
constexpr int cell_count(int r) {
  int total = 1;
  for (int i = 0; i < N; ++i) total *= 2 * r + 1;
  return total;
}
// The offsets of the (2R + 1)^N cells, by dimension, padded to whole lanes of 8 (with the last
// cell again) and computed at compile time.
template <int N, int R>
struct CellOffsets {
  static constexpr int kCount = cell_count<N>(R), kPadded = (kCount + 7) / 8 * 8;
  float o[N][kPadded] = {};
  constexpr CellOffsets() {
    for (int idx = 0; idx < kPadded; ++idx) {
      int rest = idx < kCount ? idx : kCount - 1;
      for (int i = 0; i < N; ++i, rest /= 2 * R + 1) o[i][idx] = static_cast<float>(rest % (2 * R + 1) - R);
    }
  }
};
template <int N, int R>
constexpr CellOffsets<N, R> kCellOffsets{};

template <int N, int R, typename F>
GP_INLINE void for_cells(F&& f) {
  constexpr const CellOffsets<N, R>& t = kCellOffsets<N, R>;
  for (int idx = 0; idx < t.kCount; ++idx) {
    VP<N> o;
    for (int i = 0; i < N; ++i) o[i] = t.o[i][idx];
    f(idx, o);
  }
}

// hash_float3_to_float3 of eight 3D keys (their float bits k[0..2]) into h[0..2].
GP_INLINE void cell_hash3_v(const u32x8* k, f32x8* h) {
  const u32x8 one = u32x8{} + detail::float_bits(1.0f), two = u32x8{} + detail::float_bits(2.0f);
  h[0] = uint_to_float_incl_v(hash_uint3_v(k[0], k[1], k[2]));
  // hash_uint4 of (k, 1) and (k, 2): lookup3 mixes the first three keys before the fourth
  // is added, so that mix is made once for both.
  const u32x8 init = u32x8{} + (0xdeadbeefu + (4u << 2) + 13u);
  u32x8 a = init + k[0], b = init + k[1], c = init + k[2];
  detail::jenkins_mix_v(a, b, c);
  u32x8 a1 = a + one, b1 = b, c1 = c, a2 = a + two, b2 = b, c2 = c;
  detail::jenkins_final_v(a1, b1, c1);
  detail::jenkins_final_v(a2, b2, c2);
  h[1] = uint_to_float_incl_v(c1);
  h[2] = uint_to_float_incl_v(c2);
}

// cell_hash of every cell for_cells<N, R> visits around `cell`, in its order, eight cells at a
// time over vector lanes (hash.h's *_v: the scalar hashes bit for bit; each key is the same
// float sum cell + offset). out[i][idx]: component i of cell idx.
template <int N>
using CellHashTable = float[N][CellOffsets<N, 2>::kPadded];
template <int N, int R>
GP_INLINE void cell_hashes(const VP<N>& cell, CellHashTable<N>& out) {
  constexpr const CellOffsets<N, R>& t = kCellOffsets<N, R>;
  const u32x8 one = u32x8{} + detail::float_bits(1.0f);  // hash_float2_to_float2's third key
  for (int base = 0; base < t.kPadded; base += 8) {
    u32x8 k[N];
    for (int i = 0; i < N; ++i) {
      f32x8 off;
      std::memcpy(&off, &t.o[i][base], sizeof off);
      k[i] = float_bits_v(cell[i] + off);
    }
    f32x8 h[N];
    if constexpr (N == 1) {
      h[0] = uint_to_float_incl_v(hash_uint_v(k[0]));
    } else if constexpr (N == 2) {  // hash_float2_to_float2
      h[0] = uint_to_float_incl_v(hash_uint2_v(k[0], k[1]));
      h[1] = uint_to_float_incl_v(hash_uint3_v(k[0], k[1], one));
    } else if constexpr (N == 3) {
      cell_hash3_v(k, h);
    } else {  // hash_float4_to_float4
      h[0] = uint_to_float_incl_v(hash_uint4_v(k[0], k[1], k[2], k[3]));
      h[1] = uint_to_float_incl_v(hash_uint4_v(k[3], k[0], k[1], k[2]));
      h[2] = uint_to_float_incl_v(hash_uint4_v(k[2], k[3], k[0], k[1]));
      h[3] = uint_to_float_incl_v(hash_uint4_v(k[1], k[2], k[3], k[0]));
    }
    for (int i = 0; i < N; ++i) std::memcpy(&out[i][base], &h[i], sizeof h[i]);
  }
}

// The feature points offset + hash * randomness of those cells and their metric_distance to
// `local`, eight cells at a time: the same float operations in the same order per lane (a
// distance's sum starts at 0 and adds each dimension's term), so the same bits. Minkowski's
// powers stay one cell at a time.
template <int N, int R>
GP_INLINE void cell_points(const CellHashTable<N>& hashes, const VP<N>& local, float randomness, VoronoiMetric metric,
                 float exponent, CellHashTable<N>& points, float* dist) {
  constexpr const CellOffsets<N, R>& t = kCellOffsets<N, R>;
  const u32x8 abs_mask = u32x8{} + 0x7FFFFFFFu;
  for (int base = 0; base < t.kPadded; base += 8) {
    f32x8 sum = f32x8{};
    for (int i = 0; i < N; ++i) {
      f32x8 off, h;
      std::memcpy(&off, &t.o[i][base], sizeof off);
      std::memcpy(&h, &hashes[i][base], sizeof h);
      const f32x8 p = off + h * randomness;
      std::memcpy(&points[i][base], &p, sizeof p);
      // metric_distance(p, local): N = 1 reads |local - p|, else p - local per dimension.
      const f32x8 d = N == 1 ? local[0] - p : p - local[i];
      const f32x8 ad = (f32x8)((u32x8)d & abs_mask);
      if (N == 1 || metric == VoronoiMetric::Manhattan) sum = sum + ad;
      else if (metric == VoronoiMetric::Euclidean) sum = sum + d * d;
      else if (metric == VoronoiMetric::Chebychev) sum = (f32x8)select_bits<u32x8>(below_f(sum, ad), ad, sum);
    }
    if (N == 1 || metric == VoronoiMetric::Manhattan || metric == VoronoiMetric::Chebychev) {
      std::memcpy(&dist[base], &sum, sizeof sum);
    } else if (metric == VoronoiMetric::Euclidean) {
      for (int l = 0; l < 8; ++l) dist[base + l] = std::sqrt(sum[l]);
    } else {
      for (int l = 0; l < 8; ++l) {
        VP<N> pp;
        for (int i = 0; i < N; ++i) pp[i] = points[i][base + l];
        dist[base + l] = metric_distance(pp, local, metric, exponent);
      }
    }
  }
}

float smoothstep01(float x) {  // Cycles' smoothstep(0, 1, x)
  if (x < 0.0f) return 0.0f;
  if (x >= 1.0f) return 1.0f;
  return (3.0f - 2.0f * x) * x * x;
}

// ---- Voronoi F1, Euclidean, 3D: the nearest cells first ----
// voronoi.h's F1 measures the 27 cells around the point's cell and keeps the first of least
// distance. A cell's feature point lies in the unit cube at its offset (offset + hash *
// randomness, randomness in [0, 1]), so along each axis it is at least 0 (offset 0), 1 - local
// (offset 1) or local (offset -1) from the point. Those bounds squared, summed in the distance's
// order and rooted are never above any distance the cell can give, to the bit (each rounded
// operation is monotonic, and |p - local| >= the bound exactly). The eight cells of the 2x2x2
// block towards the point's nearest cube corner are measured first; of the 19 others only those
// whose bound is not above the block's least distance can hold the least one (about 1.3 of them
// on average, none for most points). Of the cells measured: the least distance and, among
// equal ones, the first cell in voronoi.h's order -- the cell, and the bits, of the full loop.
// Tested against it (shading_procedural_test.cpp, VoronoiF1NearestCellsFirst...).
struct F1Octants {
  // Per octant (bit i: the nearer neighbour along axis i is at +1), the 19 cells off the block,
  // padded to 24 with the last: their index in voronoi.h's order and, per axis, all ones where
  // the cell's offset is the nearer (near) or the farther (far) neighbour.
  int idx[8][24] = {};
  uint32_t near[8][3][24] = {}, far[8][3][24] = {};
  int block[8][8] = {};  // the block's cells, lane l: corner (l & 1, l >> 1 & 1, l >> 2 & 1)
  constexpr F1Octants() {
    for (int oct = 0; oct < 8; ++oct) {
      int n = 0;
      for (int idx_ = 0; idx_ < 27; ++idx_) {
        int o[3] = {idx_ % 3 - 1, idx_ / 3 % 3 - 1, idx_ / 9 - 1};
        bool in_block = true;
        for (int i = 0; i < 3; ++i) {
          const int side = (oct >> i & 1) ? 1 : -1;
          in_block = in_block && (o[i] == 0 || o[i] == side);
        }
        if (in_block) continue;
        for (int pad = n; pad < (n == 18 ? 24 : n + 1); ++pad) {
          idx[oct][pad] = idx_;
          for (int i = 0; i < 3; ++i) {
            const int side = (oct >> i & 1) ? 1 : -1;
            near[oct][i][pad] = o[i] == side ? 0xFFFFFFFFu : 0u;
            far[oct][i][pad] = o[i] == -side ? 0xFFFFFFFFu : 0u;
          }
        }
        ++n;
      }
      for (int l = 0; l < 8; ++l) {
        int id = 13;  // the centre (0, 0, 0)
        for (int i = 0, p3 = 1; i < 3; ++i, p3 *= 3)
          if (l >> i & 1) id += ((oct >> i & 1) ? 1 : -1) * p3;
        block[oct][l] = id;
      }
    }
  }
};
constexpr F1Octants kF1Octants{};

// The hashes, feature points and distances of eight cells (offsets off[3] per lane) around
// `cell`: cell_hashes and cell_points' operations for 3D, Euclidean.
GP_INLINE void f1_cells3(const VP<3>& cell, const VP<3>& local, float randomness, const f32x8* off, f32x8* h,
                         f32x8* pt, f32x8& dist) {
  u32x8 k[3];
  for (int i = 0; i < 3; ++i) k[i] = float_bits_v(cell[i] + off[i]);
  cell_hash3_v(k, h);
  f32x8 sum = f32x8{};
  for (int i = 0; i < 3; ++i) {
    pt[i] = off[i] + h[i] * randomness;
    const f32x8 d = pt[i] - local[i];
    sum = sum + d * d;
  }
  for (int l = 0; l < 8; ++l) dist[l] = std::sqrt(sum[l]);
}

// Of m cells measured: the least distance, the first in voronoi.h's order (ids) among equal ones.
GP_INLINE VoronoiOut f1_result(const float* dist, const float (&hh)[3][32], const float (&pp)[3][32], const int* ids,
                               int m, const VP<3>& cell) {
  int target = 0;
  for (int j = 1; j < m; ++j)
    if (dist[j] < dist[target] || (dist[j] == dist[target] && ids[j] < ids[target])) target = j;
  VoronoiOut out;
  out.distance = dist[target];
  out.color = Vec3(hh[0][target], hh[1][target], hh[2][target]);
  for (int i = 0; i < 3; ++i) out.position[i] = pp[i][target] + cell[i];
  return out;
}

// (Its own clones, not inlined into voronoi(): GCC's array-bounds analysis of the inlined
// 2D, 3D and 4D searches together then warns of VP<2> read as VP<3>, falsely.)
// p and randomness finite (the cell and local coordinates then are), randomness in [0, 1].
GP_AVX2_CLONES VoronoiOut voronoi_f1_euclidean3(const Vec4& p4, float randomness) {
  VP<3> cell, local;
  for (int i = 0; i < 3; ++i) {
    cell[i] = std::floor(p4[i]);
    local[i] = p4[i] - cell[i];
  }
  int oct = 0;
  float near_b[3], far_b[3];
  f32x8 off[3];
  const u32x8 corner[3] = {u32x8{} - kCornerX, u32x8{} - kCornerY, u32x8{} - kCornerZ};  // all ones: 1
  for (int i = 0; i < 3; ++i) {
    const bool up = !(local[i] < 0.5f);
    oct |= up << i;
    near_b[i] = up ? 1.0f - local[i] : local[i];
    far_b[i] = up ? local[i] : 1.0f - local[i];
    // The block's offsets: 0 or the nearer neighbour's (+0, never -0: the key's bits as the table's).
    off[i] = (f32x8)(corner[i] & detail::float_bits(up ? 1.0f : -1.0f));
  }
  // Up to 8 + 19 cells measured, lane by lane.
  float dist[32], hh[3][32], pp[3][32];
  int ids[32];
  int m = 8;
  {
    f32x8 h[3], pt[3], d;
    f1_cells3(cell, local, randomness, off, h, pt, d);
    std::memcpy(dist, &d, sizeof d);
    for (int i = 0; i < 3; ++i) std::memcpy(hh[i], &h[i], sizeof h[i]), std::memcpy(pp[i], &pt[i], sizeof pt[i]);
    for (int l = 0; l < 8; ++l) ids[l] = kF1Octants.block[oct][l];
  }
  float best = dist[0];
  for (int l = 1; l < 8; ++l) best = dist[l] < best ? dist[l] : best;
  // The least bound of the 19 other cells is that of a cell one farther neighbour away along a
  // single axis (the others' sums add terms to one of those): sqrt(far^2), formed as the bounds
  // are. Above `best` (most points): none of them can hold the least distance.
  float least_far = 8.0f;
  for (int i = 0; i < 3; ++i) least_far = std::min(least_far, std::sqrt(far_b[i] * far_b[i]));
  if (least_far > best) return f1_result(dist, hh, pp, ids, 8, cell);
  // The bounds of the 19 other cells; those not above `best` are measured too.
  float bound[24];
  f32x8 least_bound = f32x8{} + 8.0f;
  for (int base = 0; base < 24; base += 8) {
    f32x8 sum = f32x8{};
    for (int i = 0; i < 3; ++i) {
      u32x8 mn, mf;
      std::memcpy(&mn, &kF1Octants.near[oct][i][base], sizeof mn);
      std::memcpy(&mf, &kF1Octants.far[oct][i][base], sizeof mf);
      const f32x8 b = (f32x8)((mn & detail::float_bits(near_b[i])) | (mf & detail::float_bits(far_b[i])));
      sum = sum + b * b;
    }
    f32x8 r;
    for (int l = 0; l < 8; ++l) r[l] = std::sqrt(sum[l]);
    least_bound = (f32x8)select_bits<u32x8>(below_f(r, least_bound), r, least_bound);
    std::memcpy(&bound[base], &r, sizeof r);
  }
  float lb = least_bound[0];
  for (int l = 1; l < 8; ++l) lb = least_bound[l] < lb ? least_bound[l] : lb;
  if (!(lb > best)) {
    int list[24];
    int n = 0;
    for (int j = 0; j < 19; ++j) {
      list[n] = kF1Octants.idx[oct][j];
      n += !(bound[j] > best);
    }
    constexpr const CellOffsets<3, 1>& t = kCellOffsets<3, 1>;
    for (int base = 0; base < n; base += 8) {
      float o[3][8];
      for (int l = 0; l < 8; ++l) {
        const int id = list[base + l < n ? base + l : n - 1];
        ids[m + l] = id;
        for (int i = 0; i < 3; ++i) o[i][l] = t.o[i][id];
      }
      f32x8 offs[3], h[3], pt[3], d;
      for (int i = 0; i < 3; ++i) std::memcpy(&offs[i], o[i], sizeof offs[i]);
      f1_cells3(cell, local, randomness, offs, h, pt, d);
      std::memcpy(&dist[m], &d, sizeof d);
      for (int i = 0; i < 3; ++i) std::memcpy(&hh[i][m], &h[i], sizeof h[i]), std::memcpy(&pp[i][m], &pt[i], sizeof pt[i]);
      m += std::min(8, n - base);
    }
  }
  return f1_result(dist, hh, pp, ids, m, cell);
}

template <int N>
GP_INLINE VoronoiOut voronoi_n(VoronoiFeature feature, VoronoiMetric metric, const Vec4& p4, float smoothness, float exponent,
                     float randomness) {
  VP<N> coord, cell, local;
  for (int i = 0; i < N; ++i) {
    coord[i] = p4[i];
    cell[i] = std::floor(coord[i]);
    local[i] = coord[i] - cell[i];
  }
  VoronoiOut out;
  // The feature points of the 3^N cells around (5^N for smooth F1), hashed together up front.
  CellHashTable<N> hashes;
  if (feature == VoronoiFeature::SmoothF1) cell_hashes<N, 2>(cell, hashes);
  else cell_hashes<N, 1>(cell, hashes);
  CellHashTable<N> points;
  float dist[CellOffsets<N, 2>::kPadded];
  if (feature == VoronoiFeature::SmoothF1) cell_points<N, 2>(hashes, local, randomness, metric, exponent, points, dist);
  else cell_points<N, 1>(hashes, local, randomness, metric, exponent, points, dist);
  // (offset + cell_hash(cell + offset) * randomness)
  auto point_in = [&](int idx, const VP<N>&) {
    VP<N> pp;
    for (int i = 0; i < N; ++i) pp[i] = points[i][idx];
    return pp;
  };
  // A cell's colour: for 3D the same hash as its point (hash_float3_to_float3).
  auto color_of = [&](int idx, const VP<N>& offset) {
    if constexpr (N == 3) return Vec3(hashes[0][idx], hashes[1][idx], hashes[2][idx]);
    else return cell_color(cell + offset);
  };
  auto set_position = [&](const VP<N>& pos) {
    for (int i = 0; i < N; ++i) out.position[i] = pos[i];
  };
  switch (feature) {
    case VoronoiFeature::F1: {
      // voronoi.h's loop keeps the first cell whose distance is below all before it and below
      // 8: the first cell holding the least distance under 8. The least is found over the
      // lanes (the padding repeats the last cell: the same least), then its first cell.
      constexpr const CellOffsets<N, 1>& t = kCellOffsets<N, 1>;
      f32x8 m = f32x8{} + 8.0f;
      for (int base = 0; base < t.kPadded; base += 8) {
        f32x8 d;
        std::memcpy(&d, &dist[base], sizeof d);
        m = (f32x8)select_bits<u32x8>((u32x8)(d < m), d, m);  // NaN never below
      }
      float least = 8.0f;
      for (int l = 0; l < 8; ++l) least = m[l] < least ? m[l] : least;
      float min_d = 8.0f;
      VP<N> target_offset{}, target_pos{};
      int target = 0;
      if (least < 8.0f) {
        while (!(dist[target] == least)) ++target;
        min_d = dist[target];  // (its own bits: a zero's sign as the loop's)
        for (int i = 0; i < N; ++i) target_offset[i] = t.o[i][target];
        target_pos = point_in(target, target_offset);
      }
      out.distance = min_d;
      out.color = color_of(target, target_offset);
      set_position(target_pos + cell);
      break;
    }
    case VoronoiFeature::SmoothF1: {
      float smooth_d = 8.0f;
      Vec3 smooth_color;
      VP<N> smooth_pos{};
      for_cells<N, 2>([&](int idx, const VP<N>& o) {
        const VP<N> pp = point_in(idx, o);
        const float d = dist[idx];  // metric_distance(pp, local, metric, exponent)
        const float h = smoothstep01(0.5f + 0.5f * (smooth_d - d) / smoothness);
        float correction = smoothness * h * (1.0f - h);
        smooth_d = lerp(smooth_d, d, h) - correction;
        correction /= 1.0f + 3.0f * smoothness;
        const Vec3 c = color_of(idx, o);
        smooth_color = smooth_color * (1.0f - h) + c * h - Vec3(correction);
        VP<N> corr;
        for (int i = 0; i < N; ++i) corr[i] = correction;
        smooth_pos = vmix(smooth_pos, pp, h) - corr;
      });
      out.distance = smooth_d;
      out.color = smooth_color;
      set_position(cell + smooth_pos);
      break;
    }
    case VoronoiFeature::F2: {
      float d1 = 8.0f, d2 = 8.0f;
      VP<N> off1{}, pos1{}, off2{}, pos2{};
      int idx1 = 0, idx2 = 0;
      for_cells<N, 1>([&](int idx, const VP<N>& o) {
        const VP<N> pp = point_in(idx, o);
        const float d = dist[idx];  // metric_distance(pp, local, metric, exponent)
        if (d < d1) {
          d2 = d1, d1 = d, off2 = off1, off1 = o, pos2 = pos1, pos1 = pp, idx2 = idx1, idx1 = idx;
        } else if (d < d2) {
          d2 = d, off2 = o, pos2 = pp, idx2 = idx;
        }
      });
      out.distance = d2;
      out.color = color_of(idx2, off2);
      set_position(pos2 + cell);
      break;
    }
    case VoronoiFeature::DistanceToEdge: {
      if constexpr (N == 1) {
        const float mid = cell_hash(cell)[0] * randomness;
        VP<1> cl, cr;
        cl[0] = cell[0] - 1.0f, cr[0] = cell[0] + 1.0f;
        const float left = -1.0f + cell_hash(cl)[0] * randomness;
        const float right = 1.0f + cell_hash(cr)[0] * randomness;
        out.distance = std::min(std::abs((mid + left) / 2.0f - local[0]), std::abs((mid + right) / 2.0f - local[0]));
      } else {
        VP<N> to_closest{};
        float min_d = 8.0f;
        for_cells<N, 1>([&](int idx, const VP<N>& o) {
          const VP<N> v = point_in(idx, o) - local;
          const float d = vdot(v, v);
          if (d < min_d) min_d = d, to_closest = v;
        });
        min_d = 8.0f;
        for_cells<N, 1>([&](int idx, const VP<N>& o) {
          const VP<N> v = point_in(idx, o) - local;
          const VP<N> perp = v - to_closest;
          if (vdot(perp, perp) > 0.0001f) {
            const float d = vdot((to_closest + v) * 0.5f, perp * (1.0f / vlen(perp)));
            min_d = std::min(min_d, d);
          }
        });
        out.distance = min_d;
      }
      break;
    }
    case VoronoiFeature::NSphereRadius: {
      VP<N> closest{}, closest_offset{};
      float min_d = 8.0f;
      for_cells<N, 1>([&](int idx, const VP<N>& o) {
        const VP<N> pp = point_in(idx, o);
        const float d = vlen(pp - local);
        if (d < min_d) min_d = d, closest = pp, closest_offset = o;
      });
      min_d = 8.0f;
      VP<N> closest_to_closest{};
      for_cells<N, 1>([&](int, const VP<N>& o) {
        bool centre = true;
        for (int i = 0; i < N; ++i) centre = centre && o[i] == 0.0f;
        if (centre) return;
        const VP<N> off = o + closest_offset;
        const VP<N> pp = off + cell_hash(cell + off) * randomness;
        const float d = vlen(closest - pp);
        if (d < min_d) min_d = d, closest_to_closest = pp;
      });
      out.radius = vlen(closest_to_closest - closest) / 2.0f;
      break;
    }
  }
  return out;
}

}  // namespace

GP_AVX2_CLONES VoronoiOut voronoi(VoronoiFeature feature, VoronoiMetric metric, const Vec4& p, int dims, float smoothness,
                   float exponent, float randomness) {
  switch (dims) {
    case 1: return voronoi_n<1>(feature, metric, p, smoothness, exponent, randomness);
    case 2: return voronoi_n<2>(feature, metric, p, smoothness, exponent, randomness);
    case 3:
      // (A NaN point or randomness: the full loop, whose comparisons then keep 8 and cell 0.)
      if (feature == VoronoiFeature::F1 && metric == VoronoiMetric::Euclidean && std::isfinite(p[0]) &&
          std::isfinite(p[1]) && std::isfinite(p[2]) && std::isfinite(randomness))
        return voronoi_f1_euclidean3(p, randomness);
      return voronoi_n<3>(feature, metric, p, smoothness, exponent, randomness);
    default: return voronoi_n<4>(feature, metric, p, smoothness, exponent, randomness);
  }
}

#pragma GCC diagnostic pop

// ---- Wave, Magic, Gradient, Checker, Brick, White Noise ----

float wave(WaveType type, WaveDirection bands_dir, WaveDirection rings_dir, WaveProfile profile, Vec3 p,
           float distortion, float detail, float detail_scale, float detail_roughness, float phase) {
  // wave.h: nudged off integer lattice planes as Cycles does.
  p = (p + Vec3(0.000001f)) * 0.999999f;
  float n;
  if (type == WaveType::Bands) {
    switch (bands_dir) {
      case WaveDirection::X: n = p.x * 20.0f; break;
      case WaveDirection::Y: n = p.y * 20.0f; break;
      case WaveDirection::Z: n = p.z * 20.0f; break;
      default: n = (p.x + p.y + p.z) * 10.0f; break;
    }
  } else {
    Vec3 rp = p;
    switch (rings_dir) {
      case WaveDirection::X: rp.x = 0; break;
      case WaveDirection::Y: rp.y = 0; break;
      case WaveDirection::Z: rp.z = 0; break;
      default: break;
    }
    n = std::sqrt(dot(rp, rp)) * 20.0f;
  }
  n += phase;
  if (distortion != 0.0f) {
    Vec4 q;
    q[0] = p.x * detail_scale, q[1] = p.y * detail_scale, q[2] = p.z * detail_scale;
    n += distortion * (fractal_noise(q, 3, detail, detail_roughness) * 2.0f - 1.0f);
  }
  switch (profile) {
    case WaveProfile::Saw: {
      n /= 2.0f * kPiF;
      return n - std::floor(n);
    }
    case WaveProfile::Tri: {
      n /= 2.0f * kPiF;
      return std::abs(n - std::floor(n + 0.5f)) * 2.0f;
    }
    default: return 0.5f + 0.5f * std::sin(n - kPiF / 2.0f);
  }
}

Vec3 magic(Vec3 p, int n, float d) {
  // magic.h (3.4: the coordinate already scaled, no period wrap).
  float x = std::sin((p.x + p.y + p.z) * 5.0f);
  float y = std::cos((-p.x + p.y - p.z) * 5.0f);
  float z = -std::cos((-p.x - p.y + p.z) * 5.0f);
  if (n > 0) {
    x *= d, y *= d, z *= d;
    y = -std::cos(x - y + z) * d;
    if (n > 1) {
      x = std::cos(x - y - z) * d;
      if (n > 2) {
        z = std::sin(-x - y - z) * d;
        if (n > 3) {
          x = -std::cos(-x + y - z) * d;
          if (n > 4) {
            y = -std::sin(-x + y + z) * d;
            if (n > 5) {
              y = -std::cos(-x + y + z) * d;
              if (n > 6) {
                x = std::cos(x + y + z) * d;
                if (n > 7) {
                  z = std::sin(x + y - z) * d;
                  if (n > 8) {
                    x = -std::cos(-x - y + z) * d;
                    if (n > 9) y = -std::sin(x - y + z) * d;
                  }
                }
              }
            }
          }
        }
      }
    }
  }
  if (d != 0.0f) {
    d *= 2.0f;
    x /= d, y /= d, z /= d;
  }
  return {0.5f - x, 0.5f - y, 0.5f - z};
}

float gradient(GradientType type, Vec3 p) {
  switch (type) {
    case GradientType::Linear: return p.x;
    case GradientType::Quadratic: {
      const float r = std::max(p.x, 0.0f);
      return r * r;
    }
    case GradientType::Easing: {
      const float r = std::min(std::max(p.x, 0.0f), 1.0f);
      const float t = r * r;
      return 3.0f * t - 2.0f * t * r;
    }
    case GradientType::Diagonal: return (p.x + p.y) * 0.5f;
    case GradientType::Radial: return std::atan2(p.y, p.x) / (2.0f * kPiF) + 0.5f;
    case GradientType::QuadraticSphere: {
      const float r = std::max(0.999999f - std::sqrt(dot(p, p)), 0.0f);
      return r * r;
    }
    case GradientType::Spherical: return std::max(0.999999f - std::sqrt(dot(p, p)), 0.0f);
  }
  return 0.0f;
}

// An AVX2 clone too: there each floor is one vroundss (the SSE2 build emulates it in about a
// dozen instructions), the same value.
GP_AVX2_CLONES float checker(Vec3 p) {
  // checker.h: nudged so faces on integer planes do not flicker between squares.
  p.x = (p.x + 0.000001f) * 0.999999f;
  p.y = (p.y + 0.000001f) * 0.999999f;
  p.z = (p.z + 0.000001f) * 0.999999f;
  const int xi = static_cast<int>(std::floor(p.x));
  const int yi = static_cast<int>(std::floor(p.y));
  const int zi = static_cast<int>(std::floor(p.z));
  // checker.h's ((|xi| % 2 == |yi| % 2) == |zi| % 2) of the three parities a, b, c (abs keeps an
  // int's parity) is (1 ^ a ^ b) == c, that is a ^ b ^ c.
  return ((xi ^ yi ^ zi) & 1) ? 1.0f : 0.0f;
}

namespace {
float brick_noise(uint32_t n) {  // brick.h's integer noise
  n = (n + 1013) & 0x7fffffff;
  n = (n >> 13) ^ n;
  const uint32_t nn = (n * (n * n * 60493 + 19990303) + 1376312589) & 0x7fffffff;
  return 0.5f * (static_cast<float>(nn) / 1073741824.0f);
}
}  // namespace

void brick(Vec3 p, float mortar_size, float mortar_smooth, float bias, float brick_width, float row_height,
           float offset_amount, int offset_frequency, float squash_amount, int squash_frequency, float* tint,
           float* mortar) {
  const int rownum = static_cast<int>(std::floor(p.y / row_height));
  float offset = 0.0f;
  if (offset_frequency && squash_frequency) {
    brick_width *= (rownum % squash_frequency) ? 1.0f : squash_amount;
    offset = (rownum % offset_frequency) ? 0.0f : (brick_width * offset_amount);
  }
  const int bricknum = static_cast<int>(std::floor((p.x + offset) / brick_width));
  const float x = (p.x + offset) - brick_width * bricknum;
  const float y = p.y - row_height * rownum;
  *tint = std::clamp(brick_noise((static_cast<uint32_t>(rownum) << 16) + (bricknum & 0xFFFF)) + bias, 0.0f, 1.0f);
  float min_dist = std::min(std::min(x, y), std::min(brick_width - x, row_height - y));
  if (min_dist >= mortar_size) {
    *mortar = 0.0f;
  } else if (mortar_smooth == 0.0f) {
    *mortar = 1.0f;
  } else {
    min_dist = 1.0f - min_dist / mortar_size;
    *mortar = smoothstep01(min_dist / mortar_smooth);
  }
}

void white_noise(const Vec4& p, int dims, float* value, Vec3* color) {
  switch (dims) {
    case 1:
      *value = hash_float_to_float(p[0]);
      *color = hash_float_to_float3(p[0]);
      break;
    case 2:
      *value = hash_float2_to_float(p[0], p[1]);
      *color = hash_float2_to_float3(p[0], p[1]);
      break;
    case 3:
      *value = hash_float3_to_float(p[0], p[1], p[2]);
      *color = hash_float3_to_float3(Vec3(p[0], p[1], p[2]));
      break;
    default:
      *value = hash_float4_to_float(p[0], p[1], p[2], p[3]);
      *color = hash_float4_to_float3(p[0], p[1], p[2], p[3]);
      break;
  }
}

}  // namespace gp::shading
