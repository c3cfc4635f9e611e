// Where an estimator takes its random numbers from. Path samplers that may be driven either by
// independent streams (path tracing) or by a Markov chain over primary sample space (Kelemen et
// al. 2002; gradient-domain MLT) consume uniforms through this interface, in a fixed order.
//
// The camera-path loop of pt, spt and spt-hero (integrators/paths/camera_path.h) instead takes
// its numbers by dimension, from one of two value types with the same two calls:
//
//   float get1d(int dim);  Vec2 get2d(int dim);
//
// IndependentSampler (the pixel's PCG32 stream, dimensions ignored: the order of the calls is
// the order of the draws) or SobolSampler (each dimension its own Owen-scrambled Sobol set, the
// sample index the pass). `dim` is a camera dimension (CameraDim) or a vertex's (path_dim).
#pragma once

#include <cstdint>
#include <string>

#include "core/math.h"
#include "core/rng.h"
#include "core/sobol.h"

namespace gp {

class Sampler {
 public:
  virtual ~Sampler() = default;
  // Next uniform number in [0, 1).
  virtual float uniform() = 0;
};

// Independent uniforms from a PCG32 stream (the ordinary Monte Carlo case).
class RngSampler final : public Sampler {
 public:
  explicit RngSampler(Rng& rng) : rng_(rng) {}
  float uniform() override { return rng_.uniform(); }

 private:
  Rng& rng_;
};

// ---- The camera-path loop's samplers ----

// How pt, spt and spt-hero draw their numbers (parameter `sampling_pattern`, methods.cpp).
enum class SamplingPattern { Sobol, Independent };

// `sampling_pattern`'s value (its choices are checked by its declaration).
inline SamplingPattern parse_sampling_pattern(const std::string& s) {
  return s == "independent" ? SamplingPattern::Independent : SamplingPattern::Sobol;
}

// The dimensions of a camera path, each a 1D or 2D set, laid out as the loop consumes them
// (Cycles 3.4 lays out its PRNG_* dimensions alike: the camera's, then a fixed block per bounce).
enum CameraDim : int { kDimFilter = 0, kDimLens, kDimTime, kDimWavelength, kCameraDims };
enum VertexDim : int {
  kDimMediumChannel = 0, kDimMediumDistance,              // free flight (channel pick, distance)
  kDimEquiangularLight, kDimEquiangularLight2, kDimEquiangularT,  // equiangular next-event
  kDimLight, kDimLight2,                                  // next-event estimation: light, point
  kDimLobe, kDimScatter2,                                 // BSDF or phase: lobe, direction
  kDimRoulette,                                           // Russian roulette
  kVertexDims
};
// Dimension `d` of the `vertex`-th segment of the path (every loop iteration, pass-through ones
// included, is a new segment, so no dimension is drawn twice in one path).
inline int path_dim(int vertex, VertexDim d) { return kCameraDims + vertex * kVertexDims + d; }

// The pixel's PCG32 stream: the numbers in the order they are asked for (the images of the
// independent pattern are those of before the Sobol pattern, bit for bit).
struct IndependentSampler {
  Rng& rng;
  float get1d(int) { return rng.uniform(); }
  Vec2 get2d(int) { return Vec2(rng.uniform(), rng.uniform()); }
};

// Owen-scrambled, shuffled and padded Sobol points (core/sobol.h, Burley 2020 §5-6): sample
// `index` of the pixel (its pass) in every dimension; each dimension's shuffle and scrambles are
// hashed from the render seed, the pixel and the dimension, so every pixel and every seed has
// its own independent scramble (a distributed render's seeds stay independent runs) and every
// power-of-two prefix of a pixel's samples is stratified in each 1D and 2D dimension. Dimensions
// from kSobolDims on (deep vertices, where stratification no longer pays for itself) come from
// the pixel's PCG32 stream.
class SobolSampler {
 public:
  static constexpr int kSobolDims = kCameraDims + 8 * kVertexDims;  // 8 segments
  SobolSampler() = default;
  SobolSampler(uint64_t seed, uint64_t pixel, uint64_t index, Rng rng)
      : key_(mix_bits(seed * 0x9E3779B97F4A7C15ULL ^ mix_bits(pixel + 0x2545F4914F6CDD1DULL))),
        reversed_index_(reverse_bits(static_cast<uint32_t>(index))), rng_(rng) {}

  float get1d(int dim) {
    if (dim >= kSobolDims) return rng_.uniform();
    const uint64_t h = hash(dim);
    const uint32_t r = laine_karras_permutation(reversed_index_, static_cast<uint32_t>(h));  // the shuffle
    return bits_to_unit(sobol_owen(r, 0, static_cast<uint32_t>(h >> 32)));
  }
  Vec2 get2d(int dim) {
    if (dim >= kSobolDims) {
      const float u = rng_.uniform();
      return Vec2(u, rng_.uniform());
    }
    const uint64_t h = hash(dim), h2 = mix_bits(h);
    const uint32_t r = laine_karras_permutation(reversed_index_, static_cast<uint32_t>(h));
    return Vec2(bits_to_unit(sobol_owen(r, 0, static_cast<uint32_t>(h >> 32))),
                bits_to_unit(sobol_owen(r, 1, static_cast<uint32_t>(h2))));
  }

 private:
  uint64_t hash(int dim) const { return mix_bits(key_ + static_cast<uint64_t>(dim + 1) * 0xD1B54A32D192ED03ULL); }
  uint64_t key_ = 0;
  uint32_t reversed_index_ = 0;  // the sample index, bit-reversed (core/sobol.h sobol_owen)
  Rng rng_;
};

}  // namespace gp
