// Where an estimator takes its random numbers from. Path samplers that may be driven either by
// independent streams (path tracing) or by a Markov chain over primary sample space (Kelemen et
// al. 2002; gradient-domain MLT) consume uniforms through this interface, in a fixed order.
#pragma once

#include "core/rng.h"

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

}  // namespace gp
