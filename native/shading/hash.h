// Cycles' hashes (intern/cycles/util/hash.h): Bob Jenkins' lookup3 "final" mix over one to four
// 32-bit keys, and the float hashes the procedural textures seed with. Pixel-exact agreement
// with Cycles' Noise, Voronoi and White Noise textures depends on these bit for bit.
#pragma once

#include <cstdint>
#include <cstring>

#include "core/math.h"

#define GP_VECTOR_INLINE inline __attribute__((always_inline))

namespace gp::shading {

namespace detail {
// lookup3's rot, mix(a, b, c) and final(a, b, c), written once for a 32-bit key (U = uint32_t)
// and for vectors of them (U = u32x8 below: several keys at once, lane by lane the same bits).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"  // always inlined: no vector crosses a call (below)
template <class U>
GP_VECTOR_INLINE U rot_v(const U& x, int k) {
  return (x << k) | (x >> (32 - k));
}
template <class U>
GP_VECTOR_INLINE void jenkins_mix_v(U& a, U& b, U& c) {
  a -= c; a ^= rot_v(c, 4); c += b;
  b -= a; b ^= rot_v(a, 6); a += c;
  c -= b; c ^= rot_v(b, 8); b += a;
  a -= c; a ^= rot_v(c, 16); c += b;
  b -= a; b ^= rot_v(a, 19); a += c;
  c -= b; c ^= rot_v(b, 4); b += a;
}
template <class U>
GP_VECTOR_INLINE void jenkins_final_v(U& a, U& b, U& c) {
  c ^= b; c -= rot_v(b, 14);
  a ^= c; a -= rot_v(c, 11);
  b ^= a; b -= rot_v(a, 25);
  c ^= b; c -= rot_v(b, 16);
  a ^= c; a -= rot_v(c, 4);
  b ^= a; b -= rot_v(a, 14);
  c ^= b; c -= rot_v(b, 24);
}
#pragma GCC diagnostic pop
inline void jenkins_mix(uint32_t& a, uint32_t& b, uint32_t& c) { jenkins_mix_v(a, b, c); }
inline void jenkins_final(uint32_t& a, uint32_t& b, uint32_t& c) { jenkins_final_v(a, b, c); }
inline uint32_t float_bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}
}  // namespace detail

// hash_uint .. hash_uint4 of util/hash.h: seeds 0xdeadbeef + (n << 2) + 13 for n keys.
inline uint32_t hash_uint(uint32_t kx) {
  uint32_t a, b, c;
  a = b = c = 0xdeadbeefu + (1u << 2) + 13u;
  a += kx;
  detail::jenkins_final(a, b, c);
  return c;
}
inline uint32_t hash_uint2(uint32_t kx, uint32_t ky) {
  uint32_t a, b, c;
  a = b = c = 0xdeadbeefu + (2u << 2) + 13u;
  b += ky;
  a += kx;
  detail::jenkins_final(a, b, c);
  return c;
}
inline uint32_t hash_uint3(uint32_t kx, uint32_t ky, uint32_t kz) {
  uint32_t a, b, c;
  a = b = c = 0xdeadbeefu + (3u << 2) + 13u;
  c += kz;
  b += ky;
  a += kx;
  detail::jenkins_final(a, b, c);
  return c;
}
inline uint32_t hash_uint4(uint32_t kx, uint32_t ky, uint32_t kz, uint32_t kw) {
  uint32_t a, b, c;
  a = b = c = 0xdeadbeefu + (4u << 2) + 13u;
  a += kx;
  b += ky;
  c += kz;
  detail::jenkins_mix(a, b, c);
  a += kw;
  detail::jenkins_final(a, b, c);
  return c;
}

// [0, 2^32 - 1] -> [0, 1] (uint_to_float_incl).
inline float uint_to_float_incl(uint32_t n) { return static_cast<float>(n) * (1.0f / static_cast<float>(0xFFFFFFFFu)); }

inline float hash_float_to_float(float k) { return uint_to_float_incl(hash_uint(detail::float_bits(k))); }
inline float hash_float2_to_float(float x, float y) {
  return uint_to_float_incl(hash_uint2(detail::float_bits(x), detail::float_bits(y)));
}
inline float hash_float3_to_float(float x, float y, float z) {
  return uint_to_float_incl(hash_uint3(detail::float_bits(x), detail::float_bits(y), detail::float_bits(z)));
}
inline float hash_float4_to_float(float x, float y, float z, float w) {
  return uint_to_float_incl(
      hash_uint4(detail::float_bits(x), detail::float_bits(y), detail::float_bits(z), detail::float_bits(w)));
}

