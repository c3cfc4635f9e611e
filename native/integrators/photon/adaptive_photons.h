// Adaptive photon tracing using path visibility: Hachisuka, "Progressive density estimation"
// thesis ch. 8 (Hachisuka, Jensen 2011). Photon paths are points u of the unit hypercube of
// primary samples (PhotonTracer::trace_path); the visibility function V(u) is 1 when the path
// deposits a photon inside the radius of any measurement point of the current pass (the
// splatting test of §8.2.3, done here by a hash-grid query of the measurement points at every
// deposit), 0 otherwise. Photon paths are sampled from F(u) = V(u) / V_c (§8.2.2) by
//
//   controlled MCMC (§8.3.2): every coordinate is mutated by
//       du = sgn(2 xi0 - 1) xi1^(1/theta + 1)                                  eq. 8.4
//     (wrapped into [0, 1)); a mutation is accepted iff the mutated path is visible
//     (eq. 8.5, no extra random number); the mutation size adapts towards the acceptance
//     ratio A* = 0.234 by theta_{i+1} = theta_i + gamma_i (A_i - A*), gamma_i = 1/i, theta_1 = 1
//     (eq. 8.6), theta bounded to [kThetaMin, kThetaMax] (bounded convergence, §8.3.2);
//   replica exchange with a uniform chain (§8.4.2): every iteration draws one uniform path;
//     if it is visible it replaces the current state (exchange probability V(u_I), eq. 8.10),
//     then the state is mutated as above, and the current state is splatted (Fig. 8.2);
//   progressive normalisation (§8.4.3): V_c = N_{I,V=1} / N_{I,total} over all uniform
//     paths so far (eq. 8.11); the photon estimate of every pixel is multiplied by V_c.
//
// Parallel and deterministic: the sampler runs a fixed number of independent chains (the
// `chains` parameter, not the thread count), each with its own random stream keyed by
// (seed, chain, pass), its own state and its own adaptive theta (eq. 8.6 per chain; the thesis
// ran one chain on one core). Chains are concatenated in chain order, so the photon list does
// not depend on the thread count. A chain keeps its state across passes while the state stays
// visible under the new measurement points; otherwise it searches for a visible uniform path
// (at most `count` tries per pass, all counted in V_c), as the initialisation of Fig. 8.2.
//
// Participating media (issue 32, thesis §5.6 with ch. 8): a path is visible too when one of its
// volume photons lands near a camera segment through a medium (BeamVisibility: cells within the
// largest cylinder radius of the segments, a superset of the beam radiance estimate's cylinders).
// V(u) is then 1 wherever the path contributes to some pixel, surface or beam (a superset is
// enough: F = V / V_c stays a density on the paths that matter, and V_c normalises it), so
// the chains are not biased against light that reaches the camera only through a medium.
//
// Used by ProgressivePhotonMapping when the parameter photon_sampler = "adaptive" (sppm and ppm;
// method alias "sppm-adaptive"). Parameters (defaults):
//   photon_sampler  uniform  uniform | adaptive
//   chains          64       independent Markov chains per photon pass (>= 1)
//
// Statistics (Stats::extra): "acceptance rate" (mutations accepted / tried), "mutation size"
// (theta averaged over the chains), "V_c" (eq. 8.11), "uniform count" (uniform paths traced,
// N_I,total), "visible count" (visible uniform paths, N_I,V=1), "photon paths traced".
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "integrators/photon/photon_hash.h"
#include "core/frame.h"
#include "core/rng.h"
#include "integrators/photon/photon_tracer.h"

namespace gp {

// The measurement points of one pass in a hash grid, for the visibility test V(u): does a
// photon land within the radius of a point, on the side the point is seen from?
class VisibilityGrid {
 public:
  struct Point {
    Vec3 p;
    Vec3 n;      // shading normal of the point (Frame::n)
    float wo_z;  // cosine of the direction towards the viewer in that frame (VisiblePoint::wo.z)
    float R;     // gathering radius this pass, as the gathering computes it: float(sqrt(r2))
    float R2 = 0;  // set by build(): R * R, as the gathering squares it
  };
  // Rebuilds the grid (capacity kept between passes). Points with R <= 0 are skipped.
  // `cancelled` (polled between the grid's build stages) leaves it empty.
  void build(const std::vector<Point>& points, int threads, const std::function<bool()>& cancelled = {});
  // V for one deposit: the same test as the gathering (distance <= R, same hemisphere).
  bool splats(const Photon& ph) const;
  // V(u) for a whole path: any of its deposits splats.
  bool any_splats(const Photon* begin, const Photon* end) const;
  bool empty() const { return points_.empty(); }

