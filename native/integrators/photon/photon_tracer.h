// Photon tracing shared by the progressive photon mapping family (thesis ch. 5, §5.3.4
// "photon tracing passes"): photons leave the lights in proportion to their power
// (LightSet::sample_le), scatter with the importance (adjoint) form of the BSDFs, are ended
// by Russian roulette, and are deposited at every vertex whose BSDF is diffuse for photon
// methods (Bsdf::is_diffuse_for_photons: roughness above the specular threshold), or for
// MSPPM at every non-delta vertex (DepositRule).
//
// A photon path is a function of its primary samples, a point of the unit hypercube (thesis
// §8.2.1-8.2.2, after Kelemen et al.): trace_path() reads them one by one from a
// PrimarySamples source in a fixed order (emission: light choice, 2 for the position, 2 for
// the direction; every bounce: lobe choice, 2 for the direction, 1 for Russian roulette), so
// coordinate k always means the same thing. Uniform photon tracing feeds it fresh uniform
// numbers (RngSamples, used by trace()); the adaptive MCMC sampler (adaptive_photons.h) feeds
// it stored and mutated coordinates.
//
// trace() works in fixed chunks, each drawing from its own random stream keyed by
// (seed, chunk, pass), and concatenated in chunk order: the photon list (and so the image)
// does not depend on the thread count. Stored power is not divided by the number of emitted
// photons; estimators divide by it (thesis eq. 5.10 / 5.13).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/color.h"
#include "core/frame.h"
#include "core/math.h"
#include "core/rng.h"
#include "integrators/paths/light_chain.h"
#include "integrators/paths/medium_stack.h"
#include "materials/bsdf.h"
#include "media/medium.h"
#include "scene/scene.h"

namespace gp {

struct Photon {
  Vec3 p;       // where it landed
  Vec3 wi;      // unit world direction back towards where it came from
  RGB power;    // flux it carries (W), before division by the number of emitted photons
  uint32_t index = 0;  // position in the pass's photon list (links it to its PhotonOrigin)
  // The lobes (kRay* bits) a gather may light with it: the kinds of bounce ray that see where
  // it came from through the surfaces it crossed (photon_tracer.cpp: a light or a surface hidden
  // from some kinds); all when nothing on its way hides anything.
  uint8_t lobes = kAllLobes;
  // Straight from a World hidden from some kinds (Light::lit_by_bsdf_rays_only), traced with
  // PhotonTracer::set_world_by_closure_share: a gather lights with f q_V, q_V the share of
  // Cycles' closure choice in `lobes` (lobe_split.h, gathered_f), not with those lobes' f.
  bool world_share = false;
};

// Where a photon came from: its previous light-path vertex y_{s-1} (GPM §4.2 needs it to shift
// the photon: the offset photon is traced from y_{s-1}, and DD endings reconnect there).
// Recorded only when PhotonTracer::trace is given an `origins` list.
struct PhotonOrigin {
  Vec3 p;              // y_{s-1}
  Vec3 ng;             // its geometric normal
  Frame frame;         // its shading frame
  Vec3 wo;             // local direction at y_{s-1} towards y_{s-2} (or the light)
  RGB scale;           // power arriving at y_{s-1} / (pdf * Russian-roulette survival)
  float pdf = 0;       // solid-angle pdf with which y_{s-1} sampled the direction to y_s
  int material = -1;   // material at y_{s-1}
  Vec2 uv;  // texture coordinate there (Scene::bsdf)
  bool diffuse = false;  // y_{s-1} is diffuse for photon methods (a DD ending, GPM §4.2 step 2)
  Vec3 n_photon;       // geometric normal at the photon y_s
  int32_t chain = -1;  // !diffuse: its PhotonChain in the pass's list (-1: none recorded)
  // The segment y_{s-1} -> y_s crossed a surface hidden from some of its kinds, or y_s is one:
  // the tracer chose there between crossing and scattering (per-kind switches; GPM shifts none).
  bool branched = false;
};

// Optional record of whole photon paths (thesis §9.5 step 1: "each photon stores a pointer to
// the photon at the previous bounce"), for the path densities of multisampled PPM
// (msppm.h). A path's vertices are consecutive: its light vertex (start = true), then
// every surface hit in order, specular and crossed ones included, and its scattering points in
// media (medium = true).
struct PhotonPathVertex {
  Vec3 p, ng;       // light vertex: origin on the light (or on the emission disk) and its normal
  Frame frame;      // shading frame (surface vertices)
  Vec3 wi;          // surface: unit direction towards the previous vertex; light: direction of travel
  float pdf_fwd;    // area density the light side sampled this vertex with (light vertex: see
                    // PhotonEmission; distant lights: pdf_dir, and the first hit pdf_pos |cos|)
  int material = -1;
  Vec2 uv;  // texture coordinate there (Scene::bsdf)
  int light = -1;   // light vertex: the light
  bool delta = false;  // specular BSDF: its direction density counts as 1 on both sides
  bool start = false;
  // A surface hidden from some of the segment's kinds that the photon went on through (per-kind
  // switches, photon_tracer.cpp): not a vertex of the path, but a deposit may have been made
  // there (it received the photon), so it stays in the record for deposit_vertex to point at.
  bool crossed = false;
  // A scattering point in a participating medium (photon_walk.h): p, wi; no surface.
  bool medium = false;
};
struct PhotonPathRecord {
  std::vector<PhotonPathVertex> vertices;
  std::vector<uint32_t> deposit_vertex;  // per deposit appended to `out`: its vertex index
  void clear() { vertices.clear(); deposit_vertex.clear(); }
};

struct PhotonPassStats {
  int64_t emitted = 0;   // photon paths started (including those whose emission sample failed)
  int64_t stored = 0;    // photons deposited
  int64_t rays = 0;      // closest-hit rays traced
  int64_t invalid = 0;   // deposits dropped because their power was NaN/Inf
};

// Source of the primary samples (coordinates in [0, 1)) one photon path consumes in order.
class PrimarySamples {
 public:
  virtual ~PrimarySamples() = default;
  virtual float next() = 0;
};

// Fresh uniform numbers from an Rng: ordinary (uniform) photon tracing.
class RngSamples final : public PrimarySamples {
 public:
  explicit RngSamples(Rng& rng) : rng_(rng) {}
  float next() override { return rng_.uniform(); }

