// Gradient-domain Metropolis light transport (Lehtinen, Karras, Laine, Aittala, Durand, Aila 2013,
// "Gradient-domain Metropolis light transport"; the GD-MLT slides in shared/papers), here in
// primary sample space (Kelemen et al. 2002, "A simple and robust mutation strategy for the
// Metropolis light transport algorithm").
//
// A state of each Markov chain is a primary sample vector u in [0,1)^inf. It is turned into a
// film position over the whole image (u0, u1), a lens sample (u2, u3) and the random decisions of
// one gradient-domain path sample: a base path and its four shifted offsets (left, right, up,
// down), traced by GradientPathTracer::trace with its shifts and MIS (gpt.h, shift.h), which
// reads u through the Sampler interface. The chain's target function is
//   T(u) = sum_d lum|Delta_d(u)| + alpha * lum(f(u)),
// the luminance of the absolute (MIS-weighted) throughput differences to the four neighbours plus
// a small share alpha of the primal throughput (slides: "we also mix in a little of primal path
// throughput, so we get some samples everywhere"); lum|.| weights the absolute value of each
// channel, so T > 0 wherever any contribution is non-zero.
//
// Mutations: with probability `large_step` a large step (every coordinate redrawn uniformly),
// otherwise a small step (every coordinate moved by a Gaussian of deviation `sigma`, wrapped
// onto [0, 1)). Coordinates are drawn lazily as the path sampler consumes them, with pbrt-v3's
// bookkeeping (MLTSampler): each remembers the iteration it was last modified at, and one that
// was not used for n small steps receives them at once as one Gaussian of deviation sigma sqrt(n)
// (or a uniform value if a large step was accepted since). The kernel is then the same symmetric
// one on the whole infinite vector whatever the path lengths, which freezing unused coordinates
// would not be.
// Acceptance a = min(1, T(u') / T(u)). Both the proposal and the current state are splatted with
// weights a and 1 - a (Veach's expected-value estimator), each contribution g as g / T scaled by
//   (width * height) * b / N,
// with N the number of mutations so far and b = integral of T over primary sample space (the
// image brightness in T's units). b is first estimated from a bootstrap of uniform samples
// (`bootstrap` per pixel), which also picks each chain's start state in proportion to T (no
// start-up bias), and then keeps being refined by every large-step proposal, which is a uniform
// sample too, so the normalisation converges with the image. (Estimator with
// large_step_mis = false.)
// By default (large_step_mis) the splat weights are Kelemen et al.'s instead: the proposal
// (a + [large step]) / (T/b + p_large), the current state (1 - a) / (T/b + p_large), scaled by
// (width * height) / N, with b the estimate before the pass: the chain (density T/b per
// mutation) and the large-step proposals (uniform, probability p_large) combined by the balance
// heuristic, so pixels where T/b is small (flat, directly lit regions) tend to a plain uniform
// estimate that depends neither on b nor on where the chains happen to be.
//
// The primal image, the horizontal and vertical forward differences (each from both of its
// pixels, as gpt) and the light seen through delta vertices only are accumulated; develop()
// reconstructs the primal and gradients by screened Poisson (reconstruction/poisson.h) and adds
// the direct light, as gpt does.
//
// Chains: `chains` independent chains (a fixed count, not the thread count), each with its own
// Rng::for_key(seed, chain, ...) stream and its own list of splats per pass; the lists are summed
// in chain order, so the image does not depend on the thread count.
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods gdmlt`, docs/methods.md#gdmlt).
//
// Bias and convergence (measured, docs/gradient.md "Bias and stuck chains"): no bias within error
// bars. cornell-glass 48 x 36, 24 seeds, L2: image mean / path-traced mean 1.004 +- 0.007 after
// 1024 passes (72 seeds: 1.014 +- 0.011 after 256, 1.031 +- 0.020 after 64); primal and L2
// combined means agree to 1e-6. L1 lowers the mean by 2.2 % (64 passes), 1.0 % (256), 0.6 %
// (1024) against L2 on the same chains: its known, vanishing bias. One seed's mean scatters by
// 3.4 % (sd) at 1024 passes; b, which scales the whole image, scatters by 3.0 % (T is
// heavy-tailed on caustics) with correlation 0.5 to the mean, the rest is the chains. (These
// numbers are without large-step MIS.) On torus-glass 1 % of the pixels carry 90 % of the relMSE at 128
// passes: chains stuck on isolated high-T caustic paths (acceptance 0.18; one pixel held 1.2 %
// of all mutations), and b's scatter made whole images 0.78-1.22x as bright (10 seeds, 128
// passes). More chains, a larger bootstrap, large_step 0.5 and sigma 0.003 did not help at equal
// passes. Large-step MIS (now the default) brings that brightness scatter from sd 0.15 to 0.04
// (relMSE unchanged: the stuck pixels dominate it), lowers cornell-box's relMSE by 12 % (6 of 6
// seeds, 16 x 16, 1024 passes) and cornell-glass's per-seed brightness scatter by 15-20 %.
//
// Passes: combined, primal, gradient_x, gradient_y (as gpt), sample_density (chain states per
// pixel; sums to the number of mutations).
// Stats::extra: "acceptance rate", "large-step share", "brightness b", "chains", and the shift
// failures by reason (as gpt).
//
// A pass pauses when the sink asks (ProgressSink::pause: Blender's F12 window, every ~2 s): its
// chains stop at a cancel poll and the next call goes on with them, the same random numbers, so
// the pass and the image are a whole one's; develop() in between shows every splat so far, the
// open pass's too, over every mutation so far (each chain's mutations are samples of its
// stationary law, whatever their count). At 1920 x 1080 a pass took 62 s between images.
#pragma once

#include <memory>
#include <vector>

#include "core/rng.h"
#include "integrators/gradient/gpt.h"
#include "integrators/integrator.h"
#include "reconstruction/poisson.h"

namespace gp {

// Primary sample vector of one chain, mutated lazily (pbrt-v3's MLTSampler; see above). Each
// iteration: start_iteration(), the path sampler reads uniform()s, then accept() or reject().
class PrimarySampleChain final : public Sampler {
 public:
  PrimarySampleChain(Rng rng, double sigma, double large_step)
      : rng_(rng), sigma_(sigma), large_step_probability_(large_step) {}
  void start_iteration() {
    ++iteration_;
    large_step_ = rng_.uniform() < large_step_probability_;
    index_ = 0;
  }
  float uniform() override;
  void accept() {
    if (large_step_) last_large_step_ = iteration_;
  }
  void reject();
  bool large_step() const { return large_step_; }
  Rng& rng() { return rng_; }
  void set_rng(const Rng& rng) { rng_ = rng; }

 private:
  struct Coordinate {
    float value = 0, backup = 0;
    int64_t modified = -1, backup_modified = -1;  // iteration of the last change; -1: never drawn
  };
  Rng rng_;
  double sigma_, large_step_probability_;
  std::vector<Coordinate> x_;
  int64_t iteration_ = 0, last_large_step_ = 0;
  bool large_step_ = true;  // the first evaluation draws every coordinate uniformly
  size_t index_ = 0;
};

struct GdmltChainResult;  // gdmlt.cpp: what one chain did in one pass

class GradientDomainMlt : public Integrator {
 public:
  GradientDomainMlt(const Scene& scene, const Params& params);
  ~GradientDomainMlt() override;
  std::string name() const override { return "gdmlt"; }
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;
  // Every per-kind switch, as the path tracer: GradientPathTracer::trace, which it drives, tags
  // base and offset rays with the base's lobes and weighs lights hidden from some kinds by the
  // lobes that see them.

  // What one primary sample vector evaluates to.
  struct State {
    GradientPathTracer::Sample sample;
    int pixel = 0;
    double target = 0;  // < 0: non-finite sample (never accepted)
  };
  // Target function T of a sample (see above); public for tests.
  double target(const GradientPathTracer::Sample& s) const;

 private:
  struct Chain {
    PrimarySampleChain sampler;
    State current;
  };
  // Evaluates the sampler's current proposal (film position, lens, gpt path sample).
  State evaluate(Sampler& sampler, RayCounts& rays, std::map<std::string, double>* failures) const;
  // False when `sink` cancelled it (nothing kept: the next pass starts it again) or asked for a
  // pause (ProgressSink::pause: the samples done so far kept in boot_, the next call goes on).
  bool bootstrap(ProgressSink* sink);
  static constexpr int64_t kCancelPoll = 1024;  // mutations / bootstrap samples between cancel polls

  const Scene& scene_;
  GradientPathTracer gpt_;  // the path sampler and its shifts
  int mutations_, chain_count_, bootstrap_per_pixel_, threads_;
  double large_step_, sigma_, alpha_;
  bool large_step_mis_;
  bool direct_uniform_ = false;  // delta-only light from the uniform samples, not the chains
  uint64_t seed_;
  ReconOptions recon_;
  int width_, height_;
  std::vector<Chain> chains_;
  bool started_ = false;
  // Accumulators in units of g / T (see above), summed over all passes.
  std::vector<double> primal_, direct_, gx_, gy_;  // 3 per pixel
  std::vector<double> density_;                    // 1 per pixel
  double b_sum_ = 0;                               // sum of T over uniform samples
  int64_t b_count_ = 0, mutations_done_ = 0, accepted_ = 0, large_steps_ = 0;
  int64_t uniform_count_ = 0;  // uniform samples (bootstrap + large steps) behind direct_
  // The pass a pause left open: each chain's results so far (merged at the pass's end) and the
  // brightness estimate its splats use; null between passes.
  struct OpenPass {
    std::vector<GdmltChainResult> results;
    double b_now = 1;
  };
  std::unique_ptr<OpenPass> open_;
  // The bootstrap a pause left open (Blender's F12 window shows develop()'s image of its samples
  // so far): its samples, done in blocks of kCancelPoll (each sample draws its own stream, so the
  // blocks' order does not change them), and the rays they traced; null when none is open.
  struct OpenBootstrap {
    std::vector<double> t;                      // T of each sample (0: invalid)
    std::vector<std::pair<int, RGB>> direct;    // its pixel and delta-only light
    std::vector<RGB> primal;                    // its primal (the preview's, with `direct`)
    std::vector<uint8_t> done;                  // per block
    size_t samples_done = 0;
    int64_t closest = 0, shadow = 0, invalid = 0;
  };
  std::unique_ptr<OpenBootstrap> boot_;
};

}  // namespace gp
