// Owen-scrambled Sobol points by hashing (Burley 2020, "Practical Hash-based Owen Scrambling",
// JCGT 9(4)): the low-discrepancy pattern of the camera-path loop (core/sampler.h SobolSampler).
//
// sobol_bits(i, d) is dimension d < kSobolDimensions of the i-th point of the Sobol sequence
// (Joe & Kuo's direction numbers; dimension 0 is van der Corput's radical inverse), as a 32-bit
// fixed-point fraction. Dimensions 0 and 1 form a (0,2)-sequence: every aligned block of 2^k
// points is a (0,k,2)-net (each elementary interval of area 2^-k holds exactly one point).
//
// nested_uniform_scramble(v, seed) is Owen's nested uniform scrambling of v's base-2 digits
// drawn from a hash (Burley 2020 §3-4: reverse the bits, apply the Laine-Karras permutation,
// whose output bit k depends only on input bits <= k, reverse again). Owen scrambling keeps
// every net a net and makes each point uniform on [0,1) over the seeds (unbiased estimates).
// Applied to the sample index (Burley §5, "shuffling") it permutes the sequence in aligned
// blocks: for every k, samples 0..2^k-1 land on one aligned block of 2^k Sobol points, so any
// prefix of 2^k samples of a pixel stays a net, and a set of dimensions shuffled with its own
// seed is independent of the others (padding, Burley §6).
//
// Written here rather than taken from a library: Debian's QMC generators (GSL's gsl_qrng_sobol,
// Boost.Random's sobol engine) draw points in order and have no hash-based Owen scrambling.
#pragma once

#include <array>
#include <cstdint>

namespace gp {

inline constexpr int kSobolDimensions = 2;

inline constexpr uint32_t reverse_bits(uint32_t v) {
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
  v = ((v >> 8) & 0x00FF00FFu) | ((v & 0x00FF00FFu) << 8);
  return (v >> 16) | (v << 16);
}

// Laine & Karras 2011's permutation with Burley 2020's constants (§4, the improved hash).
inline constexpr uint32_t laine_karras_permutation(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

inline constexpr uint32_t nested_uniform_scramble(uint32_t v, uint32_t seed) {
  return reverse_bits(laine_karras_permutation(reverse_bits(v), seed));
}

namespace sobol_detail {
// Generator matrix columns of dimension d (column k multiplies bit k of the index). Dimension 1
// is Joe & Kuo's first primitive polynomial x + 1 (s = 1, a = 0, m1 = 1): v_k = v_{k-1} ^
// (v_{k-1} >> 1), v_0 = 2^31 (Bratley & Fox 1988's recurrence).
inline constexpr std::array<std::array<uint32_t, 32>, kSobolDimensions> matrices() {
  std::array<std::array<uint32_t, 32>, kSobolDimensions> m{};
  for (int k = 0; k < 32; ++k) m[0][k] = 1u << (31 - k);
  m[1][0] = 1u << 31;
  for (int k = 1; k < 32; ++k) m[1][k] = m[1][k - 1] ^ (m[1][k - 1] >> 1);
  return m;
}
// The same matrices sliced by index byte: entry [d][b][x] is the XOR of the columns that byte b
// of the index selects when its value is x (four lookups per point instead of 32 steps).
struct ByteTables {
  uint32_t t[kSobolDimensions][4][256];
};
inline constexpr ByteTables byte_tables() {
  ByteTables out{};
  const auto m = matrices();
  for (int d = 0; d < kSobolDimensions; ++d)
    for (int b = 0; b < 4; ++b)
      for (int x = 0; x < 256; ++x) {
        uint32_t v = 0;
        for (int k = 0; k < 8; ++k)
          if (x & (1 << k)) v ^= m[d][8 * b + k];
        out.t[d][b][x] = v;
      }
  return out;
}
inline constexpr ByteTables kTables = byte_tables();
}  // namespace sobol_detail

// Dimension d (0 or 1) of Sobol point i, as bits of a fraction (value = bits * 2^-32).
inline uint32_t sobol_bits(uint32_t i, int d) {
  if (d == 0) return reverse_bits(i);
  const auto& t = sobol_detail::kTables.t[d];
  return t[0][i & 0xFF] ^ t[1][(i >> 8) & 0xFF] ^ t[2][(i >> 16) & 0xFF] ^ t[3][i >> 24];
}

// 32 bits of a fraction as a float in [0, 1): the top 24 bits, so it never rounds up to 1.
inline float bits_to_unit(uint32_t v) { return static_cast<float>(v >> 8) * 0x1p-24f; }

}  // namespace gp
