#include "integrators/photon/photon_tracer.h"

#include <atomic>
#include <optional>

#include "core/parallel.h"
#include "core/rng.h"
#include "materials/bsdf.h"

namespace gp {

PhotonTracer::PhotonTracer(const Scene& scene, int max_depth, float specular_threshold, uint64_t seed,
                           int threads, DepositRule rule)
    : scene_(scene), max_depth_(max_depth), threshold_(specular_threshold), seed_(seed), threads_(threads), rule_(rule) {}

int64_t PhotonTracer::trace_path(PrimarySamples& u, int min_deposit_bounce, std::vector<Photon>& dst,
                                 int64_t& invalid, PhotonPathRecord* record,
                                 std::vector<PhotonOrigin>* origins, std::vector<PhotonChain>* chains) const {
  const LightSet& lights = scene_.light_set();
  if (lights.empty()) return 0;
  int64_t rays = 0;
  // ---- Emission ----
  const float us = u.next();
  const float up0 = u.next(), up1 = u.next(), ud0 = u.next(), ud1 = u.next();
  const auto em = lights.sample_le(us, Vec2(up0, up1), Vec2(ud0, ud1));
  if (!em || em->power.is_black()) return 0;
  RGB beta = em->power;
  Ray ray = em->n.x != 0 || em->n.y != 0 || em->n.z != 0 ? Ray(offset_ray_origin(em->o, em->n, em->d), em->d)
                                                          : Ray(em->o, em->d);
  const bool distant = lights.lights()[em->light].is_infinite();
  // The light's Diffuse / Glossy / Transmission switches (Light::visible_lobes), by Cycles' rule
  // that a ray's kind is the kind of the bounce that spawned it on the camera side: the first
  // segment, light to first hit y, is the ray y's bounce sends towards the light. So a photon
  // deposited at y lights only the lobes of y that see the light (Photon::lobes, read by the
  // gather), and one scattered on from y counts when the lobe it sampled there sees the light,
  // weighted by that lobe set's f and density (as the path tracer's BSDF hits).
  //
  // Surfaces' switches (Material::visible_lobes) follow from the same rule: every segment x -> y
  // takes the kind of the bounce at y, so `arrive`, the kinds it may be, is those that see x
  // (the light's, then the last surface's) and that every surface it crossed is hidden from. A
  // surface y hidden from some of those kinds both receives the photon (for all of them: y's
  // own switches are about rays towards y) and lets it through (for the kinds hidden): the
  // photon is deposited at y, then either scatters there or goes on past y, chosen at random
  // and weighted by the inverse probability, as the path tracer's rays of those kinds cross y.
  // A recorded path (multisampled PPM's path densities) keeps a crossed surface as a vertex
  // marked `crossed`, which its densities skip (the segment goes straight on through it).
  //
  // A World hidden from some kinds follows Cycles' rule instead where asked
  // (set_world_by_closure_share; lobe_split.h): Cycles' BSDF ray of a visible kind that finds it
  // carries the whole f / pdf, so a photon straight from it (until its first scattering
  // vertex) is deposited for the gather to weigh by f q_V (Photon::world_share): in the adjoint
  // view where it lands is where Cycles' BSDF ray from the measurement point meets the sky.
  // Its scattering on still takes the lights' rule below (f_V / p_V), where Cycles' would be
  // f q_V / p with q_V(wo = the sampled direction, wi = towards the sky): not done yet.
  uint8_t arrive = lights.lights()[em->light].visible_lobes;
  const bool world_rule = world_share_ && lights.lights()[em->light].lit_by_bsdf_rays_only();
  float t_crossed = 0;  // distance along the segment before the last surface crossed (records)
  int crossed = 0;      // surfaces crossed on this segment (a bound, as Embree's filters have none)
  // Surfaces the photon scattered at so far, light objects (pass-through surfaces, which Cycles'
  // rays cross as if they were not there) not counted: the first hit above is the first
  // surface that is not one, and min_deposit_bounce counts these (a photon that crossed a
  // light object and landed is still direct light, which next-event estimation covers).
  int scattered = 0;
  float pdf_dir_prev = em->pdf_dir;  // solid-angle density of the segment being traced
  PhotonOrigin last;                 // the previous scattering vertex (valid from bounce 1 on)
  // The light subpath since its last diffuse vertex (GPM's specular chains); a distant light's
  // chain keeps its direction (PhotonChain::dir).
  // Only built when asked for: it is a few hundred bytes to clear on every path.
  std::optional<PhotonChain> chain_store;
  PhotonChain* chain = chains ? &chain_store.emplace() : nullptr;
  bool chain_ok = chains != nullptr;
  if (chains) {
    chain->p = em->o;
    chain->ng = distant ? Vec3(0.0f) : em->n;
    chain->dir = distant ? em->d : Vec3(0.0f);
    chain->light = em->light;
  }
  if (record) {
    PhotonPathVertex lv;
    lv.p = em->o;
    lv.ng = em->n;
    lv.wi = em->d;
    lv.pdf_fwd = distant ? em->pdf_dir : em->pdf_pos;
    lv.light = em->light;
    lv.start = true;
    record->vertices.push_back(lv);
  }
  for (int bounce = 0; bounce + 1 <= max_depth_; ++bounce) {
    ++rays;
    const auto hit = scene_.intersect(ray);
    if (!hit) break;
    const Bsdf bsdf = scene_.bsdf(*hit);
    const Material& mat = scene_.material(hit->material);
    const uint8_t seen_by = mat.visible_lobes & kAllLobes;  // the next segment's kinds
    if (bsdf.is_black() && !(arrive & ~seen_by)) break;     // (one that hides some goes on below)
    const bool diffuse = bsdf.is_diffuse_for_photons(threshold_);
    if (record) {
      PhotonPathVertex v;
      v.p = hit->p;
      v.ng = hit->ng;
      v.frame = hit->frame;
      v.wi = -ray.d;
      const float cos_in = std::abs(dot(hit->ng, ray.d));
      const float t = t_crossed + hit->t;
      v.pdf_fwd = bounce == 0 && distant ? em->pdf_pos * cos_in : pdf_dir_prev * cos_in / (t * t);
      v.material = hit->material;
      v.uv = hit->uv;
      v.delta = bsdf.is_delta();
      record->vertices.push_back(v);
    }
    // ---- Deposit (at diffuse vertices, or every non-delta one: DepositRule) ----
    if (scattered >= min_deposit_bounce && !bsdf.is_black() && deposits_at(bsdf)) {
      if (beta.is_finite()) {
        dst.push_back(Photon{hit->p, -ray.d, beta, 0, arrive, world_rule && scattered == 0});
        if (record) record->deposit_vertex.push_back(static_cast<uint32_t>(record->vertices.size() - 1));
        if (origins) {
          last.n_photon = hit->ng;
          last.chain = -1;
          last.branched = crossed > 0 || (arrive & ~seen_by);
          if (chain_ok && !last.diffuse && bounce > 0 && chain->count > 0) {
            last.chain = static_cast<int32_t>(chains->size());
            chains->push_back(*chain);
          }
          origins->push_back(last);
        }
      } else {
        ++invalid;
      }
    }
    // ---- A surface hidden from some of the segment's kinds: scatter here or cross it ----
    const bool pass_through = mat.is_pass_through();
    if (const uint8_t hidden = arrive & ~seen_by; hidden && !pass_through && crossed < kMaxCrossed) {
      const float q = crossing_probability(seen_by, bsdf.is_black(), bounce + 2 > max_depth_);
      const bool cross = q == 1.0f || u.next() < q;
      if (cross) {
        if (record) record->vertices.back().crossed = true;
        beta = beta / q;
        arrive = hidden;
        ++crossed;
        t_crossed += hit->t;
        chain_ok = false;  // the chain's segments no longer join its vertices (GPM shifts none)
        const RayState state = ray.state;
        ray = Ray(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
        ray.state = state;
        --bounce;  // not a bounce: the path tracer's ray of those kinds does not stop here
        continue;
      }
      beta = beta / (1.0f - q);
    }
    // Nothing leaves a black surface, or one no kind of bounce ray sees.
    if (bsdf.is_black() || (seen_by == 0 && !pass_through)) break;
    if (bounce + 2 > max_depth_) break;
    // ---- Scattering (adjoint BSDF) ----
    const Vec3 wo_world = -ray.d;
    const Vec3 wo = hit->frame.to_local(wo_world);
    if (wo.z == 0) break;
    const float uc = u.next();
    const float u0 = u.next(), u1 = u.next();
    const auto bs = bsdf.sample(wo, uc, Vec2(u0, u1), TransportMode::Importance);
    if (!bs || bs->pdf <= 0 || bs->f.is_black()) break;
    pdf_dir_prev = bsdf.is_delta() ? 1.0f : bs->pdf;
    const Vec3 wi_world = hit->frame.to_world(bs->wi);
    const float correction = adjoint_shading_correction(wo_world, wi_world, hit->ng, hit->ns);
    if (correction == 0) break;
    RGB beta_new = beta * bs->f * (std::abs(bs->wi.z) / bs->pdf * correction);
    if (!pass_through && arrive != kAllLobes) {  // the rule above, for the scattered photon
      if (!(bs->lobe & arrive)) break;
      if (!bs->delta) {
        const float pdf_v = bsdf.pdf(wo, bs->wi, arrive);
        if (!(pdf_v > 0)) break;
        beta_new = beta * bsdf.eval(wo, bs->wi, TransportMode::Importance, arrive) *
                   (std::abs(bs->wi.z) / pdf_v * correction);
      }
    }
    // ---- Russian roulette: keep the photon's power roughly constant ----
    const float m_old = beta.max_component(), m_new = beta_new.max_component();
    if (!(m_new > 0) || !(m_old > 0)) break;
    const float p_continue = std::min(1.0f, m_new / m_old);
    if (u.next() >= p_continue) break;
    if (origins) {
      last.p = hit->p;
      last.ng = hit->ng;
      last.frame = hit->frame;
      last.wo = wo;
      last.scale = beta / (bs->pdf * p_continue);
      last.pdf = bs->pdf;
      last.material = hit->material;
      last.uv = hit->uv;
      last.diffuse = diffuse;
    }
    if (chains) {
      if (diffuse) {  // the new reconnection vertex y_b
        chain->p = hit->p;
        chain->ng = hit->ng;
        chain->ns = hit->ns;
        chain->wo = wo_world;
        chain->material = hit->material;
        chain->uv = hit->uv;
        chain->light = -1;
        chain->dir = Vec3(0.0f);
        chain->count = 0;
        chain_ok = true;
      } else if (chain->count < kMaxChainVertices) {
        chain->v[chain->count++] = ChainVertex{hit->p, hit->ng, hit->mesh, hit->prim, bs->transmission};
      } else {
        chain_ok = false;
      }
    }
    beta = beta_new / p_continue;
    const RayState state = next_ray_state(ray.state, bs->lobe, bs->transmission, bs->delta, bs->eta);
    ray = Ray(offset_ray_origin(hit->p, hit->ng, wi_world), wi_world);
    ray.state = state;  // Light Path at the photon's next vertex (photons start as emission: no flags)
    crossed = 0;
    t_crossed = 0;
    if (!pass_through) {
      ++scattered;
      arrive = seen_by;
    }
  }
  return rays;
}

PhotonPassStats PhotonTracer::trace(int64_t count, uint64_t pass, int min_deposit_bounce,
                                    std::vector<Photon>& out, std::vector<PhotonOrigin>* origins,
                                    std::vector<PhotonChain>* chains, const std::function<bool()>& cancelled) {
  if (!origins) chains = nullptr;
  PhotonPassStats stats;
  stats.emitted = count;
  const LightSet& lights = scene_.light_set();
  const size_t n_chunks = static_cast<size_t>((count + kChunk - 1) / kChunk);
  if (chunks_.size() < n_chunks) chunks_.resize(n_chunks);
  if (origins && chunk_origins_.size() < n_chunks) chunk_origins_.resize(n_chunks);
  if (chains && chunk_chains_.size() < n_chunks) chunk_chains_.resize(n_chunks);
  std::atomic<int64_t> rays{0}, invalid{0};
  if (!lights.empty() && count > 0) {
    parallel_for(n_chunks, threads_, [&](size_t lo, size_t hi) {
      int64_t local_rays = 0, local_invalid = 0;
      for (size_t c = lo; c < hi; ++c) {
        std::vector<Photon>& dst = chunks_[c];
        dst.clear();
        std::vector<PhotonOrigin>* dst_origin = origins ? &chunk_origins_[c] : nullptr;
        if (dst_origin) dst_origin->clear();
        std::vector<PhotonChain>* dst_chain = chains ? &chunk_chains_[c] : nullptr;
        if (dst_chain) dst_chain->clear();
        if (cancelled && cancelled()) continue;  // abandoned pass: the rest stays empty
        Rng rng = Rng::for_key(seed_ ^ 0x70686f746f6e73ULL, c, pass);
        const int64_t begin = static_cast<int64_t>(c) * kChunk, end = std::min(count, begin + kChunk);
        RngSamples u(rng);
        for (int64_t k = begin; k < end; ++k)
          local_rays += trace_path(u, min_deposit_bounce, dst, local_invalid, nullptr, dst_origin, dst_chain);
      }
      rays += local_rays;
      invalid += local_invalid;
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
