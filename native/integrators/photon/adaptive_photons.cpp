#include "integrators/photon/adaptive_photons.h"

#include <algorithm>
#include <cmath>

#include "core/parallel.h"

namespace gp {

// ---- Visibility grid: the measurement points of this pass ----

void VisibilityGrid::build(const std::vector<Point>& points, int threads, const std::function<bool()>& cancelled) {
  points_.clear();
  positions_.clear();
  max_r_ = 0;
  for (const Point& q : points)
    if (q.R > 0) {
      points_.push_back(q);
      points_.back().R2 = q.R * q.R;
      positions_.push_back(Photon{q.p, q.n, RGB(0.0f)});
      max_r_ = std::max(max_r_, q.R);
    }
  if (points_.empty()) return;
  // Cells twice the largest radius (thesis §10.2.2): a query touches at most 2 x 2 x 2 cells.
  // 16 buckets per point: most deposits of invisible paths land in cells with no point, and
  // a query there should find an empty bucket rather than a collision.
  const uint32_t min_buckets = static_cast<uint32_t>(std::min<size_t>(16 * points_.size(), 1u << 24));
  grid_.build(positions_, 2.0f * max_r_, PhotonHashMode::Exact, 0, 0, threads, min_buckets, cancelled);
}

bool VisibilityGrid::splats(const Photon& ph) const {
  if (points_.empty()) return false;
  return grid_.any_index(ph.p, max_r_, [&](uint32_t j, float) {
    const Point& q = points_[j];
    // The gathering's own test (progressive_photon.cpp): |p - x|^2 <= R^2 with the same float R,
    // and the photon arriving on the side the point is seen from.
    return length_squared(ph.p - q.p) <= q.R2 && q.wo_z * dot(ph.wi, q.n) > 0;
  });
}

bool VisibilityGrid::any_splats(const Photon* begin, const Photon* end) const {
  for (const Photon* ph = begin; ph != end; ++ph)
    if (splats(*ph)) return true;
  return false;
}

// ---- Adaptive MCMC photon sampler ----

namespace {

// Uniform primary samples that are recorded, so a visible uniform path can become the state.
class RecordingSamples final : public PrimarySamples {
 public:
  RecordingSamples(Rng& rng, std::vector<float>& u) : rng_(rng), u_(u) { u_.clear(); }
  float next() override {
    const float v = rng_.uniform();
    u_.push_back(v);
    return v;
  }

 private:
  Rng& rng_;
  std::vector<float>& u_;
};

// Candidate of a mutation: coordinate k is the current state's coordinate k mutated by
// eq. 8.4 when the candidate path reads it, or a fresh uniform number where the path reads
// beyond the state. States hold exactly the coordinates their path read: V(u) does not depend
// on the others, whose conditional under F is uniform, so they are never stored (Kelemen et
// al.'s lazy mutation, with the never-observed dimensions redrawn).
class MutatedSamples final : public PrimarySamples {
 public:
  MutatedSamples(Rng& rng, const std::vector<float>& current, double theta, std::vector<float>& cand)
      : rng_(rng), current_(current), theta_(theta), cand_(cand) {
    cand_.clear();
  }
  float next() override {
    const size_t k = cand_.size();
    float v;
    if (k < current_.size()) {
      const float xi0 = rng_.uniform(), xi1 = rng_.uniform();
      v = AdaptivePhotonSampler::mutate(current_[k], theta_, xi0, xi1);
    } else {
      v = rng_.uniform();
    }
    cand_.push_back(v);
    return v;
  }

 private:
  Rng& rng_;
  const std::vector<float>& current_;
  double theta_;
  std::vector<float>& cand_;
};

// The current state as it is, extended by fresh uniform coordinates where the path reads
// beyond it (re-evaluating V(u) against a new pass's measurement points).
class ReplaySamples final : public PrimarySamples {
 public:
  ReplaySamples(Rng& rng, std::vector<float>& u) : rng_(rng), u_(u) {}
  float next() override {
    if (k_ < u_.size()) return u_[k_++];
    const float v = rng_.uniform();
    u_.push_back(v);
    ++k_;
    return v;
  }

