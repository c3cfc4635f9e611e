// The one photon walk (photon_tracer.h), generic over what a photon carries, as
// paths/camera_path.h is for camera paths: an RGB power (RgbPhoton, photon_tracer.cpp: ppm,
// sppm, adaptive SPPM's primary samples, msppm's path records, gpm's origins and chains) or a
// power at the pass's sampled wavelengths (SpectralPhotonPower, progressive_photon_spectral.cpp).
// The walk owns what does not depend on the colour: the order of the primary samples, emission,
// tracing, the per-kind switches and light objects, the depth limit, where deposits happen,
// Russian roulette's rule (keep the largest channel roughly constant) and the records. The
// power type `P` owns the estimator at each step:
//
//   bool emit(const PhotonEmission& em);        // the power leaving the light; false: none
//   bool finite() const;                        // a deposit with NaN/Inf power is dropped
//   void deposit(const SurfaceHit& hit, const Vec3& wi, uint8_t lobes, bool world_share);
//   void scale(float s);                        // power *= s (a coin's inverse probability)
//   void prepare(const SurfaceHit& hit);        // the material(s) at the hit, before sampling
//   std::optional<BsdfSample> sample(const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo,
//                                    float uc, Vec2 u);   // the direction; nullopt: end
//   bool weigh(const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo, const BsdfSample& bs,
//              float uc, Vec2 u, float correction, uint8_t lobes);
//                                               // the scattered power (pending); lobes: the
//                                               // kinds it may light (kAllLobes: no restriction)
//   float max_old() const, max_new() const;     // largest channel before / after scattering
//   void commit(float p_continue);              // power = pending / p_continue
//   RGB origin_scale(float denom) const;        // power / denom as RGB (GPM's origins; RGB only)
//
// Participating media (issue 32, thesis §5.6), only in scenes that have them and for methods that
// render them (set_media):
// the walk keeps the photon's volume stack as the camera path does (a medium inside glass is
// entered through the glass), samples a free-flight distance on every segment in a medium with
// the same MediumSegment the path tracers use (paths/medium_walk.h, media/medium.h: whatever
// medium is behind it, homogeneous or a density grid), deposits a volume photon at every
// scattering point in a medium and scatters on by the phase function; a segment that reaches its
// surface takes the free flight's pass weight, so surface photons see the media's transmittance.
// Per channel of the power (RGB, or its wavelengths):
//
//   int channels() const;
//   const MediumChannels& medium_channels(int medium) const;
//   ChannelValues channel_weights() const;      // the power per channel (free-flight channel choice)
//   void medium_weight(const ChannelValues& w); // power *= w
//   void deposit_volume(const Vec3& p, const Vec3& wi);
//
// A volume photon's power is the power after the free flight's scattering weight sigma_s T / pdf:
// it carries sigma_s(x_p), so the beam radiance estimate (progressive_photon.cpp) does not
// multiply by it again. Volume photons are deposited from the light's first segment on whatever
// min_deposit_bounce says: the eye paths take no next-event estimation in media, so the photons
// carry the media's direct light too. A record (MSPPM) keeps each scattering point in a medium
// as a vertex marked `medium` (its weights, msppm_weights.cpp); origins and chains (GPM) know
// no media: that method declares that it does not render them.
#pragma once

#include <algorithm>
#include <atomic>
#include <functional>
#include <optional>

#include "core/parallel.h"
#include "core/rng.h"

#include "integrators/paths/medium_walk.h"
#include "integrators/photon/photon_tracer.h"