// The vector-valued hashes (util/hash.h: hash_float*_to_float2/3/4), component orders as there.
inline Vec3 hash_float_to_float3(float k) {
  return {hash_float_to_float(k), hash_float2_to_float(k, 1.0f), hash_float2_to_float(k, 2.0f)};
}
inline Vec3 hash_float2_to_float3(float x, float y) {
  return {hash_float2_to_float(x, y), hash_float3_to_float(x, y, 1.0f), hash_float3_to_float(x, y, 2.0f)};
}
inline Vec3 hash_float3_to_float3(const Vec3& k) {
  return {hash_float3_to_float(k.x, k.y, k.z), hash_float4_to_float(k.x, k.y, k.z, 1.0f),
          hash_float4_to_float(k.x, k.y, k.z, 2.0f)};
}
inline Vec3 hash_float4_to_float3(float x, float y, float z, float w) {
  return {hash_float4_to_float(x, y, z, w), hash_float4_to_float(z, x, w, y), hash_float4_to_float(w, z, y, x)};
}

// ---- Several keys at once ----
// The same lookup3 lines over GCC/Clang vector types (U: uint32_t lanes), so a Perlin cell's
// eight corners or a Voronoi neighbourhood's cells hash together (Cycles' SSE/AVX noise does the
// same, kernel/svm/noise.h). Integer operations lane by lane: bit for bit the scalar hashes.
// Always inlined: a vector of 32 bytes passed or returned by value has no common ABI between
// an AVX2 caller (procedural.cpp's target clones) and code built without AVX.
// (Inline only: 32-byte vectors by value have no fixed ABI without AVX, which GCC warns of.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
using u32x8 = uint32_t __attribute__((vector_size(32)));
using i32x8 = int32_t __attribute__((vector_size(32)));
using f32x8 = float __attribute__((vector_size(32)));

template <class U>
GP_VECTOR_INLINE U hash_uint_v(const U& kx) {
  U a = U{} + (0xdeadbeefu + (1u << 2) + 13u), b = a, c = a;
  a += kx;
  detail::jenkins_final_v(a, b, c);
  return c;
}
template <class U>
GP_VECTOR_INLINE U hash_uint2_v(const U& kx, const U& ky) {
  U a = U{} + (0xdeadbeefu + (2u << 2) + 13u), b = a, c = a;
  b += ky;
  a += kx;
  detail::jenkins_final_v(a, b, c);
  return c;
}
template <class U>
GP_VECTOR_INLINE U hash_uint3_v(const U& kx, const U& ky, const U& kz) {
  U a = U{} + (0xdeadbeefu + (3u << 2) + 13u), b = a, c = a;
  c += kz;
  b += ky;
  a += kx;
  detail::jenkins_final_v(a, b, c);
  return c;
}
template <class U>
GP_VECTOR_INLINE U hash_uint4_v(const U& kx, const U& ky, const U& kz, const U& kw) {
  U a = U{} + (0xdeadbeefu + (4u << 2) + 13u), b = a, c = a;
  a += kx;
  b += ky;
  c += kz;
  detail::jenkins_mix_v(a, b, c);
  a += kw;
  detail::jenkins_final_v(a, b, c);
  return c;
}
// uint_to_float_incl lane by lane: the high and low 16 bits convert exactly and their sum is
// rounded once, so each lane is static_cast<float>(n) (correctly rounded) as in the scalar one.
GP_VECTOR_INLINE f32x8 uint_to_float_incl_v(const u32x8& n) {
  const f32x8 hi = __builtin_convertvector((i32x8)(n >> 16), f32x8) * 65536.0f;
  const f32x8 lo = __builtin_convertvector((i32x8)(n & 0xFFFFu), f32x8);
  return (hi + lo) * (1.0f / static_cast<float>(0xFFFFFFFFu));
}
// The bits of each float lane (float_bits).
GP_VECTOR_INLINE u32x8 float_bits_v(const f32x8& f) { return (u32x8)f; }
#pragma GCC diagnostic pop

// Cycles' hash_string (util/hash.h: h = h * 37 + c), which names an object's random number
// (measured against Cycles 3.4: Object Info Random of "Plane" is 0.13576; x31, Blender's own
// BLI_hash_string, gave 0.5985).
inline uint32_t hash_string_x37(const char* s) {
  uint32_t h = 0;
  for (; *s; ++s) h = h * 37u + static_cast<uint8_t>(*s);
  return h;
}

}  // namespace gp::shading