 private:
  Rng& rng_;
  std::vector<float>& u_;
  size_t k_ = 0;
};

}  // namespace

float AdaptivePhotonSampler::mutate(float u, double theta, float xi0, float xi1) {
  // thesis eq. 8.4: du = sgn(2 xi0 - 1) xi1^(1/theta + 1) (as exp2(log2(xi1) e), cheaper than
  // pow); Fig. 8.2 wraps t - floor(t).
  const float e = static_cast<float>(1.0 / theta + 1.0);
  const float d = xi1 > 0 ? std::exp2(std::log2(xi1) * e) : 0.0f;
  const float t = u + (2.0f * xi0 - 1.0f > 0 ? d : -d);
  float v = t - std::floor(t);
  if (!(v < 1.0f)) v = 0.0f;  // rounding of t - floor(t) up to 1 for t just below an integer
  return v;
}

AdaptivePhotonSampler::AdaptivePhotonSampler(const PhotonTracer& tracer, int chains, uint64_t seed)
    : tracer_(tracer), seed_(seed), chains_(static_cast<size_t>(std::max(1, chains))) {}

PhotonPassStats AdaptivePhotonSampler::trace(int64_t count, uint64_t pass, int min_deposit_bounce,
                                             const VisibilityGrid& vis, std::vector<Photon>& out,
                                             const std::function<bool()>& cancelled) {
  const size_t n_chains = chains_.size();
  parallel_for(n_chains, tracer_.threads(), [&](size_t lo, size_t hi) {
    for (size_t c = lo; c < hi; ++c) {
      Chain& ch = chains_[c];
      ch.pool.clear();
      ch.runs.clear();
      ch.uniform = ch.visible = ch.iterations = ch.rays = ch.invalid = ch.paths = 0;
      // Iterations of this chain: count split evenly, the remainder to the first chains.
      const int64_t n = count / static_cast<int64_t>(n_chains) + (static_cast<int64_t>(c) < count % static_cast<int64_t>(n_chains) ? 1 : 0);
      if (n == 0 || vis.empty()) {
        if (vis.empty()) ch.u.clear();
        continue;
      }
      Rng rng = Rng::for_key(seed_ ^ 0x6d636d63ULL, c, pass);
      // Traces from `u`, returns V(u); the deposits go to `photons` (replaced).
      auto trace_into = [&](PrimarySamples& u, std::vector<Photon>& photons) {
        photons.clear();
        ch.rays += tracer_.trace_path(u, min_deposit_bounce, photons, ch.invalid);
        ++ch.paths;
        return vis.any_splats(photons.data(), photons.data() + photons.size());
      };
      auto uniform_path = [&]() {  // one sample of the uniform replica, counted for eq. 8.11
        RecordingSamples u(rng, ch.cand_u);
        const bool visible = trace_into(u, ch.cand_photons);
        ++ch.uniform;
        if (visible) ++ch.visible;
        return visible;
      };
      // ---- State for this pass: keep the old one if the new measurement points still see it ----
      if (!ch.u.empty()) {
        ReplaySamples replay(rng, ch.u);
        if (!trace_into(replay, ch.photons)) ch.u.clear();
      }
      // ---- Initialisation (Fig. 8.2): uniform paths until one is visible, at most n tries ----
      int64_t budget = n;
      auto stop = [&](int64_t i) { return i % kCancelPoll == 0 && cancelled && cancelled(); };
      while (ch.u.empty() && budget-- > 0 && !stop(n - budget))
        if (uniform_path()) {
          ch.u.swap(ch.cand_u);
          ch.photons.swap(ch.cand_photons);
        }
      if (ch.u.empty()) continue;  // nothing visible found this pass: no splats from this chain
      for (int64_t i = 0; i < n && !stop(i + 1); ++i) {
        // ---- Replica exchange with the uniform chain: r = V(u_I) (eq. 8.10) ----
        if (uniform_path()) {
          ch.u.swap(ch.cand_u);
          ch.photons.swap(ch.cand_photons);
          ch.state_changed = true;
        }
        // ---- Mutation (eq. 8.4), accepted iff visible (eq. 8.5) ----
        {
          MutatedSamples u(rng, ch.u, ch.theta, ch.cand_u);
          ++ch.mutated;
          if (trace_into(u, ch.cand_photons)) {
            ch.u.swap(ch.cand_u);
            ch.photons.swap(ch.cand_photons);
            ch.state_changed = true;
            ++ch.accepted;
          }
        }
        // ---- Controlled adaptation: theta += gamma_i (A_i - A*), gamma_i = 1/i (eq. 8.6) ----
        const double A = static_cast<double>(ch.accepted) / static_cast<double>(ch.mutated);
        ch.theta += (A - kTargetAcceptance) / static_cast<double>(ch.mutated);
        ch.theta = std::clamp(ch.theta, kThetaMin, kThetaMax);
        // ---- Splat the current state ----
        // A state splatted again (a rejected mutation, no exchange) repeats its run; a new state
        // copies its photons into the pool once.
        if (!ch.runs.empty() && !ch.state_changed) {
          ++ch.runs.back().repeats;
        } else {
          ch.runs.push_back({static_cast<uint32_t>(ch.pool.size()), static_cast<uint32_t>(ch.photons.size()), 1});
          ch.pool.insert(ch.pool.end(), ch.photons.begin(), ch.photons.end());
          ch.state_changed = false;
        }
        ++ch.iterations;
      }
    }
  });
  // ---- Concatenate in chain order (independent of the thread count) ----
  PhotonPassStats stats;
  size_t total = 0;
  for (const Chain& ch : chains_)
    for (const Run& r : ch.runs) total += static_cast<size_t>(r.size) * r.repeats;
  out.clear();
  // A quarter of headroom when it must grow: reserving exactly each new largest pass reallocated
  // (and fragmented the heap) at every new maximum, a slow creep of the resident set over
  // thousands of passes (scripts/soak.py, docs/reliability.md).
  if (out.capacity() < total) out.reserve(total + total / 4);
  for (const Chain& ch : chains_) {
    for (const Run& r : ch.runs)
      for (uint32_t k = 0; k < r.repeats; ++k)
        out.insert(out.end(), ch.pool.begin() + r.first, ch.pool.begin() + r.first + r.size);
    stats.emitted += ch.iterations;
    stats.rays += ch.rays;
    stats.invalid += ch.invalid;
    uniform_total_ += ch.uniform;
    uniform_visible_ += ch.visible;
    paths_traced_ += ch.paths;
  }
  stats.stored = static_cast<int64_t>(out.size());
  return stats;
}

double AdaptivePhotonSampler::vc() const {
  // thesis eq. 8.11: V_c = N_{I,V=1} / N_{I,total}
  return uniform_total_ > 0 ? static_cast<double>(uniform_visible_) / static_cast<double>(uniform_total_) : 1.0;
}

double AdaptivePhotonSampler::acceptance_rate() const {
  int64_t a = 0, m = 0;
  for (const Chain& ch : chains_) {
    a += ch.accepted;
    m += ch.mutated;
  }
  return m > 0 ? static_cast<double>(a) / static_cast<double>(m) : 0.0;
}

double AdaptivePhotonSampler::mean_theta() const {
  double s = 0;
  for (const Chain& ch : chains_) s += ch.theta;
  return chains_.empty() ? 0.0 : s / static_cast<double>(chains_.size());
}

}  // namespace gp