 private:
  Rng& rng_;
};

// Per-kind switches (photon_tracer.cpp): the probability that a photon whose segment reached a
// surface hidden from some of its kinds crosses it rather than scattering there: 1 where nothing
// would leave the surface (no kind of ray sees it, it is black, or the path is at its last
// bounce), else 1/2.
inline float crossing_probability(uint8_t seen_by, bool black, bool last_bounce) {
  return seen_by == 0 || black || last_bounce ? 1.0f : 0.5f;
}

// Where photons are deposited: at vertices diffuse for photon methods (roughness above the
// specular threshold; (S)PPM, GPM), or at every non-delta vertex (MSPPM, whose weights decide
// between density estimation and path tracing without a classification, thesis §9.6).
enum class DepositRule { DiffuseForPhotons, NonDelta };

// Replaces `out` by chunks[0 .. n_chunks) in chunk order (so not in thread order), numbering
// the photons (Photon::index), and clears the chunks (their capacity kept).
void concatenate_chunks(std::vector<std::vector<Photon>>& chunks, size_t n_chunks, int threads,
                        std::vector<Photon>& out);

class PhotonTracer {
 public:
  // max_depth: longest photon path in segments; min_deposit_bounce: deposits happen from this
  // many scattering events on (0 = also the first hit from the light; 1 = skip direct light).
  PhotonTracer(const Scene& scene, int max_depth, float specular_threshold, uint64_t seed, int threads,
               DepositRule rule = DepositRule::DiffuseForPhotons);

  // Traces `count` photon paths for pass `pass`; replaces `out` (its capacity is reused, so
  // memory stays flat over passes). With `origins`, also fills origins[k] for photon k (GPM),
  // and with `chains` the specular chains they point to; the random streams, and so the
  // photons, are the same either way. `cancelled` is polled (from the workers) before every
  // chunk of kChunk photons: once it returns true the remaining chunks stay empty and the
  // caller abandons the pass (a million photons would otherwise delay a cancel by a second).
  PhotonPassStats trace(int64_t count, uint64_t pass, int min_deposit_bounce, std::vector<Photon>& out,
                        std::vector<PhotonOrigin>* origins = nullptr, std::vector<PhotonChain>* chains = nullptr,
                        const std::function<bool()>& cancelled = {}, std::vector<Photon>* volume = nullptr);

