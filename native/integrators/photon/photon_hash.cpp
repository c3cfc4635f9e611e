#include "integrators/photon/photon_hash.h"

#include <algorithm>
#include <atomic>

#include "core/parallel.h"
#include "core/rng.h"

namespace gp {

size_t PhotonHashGrid::capacity_bytes() const {
  return photons_.capacity() * sizeof(Photon) + count_.capacity() * sizeof(float) +
         (start_.capacity() + key_.capacity() + order_.capacity() + bucket_count_.capacity()) * sizeof(uint32_t);
}

void PhotonHashGrid::build(const std::vector<Photon>& photons, float cell_size, PhotonHashMode mode,
                           uint64_t seed, uint64_t pass, int threads, uint32_t min_buckets) {
  cell_ = cell_size > 0 ? cell_size : 1.0f;
  inv_cell_ = 1.0f / cell_;
  const size_t n = photons.size();
  uint32_t buckets = 1024;
  while ((buckets < 2 * n || buckets < min_buckets) && buckets < (1u << 30)) buckets <<= 1;
  mask_ = buckets - 1;

  // ---- 1. bucket of every photon, and bucket sizes (parallel, atomic counts) ----
  key_.resize(n);
  std::vector<std::atomic<uint32_t>> counts(buckets);  // value-initialised to 0
  parallel_for(n, threads, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i) {
      const Vec3& p = photons[i].p;
      key_[i] = bucket(cell_coord(p.x), cell_coord(p.y), cell_coord(p.z));
      counts[key_[i]].fetch_add(1, std::memory_order_relaxed);
    }
  });
  // ---- 2. exclusive prefix sum ----
  start_.resize(buckets + 1);
  uint32_t acc = 0;
  for (uint32_t b = 0; b < buckets; ++b) {
    start_[b] = acc;
    acc += counts[b].load(std::memory_order_relaxed);
    counts[b].store(start_[b], std::memory_order_relaxed);  // becomes the write cursor
  }
  start_[buckets] = acc;
  // ---- 3. scatter photon indices, then order each bucket by index (determinism) ----
  order_.resize(n);
  parallel_for(n, threads, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i)
      order_[counts[key_[i]].fetch_add(1, std::memory_order_relaxed)] = static_cast<uint32_t>(i);
  });
  parallel_for(buckets, threads, [&](size_t lo, size_t hi) {
    for (size_t b = lo; b < hi; ++b)
      if (start_[b + 1] - start_[b] > 1) std::sort(order_.begin() + start_[b], order_.begin() + start_[b + 1]);
  });

  if (mode == PhotonHashMode::Exact) {
    photons_.resize(n);
    count_.assign(n, 1.0f);
    parallel_for(n, threads, [&](size_t lo, size_t hi) {
      for (size_t i = lo; i < hi; ++i) photons_[i] = photons[order_[i]];
    });
    return;
  }

  // ---- Stochastic selection (thesis §10.2.1): one photon per bucket, power scaled by n ----
  bucket_count_.resize(buckets);
  uint32_t kept = 0;
  for (uint32_t b = 0; b < buckets; ++b) {
    const uint32_t c = start_[b + 1] - start_[b];
    bucket_count_[b] = c;
    start_[b] = kept;
    kept += c > 0;
  }
  start_[buckets] = kept;
  photons_.resize(kept);
  count_.resize(kept);
  parallel_for(buckets, threads, [&](size_t lo, size_t hi) {
    for (size_t b = lo; b < hi; ++b) {
      const uint32_t c = bucket_count_[b];
      if (c == 0) continue;
      // Recover the bucket's first index in order_: sum of earlier counts is not stored, so
      // the cursor left by the scatter (end of bucket) minus the count gives it.
      const uint32_t end = counts[b].load(std::memory_order_relaxed);
      Rng rng = Rng::for_key(seed ^ 0x73686173ULL, b, pass);
      const uint32_t pick = std::min(c - 1, static_cast<uint32_t>(rng.uniform() * c));
      photons_[start_[b]] = photons[order_[end - c + pick]];
      count_[start_[b]] = static_cast<float>(c);
    }
  });
}

}  // namespace gp
