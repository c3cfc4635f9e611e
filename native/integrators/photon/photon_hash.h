// Spatial hash grid over the photons of one pass, for the range queries of progressive
// photon mapping, rebuilt (in parallel) every pass and then discarded with the photons.
//
// Cells are cubes of side `cell_size` (callers use twice the largest query radius, thesis
// §10.2.2, so a query touches at most 2 x 2 x 2 cells); cells map to 2^k buckets (at least
// twice the photons, §10.3: no fewer entries than photons) by the hash of Teschner et al. 2003.
// Two modes:
//   exact       every photon of the pass is kept, bucket by bucket (counting sort; photons
//               inside a bucket ordered by their index, so the build is deterministic);
//   stochastic  thesis ch. 10 as §10.2.4 builds it, in one parallel pass over the photons with
//               no lists and no sort: every photon draws a random priority (the "depth value"
//               of §10.2.4's first approach, keyed by seed, pass and photon index) and is
//               written to its bucket by an atomic minimum on (priority, index), while an atomic
//               counter counts the bucket's photons; the winner is a uniform choice among the n
//               photons of its bucket and carries its power times n (§10.2.1), so the expected
//               sum over a bucket is unchanged and every query reads one entry per bucket. The
//               minimum does not depend on the order of the writes: the table is the same
//               whatever the thread count.
#pragma once

#include <functional>

#include <atomic>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "integrators/photon/photon_tracer.h"

namespace gp {

enum class PhotonHashMode { Exact, Stochastic };

class PhotonHashGrid {
 public:
  // min_buckets: at least this many buckets (a power of two is used), for grids queried far
  // more often than built, where fewer hash collisions pay (adaptive_photons.h).
  // `cancelled` is polled between the exact build's stages; once it returns true the build stops
  // and the grid is left empty (a cancelled pass is abandoned anyway).
  void build(const std::vector<Photon>& photons, float cell_size, PhotonHashMode mode, uint64_t seed,
             uint64_t pass, int threads, uint32_t min_buckets = 0, const std::function<bool()>& cancelled = {});

  // Calls fn(photon, distance^2, weight) for every stored photon within `radius` of p. The
  // weight is 1 (exact) or the number of photons its bucket held (stochastic): the factor
  // that multiplies its power (thesis §10.2.1) and its count.
  template <typename Fn>
  void query(const Vec3& p, float radius, Fn&& fn) const {
    if (stochastic_) visit(p, radius, [&](uint32_t i, float d2) { fn(photons_[i], d2, static_cast<float>(count_[i])); });
    else visit(p, radius, [&](uint32_t i, float d2) { fn(photons_[i], d2, 1.0f); });
  }

  // Exact mode only: calls fn(index, distance^2) with the index of every photon within `radius`
  // of p in the vector given to build(), so callers can look up data kept beside the points
  // (the adaptive photon sampler's grid of measurement points, adaptive_photons.h).
  template <typename Fn>
  void query_index(const Vec3& p, float radius, Fn&& fn) const {
    visit(p, radius, [&](uint32_t i, float d2) { fn(order_[i], d2); });
  }
  // As query_index, but pred(index, distance^2) returns true to stop: true if any did.
  template <typename Pred>
  bool any_index(const Vec3& p, float radius, Pred&& pred) const {
    return visit(p, radius, [&](uint32_t i, float d2) { return pred(order_[i], d2); });
  }

  size_t stored() const { return stored_; }
  size_t bucket_count() const { return static_cast<size_t>(mask_) + (built_ ? 1 : 0); }
  float cell_size() const { return cell_; }
  // Memory held (bytes), for the flat-memory test.
  size_t capacity_bytes() const;

 private:
  // fn(slot, distance^2) for every stored slot within `radius` of p, each bucket once; when fn
  // returns bool, true stops the visit and is returned.
  template <typename Fn>
  bool visit(const Vec3& p, float radius, Fn&& fn) const {
    if (!built_ || !(radius > 0)) return false;
    const float r2 = radius * radius;
    const int x0 = cell_coord(p.x - radius), x1 = cell_coord(p.x + radius);
    const int y0 = cell_coord(p.y - radius), y1 = cell_coord(p.y + radius);
    const int z0 = cell_coord(p.z - radius), z1 = cell_coord(p.z + radius);
    uint32_t seen[8];
    int n_seen = 0;
    std::vector<uint32_t> seen_many;  // only when the radius exceeds half a cell
    const bool many = (x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1) > 8;
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const uint32_t b = bucket(x, y, z);
          // Two cells of the query may share a bucket: visit each bucket once.
          bool dup = false;
          if (many) {
            for (uint32_t s : seen_many) dup |= s == b;
            if (dup) continue;
            seen_many.push_back(b);
          } else {
            for (int i = 0; i < n_seen; ++i) dup |= seen[i] == b;
            if (dup) continue;
            seen[n_seen++] = b;
          }
          // Stochastic: bucket b holds one photon (slot b) or none; exact: slots start_[b] ..
          const uint32_t first = stochastic_ ? b : start_[b];
          const uint32_t last = stochastic_ ? b + (count_[b] > 0 ? 1 : 0) : start_[b + 1];
          for (uint32_t i = first; i < last; ++i) {
            const Photon& ph = photons_[i];
            const float d2 = length_squared(ph.p - p);
            if (d2 <= r2) {
              if constexpr (std::is_same_v<decltype(fn(i, d2)), bool>) {
                if (fn(i, d2)) return true;
              } else {
                fn(i, d2);
              }
            }
          }
        }
    return false;
  }

  int cell_coord(float v) const { return static_cast<int>(std::floor(v * inv_cell_)); }
  uint32_t bucket(int x, int y, int z) const {
    return ((static_cast<uint32_t>(x) * 73856093u) ^ (static_cast<uint32_t>(y) * 19349663u) ^
            (static_cast<uint32_t>(z) * 83492791u)) & mask_;
  }

  bool build_exact(const std::vector<Photon>& photons, uint32_t buckets, int threads,
                   const std::function<bool()>& cancelled);  // false: cancelled
  void build_stochastic(const std::vector<Photon>& photons, uint32_t buckets, uint64_t seed, uint64_t pass,
                        int threads);

  float cell_ = 1, inv_cell_ = 1;
  uint32_t mask_ = 0;
  bool built_ = false, stochastic_ = false;
  size_t stored_ = 0;
  std::vector<Photon> photons_;     // exact: bucket order; stochastic: slot b = bucket b's photon
  std::vector<uint32_t> count_;     // stochastic: photons written to bucket b (0 = empty)
  std::vector<uint32_t> start_;     // exact: bucket b holds photons_[start_[b], start_[b + 1])
  std::vector<uint32_t> key_;       // exact: scratch, capacity kept between passes
  std::vector<uint32_t> order_;     // exact: slot -> index given to build() (query_index)
  std::vector<uint64_t> winner_;    // stochastic: (priority << 32 | index) of bucket b's photon
};

}  // namespace gp