  // Traces one photon path from the primary samples `u`, appending its deposits to `out`.
  // Returns the closest-hit rays traced; deposits with NaN/Inf power are dropped and counted
  // in `invalid`. Thread-safe (const).
  // With `record`, the path's vertices and the vertex of every deposit are appended to it;
  // with `origins`, each deposit's previous scattering vertex (GPM's photon shift), and with
  // `chains` (only with `origins`) the specular chain before it (PhotonOrigin::chain indexes it).
  // With `volume`, the photons scattered in participating media (photon_walk.h); without, they
  // still scatter there but none is kept. trace() replaces `volume` as it replaces `out`.
  int64_t trace_path(PrimarySamples& u, int min_deposit_bounce, std::vector<Photon>& out, int64_t& invalid,
                     PhotonPathRecord* record = nullptr, std::vector<PhotonOrigin>* origins = nullptr,
                     std::vector<PhotonChain>* chains = nullptr, std::vector<Photon>* volume = nullptr) const;
  // The walk trace_path and the spectral photons share (photon_walk.h), generic over what the
  // photon carries (`P`: RgbPhoton in photon_tracer.cpp, SpectralPhotonPower in
  // progressive_photon_spectral.cpp), which also receives the deposits.
  template <class P>
  int64_t walk(PrimarySamples& u, int min_deposit_bounce, P& power, int64_t& invalid,
               PhotonPathRecord* record = nullptr, std::vector<PhotonOrigin>* origins = nullptr,
               std::vector<PhotonChain>* chains = nullptr) const;

  int max_depth() const { return max_depth_; }
  // Bytes held by the per-chunk output kept between passes.
  size_t capacity_bytes() const;
  // Whether a photon arriving at a surface with this BSDF is deposited there.
  bool deposits_at(const Bsdf& bsdf) const {
    return rule_ == DepositRule::NonDelta ? !bsdf.is_delta() : bsdf.is_diffuse_for_photons(threshold_);
  }
  int threads() const { return threads_; }
  uint64_t seed() const { return seed_; }
  // A World hidden from some kinds by Cycles' rule (lobe_split.h) rather than the lights' rule
  // (photon_tracer.cpp): its photons are gathered with f q_V (Photon::world_share).
  // Off by default: GPM's photon shifts (gpm.cpp) and MSPPM's path densities (msppm_weights.cpp)
  // follow the lights' rule.
  void set_world_by_closure_share(bool on) { world_share_ = on; }
  // Participating media (photon_walk.h): off by default, so methods that do not render media
  // (MSPPM, GPM) leave them out as their declarations say; PPM and SPPM turn it on.
  // Each light's photons start in the media around it (LightMedia, found here once).
  void set_media(bool on) {
    media_on_ = on && scene_.has_media();
    light_media_ = media_on_ ? LightMedia(scene_) : LightMedia();
  }

  static constexpr int64_t kChunk = 4096;  // photons per random stream / work item
  // Surfaces hidden from some kinds of ray that one photon segment may cross (trace_path).
  static constexpr int kMaxCrossed = 16;

 private:
  const Scene& scene_;
  int max_depth_;
  float threshold_;
  uint64_t seed_;
  int threads_;
  DepositRule rule_;
  bool world_share_ = false;  // set_world_by_closure_share
  bool media_on_ = false;     // set_media
  LightMedia light_media_;    // set_media: the media around each light
  std::vector<std::vector<Photon>> chunks_;  // per-chunk output, capacity kept between passes
  std::vector<std::vector<PhotonOrigin>> chunk_origins_;  // the same, for `origins`
  std::vector<std::vector<PhotonChain>> chunk_chains_;    // and for `chains`
  std::vector<std::vector<Photon>> chunk_volume_;         // and for `volume`
  std::vector<MediumChannels> media_;                     // the scene's media at R, G, B
};

}  // namespace gp
