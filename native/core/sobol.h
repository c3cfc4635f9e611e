// Owen-scrambled Sobol points by hashing (Burley 2020, "Practical Hash-based Owen Scrambling",
// JCGT 9(4)): the low-discrepancy pattern of the camera-path loop (core/sampler.h SobolSampler).
//
// sobol_owen(r, d, seed) is dimension d < kSobolDimensions of a point of the Sobol sequence (Joe
// & Kuo's direction numbers; dimension 0 is van der Corput's radical inverse), scrambled, as a
// 32-bit fixed-point fraction. Dimensions 0 and 1 form a (0,2)-sequence: every aligned block of 2^k
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
  v = __builtin_bswap32(v);  // bytes, then the bits within each byte
  v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  return ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
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
// The matrices in the bit-reversed domain, sliced by byte: entry [d][b][x] is reverse(v) for the
// point v of dimension d whose index, bit-reversed, has byte b equal to x and the other bytes 0
// (XOR over the bytes gives any index). Working on reversed indices and values saves the
// reversals of nested_uniform_scramble around the index shuffle and the point's scramble
// (sobol_owen below; Burley 2020 §5 notes the same).
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
        for (int j = 0; j < 8; ++j)
          if (x & (1 << j)) v ^= reverse_bits(m[d][31 - (8 * b + j)]);  // bit 8b+j of reverse(i) is bit 31-8b-j of i
        out.t[d][b][x] = v;
      }
  return out;
}
inline constexpr ByteTables kTables = byte_tables();
}  // namespace sobol_detail

// Dimension d (0 or 1) of the Sobol point with index i, both bit-reversed: for r = reverse(i),
// reverse(sobol point i's bits in dimension d).
inline uint32_t sobol_reversed(uint32_t r, int d) {
  const auto& t = sobol_detail::kTables.t[d];
  return t[0][r & 0xFF] ^ t[1][(r >> 8) & 0xFF] ^ t[2][(r >> 16) & 0xFF] ^ t[3][r >> 24];
}

// Shuffled, Owen-scrambled Sobol: with r = laine_karras_permutation(reverse_bits(index),
// shuffle_seed) (the shuffled index nested_uniform_scramble(index, shuffle_seed), bit-reversed),
// dimension d of that point scrambled by `seed`, as bits of a fraction:
// nested_uniform_scramble(sobol point, seed) = reverse(LK(reverse(point), seed)).
inline uint32_t sobol_owen(uint32_t r, int d, uint32_t seed) {
  return reverse_bits(laine_karras_permutation(sobol_reversed(r, d), seed));
}

// 32 bits of a fraction as a float in [0, 1): the top 24 bits, so it never rounds up to 1.
inline float bits_to_unit(uint32_t v) { return static_cast<float>(v >> 8) * 0x1p-24f; }

}  // namespace gp