 private:
  std::vector<Point> points_;
  std::vector<Photon> positions_;  // the points as "photons" for PhotonHashGrid
  PhotonHashGrid grid_;
  float max_r_ = 0;
};

// V for volume photons (media): does a photon land within the largest cylinder radius of some
// camera segment through a medium? Answered by a coarse occupancy grid (at most 64 cells an axis)
// over the region of the segments: the cells the segments pass through, dilated by that radius
// in cells, a superset of every cylinder (so V is never 0 where a beam gathers the photon).
// A point outside the grid counts as visible when some segment leaves it or a cylinder reaches
// its border (a World medium's segments run off to infinity).
class BeamVisibility {
 public:
  // Starts a pass's grid over `region` for cylinders up to `max_r`.
  void begin(const Bounds3& region, float max_r);
  // A segment o + t d, t in [0, t_max) (t_max may be infinite).
  void add(const Vec3& o, const Vec3& d, float t_max);
  // Dilates the marked cells (after the last add).
  void finish();
  bool splats(const Photon& ph) const;
  bool any_splats(const Photon* begin, const Photon* end) const;
  bool empty() const { return !any_; }

 private:
  bool cell_of(const Vec3& p, int c[3]) const;
  Bounds3 region_;
  int n_[3] = {0, 0, 0};
  float h_ = 1, max_r_ = 0;
  std::vector<uint8_t> cells_;
  std::vector<uint32_t> prefix_;  // finish()'s scratch
  bool any_ = false, outside_ = false;
};

class AdaptivePhotonSampler {
 public:
  static constexpr double kTargetAcceptance = 0.234;  // A*, thesis §8.3.1 (Roberts et al.)
  static constexpr double kThetaMin = 1e-4, kThetaMax = 1e4;

  AdaptivePhotonSampler(const PhotonTracer& tracer, int chains, uint64_t seed);

  // One photon pass of `count` Markov-chain iterations in total (split over the chains); the
  // splatted photons of every iteration go to `out` (replaced). stats.emitted is the number of
  // iterations that splatted a visible state (N_e of the estimator, to be scaled by vc()).
  // `cancelled` is polled every kCancelPoll iterations of each chain (PhotonTracer::trace).
  // With media: `vis_volume` the balls about the camera segments, `out_volume` the splatted
  // volume photons (both null: surfaces only).
  PhotonPassStats trace(int64_t count, uint64_t pass, int min_deposit_bounce, const VisibilityGrid& vis,
                        std::vector<Photon>& out, const std::function<bool()>& cancelled = {},
                        const BeamVisibility* vis_volume = nullptr, std::vector<Photon>* out_volume = nullptr);
  static constexpr int64_t kCancelPoll = 1024;

  double vc() const;                 // eq. 8.11 (1 until a uniform path has been traced)
  double acceptance_rate() const;    // accepted / mutated over all chains
  double mean_theta() const;
  int64_t uniform_count() const { return uniform_total_; }
  int64_t visible_count() const { return uniform_visible_; }
  int64_t paths_traced() const { return paths_traced_; }
  // Bytes held by the chains' states and pools (kept between passes for their capacity).
  size_t capacity_bytes() const;

  // Mutation of eq. 8.4 applied to one coordinate (exposed for tests).
  static float mutate(float u, double theta, float xi0, float xi1);

 private:
  struct Run {
    uint32_t first, size, repeats;  // pool[first, first + size) splatted `repeats` times
    uint32_t vfirst = 0, vsize = 0;  // and pool_volume[vfirst, vfirst + vsize)
  };
  struct Chain {
    std::vector<float> u;            // current state (primary samples); empty = none yet
    std::vector<Photon> photons;     // its deposits, splatted every iteration
    std::vector<Photon> volume;      // and its volume photons (media)
    double theta = 1.0;              // adaptive mutation size, theta_1 = 1 (§8.3.2)
    int64_t mutated = 0, accepted = 0;
    // Scratch of one pass, kept for its capacity.
    std::vector<float> cand_u;
    std::vector<Photon> cand_photons, cand_volume;
    // This pass's splats as runs of one state's photons (each state's photons stored once, in
    // `pool`): a copy per iteration made each chain's buffer follow its largest pass so far, a
    // creep of the resident set over thousands of passes (docs/reliability.md).
    std::vector<Photon> pool, pool_volume;
    std::vector<Run> runs;
    bool state_changed = true;
    int64_t uniform = 0, visible = 0, iterations = 0, rays = 0, invalid = 0, paths = 0;
  };

  const PhotonTracer& tracer_;
  uint64_t seed_;
  std::vector<Chain> chains_;
  int64_t uniform_total_ = 0, uniform_visible_ = 0, paths_traced_ = 0;
};

}  // namespace gp
