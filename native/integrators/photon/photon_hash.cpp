#include "integrators/photon/photon_hash.h"

#include <algorithm>
#include <atomic>

#include "core/parallel.h"
#include "core/rng.h"

namespace gp {

size_t PhotonHashGrid::capacity_bytes() const {
  return photons_.capacity() * sizeof(Photon) + winner_.capacity() * sizeof(uint64_t) +
         (count_.capacity() + start_.capacity() + key_.capacity() + order_.capacity()) * sizeof(uint32_t);
}

void PhotonHashGrid::build(const std::vector<Photon>& photons, float cell_size, PhotonHashMode mode,
                           uint64_t seed, uint64_t pass, int threads, uint32_t min_buckets,
                           const std::function<bool()>& cancelled) {
  built_ = false;  // until this build completes
  cell_ = cell_size > 0 ? cell_size : 1.0f;
  inv_cell_ = 1.0f / cell_;
  const size_t n = photons.size();
  uint32_t buckets = 1024;
  while ((buckets < 2 * n || buckets < min_buckets) && buckets < (1u << 30)) buckets <<= 1;
  mask_ = buckets - 1;
  stochastic_ = mode == PhotonHashMode::Stochastic;
  if (stochastic_) build_stochastic(photons, buckets, seed, pass, threads);
  else if (!build_exact(photons, buckets, threads, cancelled)) return;  // cancelled: left unbuilt
  built_ = true;
}

bool PhotonHashGrid::build_exact(const std::vector<Photon>& photons, uint32_t buckets, int threads,
                                 const std::function<bool()>& cancelled) {
  const size_t n = photons.size();
  // Each stage over 16 M buckets (the visibility grid at 1080p) takes up to a few hundred ms.
  auto stop = [&] {
    if (!cancelled || !cancelled()) return false;
    stored_ = 0;  // left unbuilt (built_ false): every query finds nothing
    return true;
  };
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
  if (stop()) return false;
  // ---- 2. exclusive prefix sum ----
  start_.resize(buckets + 1);
  uint32_t acc = 0;
  for (uint32_t b = 0; b < buckets; ++b) {
    start_[b] = acc;
    acc += counts[b].load(std::memory_order_relaxed);
    counts[b].store(start_[b], std::memory_order_relaxed);  // becomes the write cursor
  }
  start_[buckets] = acc;
  if (stop()) return false;
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
  if (stop()) return false;
  photons_.resize(n);
  parallel_for(n, threads, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i) photons_[i] = photons[order_[i]];
  });
  stored_ = n;
  return true;
}

void PhotonHashGrid::build_stochastic(const std::vector<Photon>& photons, uint32_t buckets, uint64_t seed,
                                      uint64_t pass, int threads) {
  // ---- Thesis Fig. 10.1 CONSTRUCT, one parallel pass over the photons (§10.2.4) ----
  // Table[h] <- photon (the smallest random priority wins: a uniform choice, §10.2.4's depth
  // test), AtomicInc(Count[h]). std::atomic_ref (C++20) on the plain arrays, reset each build.
  constexpr uint64_t kEmpty = ~uint64_t{0};
  winner_.assign(buckets, kEmpty);
  count_.assign(buckets, 0);
  const size_t n = photons.size();
  const uint64_t key = mix_bits(seed ^ 0x73686173ULL) ^ mix_bits(pass + 0x9E3779B97F4A7C15ULL);
  parallel_for(n, threads, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i) {
      const Vec3& p = photons[i].p;
      const uint32_t b = bucket(cell_coord(p.x), cell_coord(p.y), cell_coord(p.z));
      const uint64_t priority = mix_bits(key + i) >> 32;
      const uint64_t mine = priority << 32 | static_cast<uint64_t>(i);
      std::atomic_ref<uint64_t> slot(winner_[b]);
      uint64_t cur = slot.load(std::memory_order_relaxed);
      while (mine < cur && !slot.compare_exchange_weak(cur, mine, std::memory_order_relaxed)) {
      }
      std::atomic_ref<uint32_t>(count_[b]).fetch_add(1, std::memory_order_relaxed);
    }
  });
  // ---- Step 3: the winners, read in place; their weight (count) multiplies the flux at query ----
  photons_.resize(buckets);
  std::atomic<size_t> kept{0};
  parallel_for(buckets, threads, [&](size_t lo, size_t hi) {
    size_t local = 0;
    for (size_t b = lo; b < hi; ++b)
      if (count_[b] > 0) {
        photons_[b] = photons[static_cast<uint32_t>(winner_[b] & 0xffffffffu)];
        ++local;
      }
    kept += local;
  });
  stored_ = kept;
}

}  // namespace gp