namespace gp {

template <class P>
int64_t PhotonTracer::walk(PrimarySamples& u, int min_deposit_bounce, P& power, int64_t& invalid,
                           PhotonPathRecord* record, std::vector<PhotonOrigin>* origins,
                           std::vector<PhotonChain>* chains) const {
  const LightSet& lights = scene_.light_set();
  if (lights.empty()) return 0;
  int64_t rays = 0;
  // ---- Emission ----
  const float us = u.next();
  const float up0 = u.next(), up1 = u.next(), ud0 = u.next(), ud1 = u.next();
  const auto em = lights.sample_le(us, Vec2(up0, up1), Vec2(ud0, ud1));
  if (!em || em->power.is_black()) return 0;
  if (!power.emit(*em)) return 0;
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
  // (Spectral photons keep the lights' rule: their deposit ignores world_share.)
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
  const bool media = media_on_;
  // It starts in the media around its light (a lamp inside a glass of murky water: LightMedia).
  MediumStack stack = media ? light_media_.of(em->light) : scene_.initial_medium_stack();
  // Light Paths > Volume bounces (Scene::volume_bounces, -1: none): Cycles' camera path has at
  // most volume_bounces + 1 scatterings in media, the last of them (the one nearest the light)
  // joined to the light with no surface between (paths/camera_path.h). In the photon's order:
  // its k-th scattering in a medium is allowed while k <= volume_bounces + 1, the last one only
  // if no surface scattered the photon before its first.
  int volume_scatters = 0;
  bool surface_first = false;
  for (int bounce = 0; bounce + 1 <= max_depth_; ++bounce) {
    ++rays;
    const auto hit = scene_.intersect(ray);
    // ---- Participating media along the segment: free flight (as paths/camera_path.h) ----
    if (media && !stack.empty()) {
      // (Grid media: delta tracking against the majorant grid, its weight carrying sigma_s(x).)
      MediumSegment segment(stack, ray, power.channels(),
                            [&](int m) -> const MediumChannels& { return power.medium_channels(m); });
      segment.set_channel_weights(power.channel_weights());
      const float u_channel = u.next(), u_distance = u.next();
      const float t_end = hit ? hit->t : kInfinity;
      const float t = segment.sample_distance(u_channel, u_distance, t_end);
      if (t < t_end) {
        // ---- Scattering in a medium: a volume photon, then the phase function ----
        if (const int vb = scene_.volume_bounces; vb >= 0) {
          ++volume_scatters;
          if (volume_scatters > vb + 1 || (volume_scatters == vb + 1 && surface_first)) break;
        }
        const float m_old = power.max_old();
        power.medium_weight(segment.scatter_weight(t));
        const Vec3 p = ray.at(t);
        if (record) {  // a medium vertex: MSPPM's weights see that the path scattered in a medium
          PhotonPathVertex v;
          v.p = p;
          v.wi = -ray.d;
          v.medium = true;
          record->vertices.push_back(v);
        }
        if (power.finite()) power.deposit_volume(p, -ray.d);
        else ++invalid;
        if (bounce + 2 > max_depth_) break;
        const float u_lobe = u.next();
        const float v0 = u.next(), v1 = u.next();
        const Vec3 wi = segment.sample_phase(ray.d, u_lobe, Vec2(v0, v1));
        const float cos_theta = dot(ray.d, wi);
        const float pdf = segment.phase_pdf(cos_theta);
        if (!(pdf > 0)) break;
        ChannelValues ratio = segment.phase(cos_theta);
        for (float& r : ratio) r /= pdf;
        power.medium_weight(ratio);
        // Russian roulette, as at surfaces: the largest channel kept roughly constant.
        const float m_new = power.max_old();
        if (!(m_new > 0) || !(m_old > 0)) break;
        const float p_continue = std::min(1.0f, m_new / m_old);
        if (u.next() >= p_continue) break;
        power.scale(1.0f / p_continue);
        const RayState state = ray.state.volume_next();
        ray = Ray(p, wi);  // a volume ray: every surface is there for it
        ray.state = state;
        crossed = 0;
        t_crossed = 0;
        chain_ok = false;
        ++scattered;
        arrive = kAllLobes;
        continue;
      }
      power.medium_weight(segment.pass_weight(t_end));
    }
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
      if (power.finite()) {
        power.deposit(*hit, -ray.d, arrive, world_rule && scattered == 0);
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
        power.scale(1.0f / q);
        if (media && mat.interior >= 0) stack.cross(hit->mesh, mat.interior, dot(ray.d, hit->ng) < 0);
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
      power.scale(1.0f / (1.0f - q));
    }
    // Nothing leaves a black surface, or one no kind of bounce ray sees.
    if (bsdf.is_black() || (seen_by == 0 && !pass_through)) break;
    if (bounce + 2 > max_depth_) break;
    // ---- Scattering (adjoint BSDF) ----
    const Vec3 wo_world = -ray.d;
    const Vec3 wo = hit->frame.to_local(wo_world);
    if (wo.z == 0) break;
    power.prepare(*hit);
    const float uc = u.next();
    const float u0 = u.next(), u1 = u.next();
    const std::optional<BsdfSample> bs = power.sample(*hit, bsdf, wo, uc, Vec2(u0, u1));
    if (!bs) break;
    pdf_dir_prev = bsdf.is_delta() ? 1.0f : bs->pdf;
    const Vec3 wi_world = hit->frame.to_world(bs->wi);
    const float correction = adjoint_shading_correction(wo_world, wi_world, hit->ng, hit->ns);
    if (correction == 0) break;
    // Only the lobes of the segment's kinds (the rule above, for the scattered photon).
    if (!power.weigh(*hit, bsdf, wo, *bs, uc, Vec2(u0, u1), correction, pass_through ? kAllLobes : arrive)) break;
    // ---- Russian roulette: keep the photon's power roughly constant ----
    const float m_old = power.max_old(), m_new = power.max_new();
    if (!(m_new > 0) || !(m_old > 0)) break;
    const float p_continue = std::min(1.0f, m_new / m_old);
    if (u.next() >= p_continue) break;
    if (origins) {
      last.p = hit->p;
      last.ng = hit->ng;
      last.frame = hit->frame;
      last.wo = wo;
      last.scale = power.origin_scale(bs->pdf * p_continue);
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
      } else if (!bs->delta && bsdf.is_stochastic()) {
        // A random-walk lobe (Multiscatter GGX): its directions hold no half-vector and its
        // density is unknown, so no manifold walk may move the chain through it (GPM §4.2
        // assumes single-scatter lobes): the photon is the primal's alone (gpm.cpp: counted
        // as a failed specular-chain shift), as gpt stops offsets at such a vertex.
        chain_ok = false;
      } else if (chain->count < kMaxChainVertices) {
        chain->v[chain->count++] = ChainVertex{hit->p, hit->ng, hit->mesh, hit->prim, bs->transmission};
      } else {
        chain_ok = false;
      }
    }
    power.commit(p_continue);
    // A light object or a volume boundary that casts no shadow, or a pass through a Transparent
    // BSDF that shadow rays pass (below) is no vertex of the path in a record either: next-event
    // estimation reaches the light through it (msppm_weights.cpp).
    if (record && ((pass_through && !mat.casts_shadow) || (is_transparent_pass(*bs) && mat.transparent_shadow())))
      record->vertices.back().crossed = true;
    // A sample through a surface with an interior medium (glass of murky water) crosses it.
    if (media && mat.interior >= 0 && (dot(wi_world, hit->ng) < 0) == (dot(ray.d, hit->ng) < 0))
      stack.cross(hit->mesh, mat.interior, dot(ray.d, hit->ng) < 0);
    const RayState state = next_ray_state(ray.state, bs->lobe, bs->transmission, bs->delta, bs->eta);
    ray = Ray(offset_ray_origin(hit->p, hit->ng, wi_world), wi_world);
    ray.state = state;  // Light Path at the photon's next vertex (photons start as emission: no flags)
    crossed = 0;
    t_crossed = 0;
    // A pass through a Transparent BSDF is not a scattering either where shadow rays pass it
    // (paths/medium_walk.h): a photon that only passed such surfaces is direct light too.
    if (!pass_through && !(is_transparent_pass(*bs) && mat.transparent_shadow())) {
      ++scattered;
      arrive = seen_by;
      surface_first = surface_first || volume_scatters == 0;
    }
  }
  return rays;
}

