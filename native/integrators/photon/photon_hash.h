// Spatial hash grid over the photons of one pass, for the range queries of progressive
// photon mapping, rebuilt (in parallel) every pass and then discarded with the photons.
//
// Cells are cubes of side `cell_size` (callers use twice the largest query radius, thesis
// §10.2.2, so a query touches at most 2 x 2 x 2 cells); cells map to 2^k buckets by the
// hash of Teschner et al. 2003. Two modes:
//   exact       every photon of the pass is kept, bucket by bucket (counting sort);
//   stochastic  thesis ch. 10 (§10.2.1): each bucket keeps one of its n photons, chosen
//               uniformly, with its power multiplied by n, so every query does exactly one
//               fetch per bucket; unbiased: the expected sum over a bucket is unchanged.
// The build is deterministic: photons inside a bucket are ordered by their index, and the
// stochastic choice draws from a stream keyed by (seed, pass, bucket).
#pragma once

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
  void build(const std::vector<Photon>& photons, float cell_size, PhotonHashMode mode, uint64_t seed,
             uint64_t pass, int threads, uint32_t min_buckets = 0);

  // Calls fn(photon, distance^2, weight) for every stored photon within `radius` of p. The
  // weight is 1 (exact) or the number of photons its bucket held (stochastic): the factor
  // that multiplies its power (thesis §10.2.1) and its count.
  template <typename Fn>
  void query(const Vec3& p, float radius, Fn&& fn) const {
    visit(p, radius, [&](uint32_t i, float d2) { fn(photons_[i], d2, count_[i]); });
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

  size_t stored() const { return photons_.size(); }
  size_t bucket_count() const { return start_.empty() ? 0 : start_.size() - 1; }
  float cell_size() const { return cell_; }
  // Memory held (bytes), for the flat-memory test.
  size_t capacity_bytes() const;

 private:
  // fn(slot, distance^2) for every stored slot within `radius` of p, each bucket once; when fn
  // returns bool, true stops the visit and is returned.
  template <typename Fn>
  bool visit(const Vec3& p, float radius, Fn&& fn) const {
    if (start_.empty() || !(radius > 0)) return false;
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
          for (uint32_t i = start_[b], e = start_[b + 1]; i < e; ++i) {
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

  float cell_ = 1, inv_cell_ = 1;
  uint32_t mask_ = 0;
  std::vector<Photon> photons_;     // bucket order
  std::vector<float> count_;        // per stored photon: 1 (exact) or the bucket's count (stochastic)
  std::vector<uint32_t> start_;     // bucket b holds photons_[start_[b], start_[b + 1])
  std::vector<uint32_t> key_;               // scratch, capacity kept between passes
  std::vector<uint32_t> order_;             // slot -> index given to build() (query_index in exact mode)
  std::vector<uint32_t> bucket_count_;      // scratch
};

}  // namespace gp
