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

// ---- Beam visibility: cells near the camera segments through media ----

void BeamVisibility::begin(const Bounds3& region, float max_r) {
  region_ = region;
  max_r_ = max_r;
  any_ = outside_ = false;
  const Vec3 e = region.diagonal();
  const float longest = std::max({e.x, e.y, e.z, 1e-6f});
  h_ = longest / 64;
  for (int a = 0; a < 3; ++a) n_[a] = std::clamp(static_cast<int>(std::ceil(e[a] / h_)), 1, 64);
  cells_.assign(size_t(n_[0]) * n_[1] * n_[2], 0);
}

bool BeamVisibility::cell_of(const Vec3& p, int c[3]) const {
  for (int a = 0; a < 3; ++a) {
    const float x = (p[a] - region_.lo[a]) / h_;
    if (!(x >= 0 && x <= static_cast<float>(n_[a]))) return false;  // (NaN: outside)
    c[a] = std::min(static_cast<int>(x), n_[a] - 1);
  }
  return true;
}

void BeamVisibility::add(const Vec3& o, const Vec3& d, float t_max) {
  // The segment clipped to the region; what lies beyond makes every outside point visible.
  float t0 = 0, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    const float inv = 1.0f / d[a];
    float ta = (region_.lo[a] - o[a]) * inv, tb = (region_.hi[a] - o[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (std::isnan(ta) || std::isnan(tb)) {  // parallel to the slab, on its plane
      if (o[a] < region_.lo[a] || o[a] > region_.hi[a]) t1 = -1;
      continue;
    }
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  any_ = true;
  if (!(t0 < t1)) {
    outside_ = true;
    return;
  }
  if (t0 > 0 || t1 < t_max) outside_ = true;
  // Points every half cell (finish() dilates one cell more for the corners this skips).
  const float step = 0.5f * h_;
  const int64_t n = std::min<int64_t>(static_cast<int64_t>((t1 - t0) / step) + 1, 1 << 16);
  for (int64_t k = 0; k <= n; ++k) {
    int c[3];
    if (cell_of(o + d * std::min(t1, t0 + static_cast<float>(k) * step), c))
      cells_[(size_t(c[2]) * n_[1] + c[1]) * n_[0] + c[0]] = 1;
  }
}

void BeamVisibility::finish() {
  if (!any_) return;
  // A point within max_r of a segment point y lies at most floor(max_r / h) + 1 cells from y's
  // cell per axis; + 1 for the half-cell steps of add().
  const int r = static_cast<int>(std::min(max_r_ / h_, 128.0f)) + 2;
  // A separable max filter of half-width r along each axis, by prefix counts.
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const int n = n_[a];
    prefix_.assign(size_t(n) + 1, 0);
    for (int j = 0; j < n_[b]; ++j)
      for (int k = 0; k < n_[c]; ++k) {
        auto at = [&](int i) -> uint8_t& {
          int idx[3];
          idx[a] = i;
          idx[b] = j;
          idx[c] = k;
          return cells_[(size_t(idx[2]) * n_[1] + idx[1]) * n_[0] + idx[0]];
        };
        for (int i = 0; i < n; ++i) prefix_[i + 1] = prefix_[i] + at(i);
        for (int i = 0; i < n; ++i) at(i) = prefix_[std::min(n, i + r + 1)] > prefix_[std::max(0, i - r)] ? 1 : 0;
      }
  }
  // A cylinder that reaches the border reaches beyond it.
  for (int z = 0; z < n_[2] && !outside_; ++z)
    for (int y = 0; y < n_[1] && !outside_; ++y)
      for (int x = 0; x < n_[0]; ++x) {
        const bool border = x == 0 || y == 0 || z == 0 || x == n_[0] - 1 || y == n_[1] - 1 || z == n_[2] - 1;
        if (border && cells_[(size_t(z) * n_[1] + y) * n_[0] + x]) {
          outside_ = true;
          break;
        }
      }
}

bool BeamVisibility::splats(const Photon& ph) const {
  if (!any_) return false;
  int c[3];
  if (!cell_of(ph.p, c)) return outside_;
  return cells_[(size_t(c[2]) * n_[1] + c[1]) * n_[0] + c[0]] != 0;
}

bool BeamVisibility::any_splats(const Photon* begin, const Photon* end) const {
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
                                             const std::function<bool()>& cancelled, const BeamVisibility* vis_volume,
                                             std::vector<Photon>* out_volume) {
  const size_t n_chains = chains_.size();
  const bool media = vis_volume && out_volume;
  const bool none_visible = vis.empty() && (!media || vis_volume->empty());
  parallel_for(n_chains, tracer_.threads(), [&](size_t lo, size_t hi) {
    for (size_t c = lo; c < hi; ++c) {
      Chain& ch = chains_[c];
      ch.pool.clear();
      ch.pool_volume.clear();
      ch.runs.clear();
      ch.uniform = ch.visible = ch.iterations = ch.rays = ch.invalid = ch.paths = 0;
      // Iterations of this chain: count split evenly, the remainder to the first chains.
      const int64_t n = count / static_cast<int64_t>(n_chains) + (static_cast<int64_t>(c) < count % static_cast<int64_t>(n_chains) ? 1 : 0);
      if (n == 0 || none_visible) {
        if (none_visible) ch.u.clear();
        continue;
      }
      Rng rng = Rng::for_key(seed_ ^ 0x6d636d63ULL, c, pass);
      // Traces from `u`, returns V(u); the deposits go to `photons` and `volume` (replaced).
      auto trace_into = [&](PrimarySamples& u, std::vector<Photon>& photons, std::vector<Photon>& volume) {
        photons.clear();
        volume.clear();
        ch.rays += tracer_.trace_path(u, min_deposit_bounce, photons, ch.invalid, nullptr, nullptr, nullptr,
                                      media ? &volume : nullptr);
        ++ch.paths;
        return vis.any_splats(photons.data(), photons.data() + photons.size()) ||
               (media && vis_volume->any_splats(volume.data(), volume.data() + volume.size()));
      };
      // The candidate becomes the state.
      auto take_candidate = [&]() {
        ch.u.swap(ch.cand_u);
        ch.photons.swap(ch.cand_photons);
        ch.volume.swap(ch.cand_volume);
      };
      auto uniform_path = [&]() {  // one sample of the uniform replica, counted for eq. 8.11
        RecordingSamples u(rng, ch.cand_u);
        const bool visible = trace_into(u, ch.cand_photons, ch.cand_volume);
        ++ch.uniform;
        if (visible) ++ch.visible;
        return visible;
      };
      // ---- State for this pass: keep the old one if the new measurement points still see it ----
      if (!ch.u.empty()) {
        ReplaySamples replay(rng, ch.u);
        if (!trace_into(replay, ch.photons, ch.volume)) ch.u.clear();
      }
      // ---- Initialisation (Fig. 8.2): uniform paths until one is visible, at most n tries ----
      int64_t budget = n;
      auto stop = [&](int64_t i) { return i % kCancelPoll == 0 && cancelled && cancelled(); };
      while (ch.u.empty() && budget-- > 0 && !stop(n - budget))
        if (uniform_path()) take_candidate();
      if (ch.u.empty()) continue;  // nothing visible found this pass: no splats from this chain
      for (int64_t i = 0; i < n && !stop(i + 1); ++i) {
        // ---- Replica exchange with the uniform chain: r = V(u_I) (eq. 8.10) ----
        if (uniform_path()) {
          take_candidate();
          ch.state_changed = true;
        }
        // ---- Mutation (eq. 8.4), accepted iff visible (eq. 8.5) ----
        {
          MutatedSamples u(rng, ch.u, ch.theta, ch.cand_u);
          ++ch.mutated;
          if (trace_into(u, ch.cand_photons, ch.cand_volume)) {
            take_candidate();
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
          ch.runs.push_back({static_cast<uint32_t>(ch.pool.size()), static_cast<uint32_t>(ch.photons.size()), 1,
                             static_cast<uint32_t>(ch.pool_volume.size()), static_cast<uint32_t>(ch.volume.size())});
          ch.pool.insert(ch.pool.end(), ch.photons.begin(), ch.photons.end());
          if (media) ch.pool_volume.insert(ch.pool_volume.end(), ch.volume.begin(), ch.volume.end());
          ch.state_changed = false;
        }
        ++ch.iterations;
      }
    }
  });
  // ---- Concatenate in chain order (independent of the thread count) ----
  PhotonPassStats stats;
  size_t total = 0, total_volume = 0;
  for (const Chain& ch : chains_)
    for (const Run& r : ch.runs) {
      total += static_cast<size_t>(r.size) * r.repeats;
      total_volume += static_cast<size_t>(r.vsize) * r.repeats;
    }
  out.clear();
  // A quarter of headroom when it must grow: reserving exactly each new largest pass reallocated
  // (and fragmented the heap) at every new maximum, a slow creep of the resident set over
  // thousands of passes (scripts/soak.py, docs/reliability.md).
  if (out.capacity() < total) out.reserve(total + total / 4);
  if (media) {
    out_volume->clear();
    if (out_volume->capacity() < total_volume) out_volume->reserve(total_volume + total_volume / 4);
  }
  for (const Chain& ch : chains_) {
    for (const Run& r : ch.runs)
      for (uint32_t k = 0; k < r.repeats; ++k) {
        out.insert(out.end(), ch.pool.begin() + r.first, ch.pool.begin() + r.first + r.size);
        if (media)
          out_volume->insert(out_volume->end(), ch.pool_volume.begin() + r.vfirst,
                             ch.pool_volume.begin() + r.vfirst + r.vsize);
      }
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

size_t AdaptivePhotonSampler::capacity_bytes() const {
  size_t b = 0;
  for (const Chain& ch : chains_)
    b += (ch.u.capacity() + ch.cand_u.capacity()) * sizeof(float) +
         (ch.photons.capacity() + ch.volume.capacity() + ch.cand_photons.capacity() + ch.cand_volume.capacity() +
          ch.pool.capacity() + ch.pool_volume.capacity()) * sizeof(Photon) +
         ch.runs.capacity() * sizeof(Run);
  return b;
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