// Runs a photon pass's chunks (PhotonTracer::kChunk photons each) on `threads` workers: for
// chunk c, begin(c) prepares its output, then photon(c, u, rays, invalid) traces each of its
// photons from the chunk's own random stream, keyed by (stream, c, pass), so the photons do not
// depend on the thread count. `cancelled` is polled before every chunk (an abandoned pass
// leaves the rest empty).
template <class Begin, class Trace>
void for_photon_chunks(int64_t count, uint64_t stream, uint64_t pass, int threads,
                       const std::function<bool()>& cancelled, std::atomic<int64_t>& rays,
                       std::atomic<int64_t>& invalid, Begin&& begin, Trace&& photon) {
  const int64_t kChunk = PhotonTracer::kChunk;
  const size_t n_chunks = static_cast<size_t>((count + kChunk - 1) / kChunk);
  parallel_for(n_chunks, threads, [&](size_t lo, size_t hi) {
    int64_t local_rays = 0, local_invalid = 0;
    for (size_t c = lo; c < hi; ++c) {
      begin(c);
      if (cancelled && cancelled()) continue;  // abandoned pass: the rest stays empty
      Rng rng = Rng::for_key(stream, c, pass);
      const int64_t first = static_cast<int64_t>(c) * kChunk, end = std::min(count, first + kChunk);
      RngSamples u(rng);
      for (int64_t k = first; k < end; ++k) local_rays += photon(c, u, local_invalid);
    }
    rays += local_rays;
    invalid += local_invalid;
  });
}

}  // namespace gp
