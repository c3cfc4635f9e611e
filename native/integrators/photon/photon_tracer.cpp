#include "integrators/photon/photon_tracer.h"

#include <atomic>
#include <optional>

#include "core/parallel.h"
#include "core/rng.h"
#include "materials/bsdf.h"
#include "integrators/photon/photon_walk.h"

namespace gp {

PhotonTracer::PhotonTracer(const Scene& scene, int max_depth, float specular_threshold, uint64_t seed,
                           int threads, DepositRule rule)
    : scene_(scene), max_depth_(max_depth), threshold_(specular_threshold), seed_(seed), threads_(threads), rule_(rule) {
  for (const Medium& m : scene.media) media_.push_back(rgb_channels(m));
}

namespace {

// The RGB photon (photon_walk.h's power type): its power, deposited into `dst`.
struct RgbPhoton {
  std::vector<Photon>& dst;
  std::vector<Photon>* volume;                      // volume photons (null: not kept)
  const std::vector<MediumChannels>& media;         // the scene's media at R, G, B
  RGB beta{0.0f}, pending{0.0f};
  bool emit(const PhotonEmission& em) {
    beta = em.power;
    return true;
  }
  bool finite() const { return beta.is_finite(); }
  void deposit(const SurfaceHit& hit, const Vec3& wi, uint8_t lobes, bool world_share) {
    dst.push_back(Photon{hit.p, wi, beta, 0, lobes, world_share});
  }
  void scale(float s) { beta = beta * s; }
  void prepare(const SurfaceHit&) {}
  std::optional<BsdfSample> sample(const SurfaceHit&, const Bsdf& bsdf, const Vec3& wo, float uc, Vec2 u) const {
    auto bs = bsdf.sample(wo, uc, u, TransportMode::Importance);
    if (!bs || bs->pdf <= 0 || bs->f.is_black()) return std::nullopt;
    return bs;
  }
  bool weigh(const SurfaceHit&, const Bsdf& bsdf, const Vec3& wo, const BsdfSample& bs, float, Vec2,
             float correction, uint8_t lobes) {
    pending = beta * bs.f * (std::abs(bs.wi.z) / bs.pdf * correction);
    if (lobes != kAllLobes) {  // f_V / p_V of the lobes the segment's kinds see
      if (!(bs.lobe & lobes)) return false;
      if (!bs.delta) {
        const float pdf_v = bsdf.pdf(wo, bs.wi, lobes);
        if (!(pdf_v > 0)) return false;
        pending = beta * bsdf.eval(wo, bs.wi, TransportMode::Importance, lobes) *
                  (std::abs(bs.wi.z) / pdf_v * correction);
      }
    }
    return true;
  }
  float max_old() const { return beta.max_component(); }
  float max_new() const { return pending.max_component(); }
  void commit(float p_continue) { beta = pending / p_continue; }
  RGB origin_scale(float denom) const { return beta / denom; }
  // ---- Participating media (photon_walk.h) ----
  int channels() const { return 3; }
  const MediumChannels& medium_channels(int m) const { return media[m]; }
  ChannelValues channel_weights() const {
    ChannelValues w{};
    for (int k = 0; k < 3; ++k) w[k] = beta[k];
    return w;
  }
  void medium_weight(const ChannelValues& w) { beta *= RGB(w[0], w[1], w[2]); }
  void deposit_volume(const Vec3& p, const Vec3& wi) {
    if (volume) volume->push_back(Photon{p, wi, beta, 0, kAllLobes, false});
  }
};

}  // namespace

int64_t PhotonTracer::trace_path(PrimarySamples& u, int min_deposit_bounce, std::vector<Photon>& dst,
                                 int64_t& invalid, PhotonPathRecord* record,
                                 std::vector<PhotonOrigin>* origins, std::vector<PhotonChain>* chains,
                                 std::vector<Photon>* volume) const {
  RgbPhoton power{dst, volume, media_};
  return walk(u, min_deposit_bounce, power, invalid, record, origins, chains);
}

void concatenate_chunks(std::vector<std::vector<Photon>>& chunks, size_t n_chunks, int threads,
                        std::vector<Photon>& out) {
  std::vector<size_t> offset(n_chunks + 1, 0);
  for (size_t c = 0; c < n_chunks; ++c) offset[c + 1] = offset[c] + chunks[c].size();
  out.resize(offset[n_chunks]);
  parallel_for(n_chunks, threads, [&](size_t lo, size_t hi) {
    for (size_t c = lo; c < hi; ++c) {
      std::copy(chunks[c].begin(), chunks[c].end(), out.begin() + offset[c]);
      for (size_t k = offset[c]; k < offset[c + 1]; ++k) out[k].index = static_cast<uint32_t>(k);
      chunks[c].clear();
    }
  });
}

size_t PhotonTracer::capacity_bytes() const {
  size_t b = 0;
  for (const auto& c : chunks_) b += c.capacity() * sizeof(Photon);
  for (const auto& c : chunk_volume_) b += c.capacity() * sizeof(Photon);
  for (const auto& c : chunk_origins_) b += c.capacity() * sizeof(PhotonOrigin);
  for (const auto& c : chunk_chains_) b += c.capacity() * sizeof(PhotonChain);
  return b;
}

PhotonPassStats PhotonTracer::trace(int64_t count, uint64_t pass, int min_deposit_bounce,
                                    std::vector<Photon>& out, std::vector<PhotonOrigin>* origins,
                                    std::vector<PhotonChain>* chains, const std::function<bool()>& cancelled,
                                    std::vector<Photon>* volume) {
  if (!origins) chains = nullptr;
  PhotonPassStats stats;
  stats.emitted = count;
  const LightSet& lights = scene_.light_set();
  const size_t n_chunks = static_cast<size_t>((count + kChunk - 1) / kChunk);
  if (chunks_.size() < n_chunks) chunks_.resize(n_chunks);
  if (origins && chunk_origins_.size() < n_chunks) chunk_origins_.resize(n_chunks);
  if (chains && chunk_chains_.size() < n_chunks) chunk_chains_.resize(n_chunks);
  if (volume && chunk_volume_.size() < n_chunks) chunk_volume_.resize(n_chunks);
  std::atomic<int64_t> rays{0}, invalid{0};
  if (!lights.empty() && count > 0) {
    for_photon_chunks(
        count, seed_ ^ 0x70686f746f6e73ULL, pass, threads_, cancelled, rays, invalid,
        [&](size_t c) {
          chunks_[c].clear();
          if (origins) chunk_origins_[c].clear();
          if (chains) chunk_chains_[c].clear();
          if (volume) chunk_volume_[c].clear();
        },
        [&](size_t c, PrimarySamples& u, int64_t& local_invalid) {
          return trace_path(u, min_deposit_bounce, chunks_[c], local_invalid, nullptr,
                            origins ? &chunk_origins_[c] : nullptr, chains ? &chunk_chains_[c] : nullptr,
                            volume ? &chunk_volume_[c] : nullptr);
        });
  }
  // ---- Concatenate in chunk order (independent of the thread count) ----
  std::vector<size_t> offset(n_chunks + 1, 0);
  for (size_t c = 0; c < n_chunks; ++c) offset[c + 1] = offset[c] + chunks_[c].size();
  out.resize(offset[n_chunks]);
  if (origins) origins->resize(offset[n_chunks]);
  std::vector<size_t> chain_offset(n_chunks + 1, 0);
  if (chains) {
    for (size_t c = 0; c < n_chunks; ++c) chain_offset[c + 1] = chain_offset[c] + chunk_chains_[c].size();
    chains->resize(chain_offset[n_chunks]);
  }
  parallel_for(n_chunks, threads_, [&](size_t lo, size_t hi) {
    for (size_t c = lo; c < hi; ++c) {
      std::copy(chunks_[c].begin(), chunks_[c].end(), out.begin() + offset[c]);
      for (size_t k = offset[c]; k < offset[c + 1]; ++k) out[k].index = static_cast<uint32_t>(k);
      if (origins) std::copy(chunk_origins_[c].begin(), chunk_origins_[c].end(), origins->begin() + offset[c]);
      if (chains) {
        std::copy(chunk_chains_[c].begin(), chunk_chains_[c].end(), chains->begin() + chain_offset[c]);
        for (size_t k = offset[c]; k < offset[c + 1]; ++k)
          if ((*origins)[k].chain >= 0) (*origins)[k].chain += static_cast<int32_t>(chain_offset[c]);
      }
    }
  });
  if (volume) concatenate_chunks(chunk_volume_, n_chunks, threads_, *volume);
  for (size_t c = 0; c < n_chunks; ++c) {
    chunks_[c].clear();
    if (origins) chunk_origins_[c].clear();
    if (chains) chunk_chains_[c].clear();
  }
  stats.stored = static_cast<int64_t>(out.size());
  stats.rays = rays;
  stats.invalid = invalid;
  return stats;
}

}  // namespace gp
