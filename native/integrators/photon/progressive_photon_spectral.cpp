// Spectral photons for SPPM (sppm.h "Spectral photons", docs/spectral.md): one set of sampled
// wavelengths per pass (hero + C - 1 rotations), shared by the pass's eye paths and photons;
// eye throughput and photon power are values at those wavelengths, the BSDFs are evaluated per
// wavelength on monochromatic() parameters (Cauchy IOR, grey colour from the upsampled
// spectrum, textures looked up per point) as in spectral_pt.cpp, and each pixel's gathered flux is converted to RGB before it
// enters the RGB statistics (eq. 7.4-7.5 unchanged).
//
// Every direction is sampled with the hero wavelength and every wavelength divides by the hero's
// pdf (unbiased per wavelength wherever the hero's pdf covers its BSDF). A smooth dispersive
// refraction sends no other wavelength the same way: the path keeps only the hero, weighted by C
// (the balance heuristic over the C wavelengths' path pdfs, which are 0 for all but the hero, as
// spt-hero). A full path (eye path + photon) is hero-only when either half is, and gets the
// factor C once: the eye half carries it in its throughput, the photon half in a flag.
#include <atomic>
#include <cmath>
#include <optional>

#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/lobe_split.h"
#include "integrators/photon/progressive_photon.h"
#include "materials/bsdf.h"

namespace gp {

namespace {

// Per-wavelength factor f_k |cos| / pdf_hero of a hero-sampled BSDF direction at `hit` (each
// wavelength's BSDF with the hit's normals, as Scene::bsdf). Returns false when every wavelength
// is dead; sets hero_only on a smooth dispersive refraction.
bool scatter_factors(const Scene& scene, const SurfaceHit& hit, const BsdfParams* mk, int C, const Vec3& wo,
                     const BsdfSample& bs, float uc, Vec2 u, TransportMode mode, SpectralValues& factor,
                     bool& hero_only) {
  const Material& base = scene.material(hit.material);
  const bool dispersive = is_dispersive(base);
  const float cos_pdf = std::abs(bs.wi.z) / bs.pdf;
  factor[0] = bs.f[0] * cos_pdf;
  bool refracted = false;
  for (int k = 1; k < C; ++k) {
    const Bsdf b = scene.bsdf(mk[k], hit);
    float f = 0;
    if (!dispersive || !bs.delta) {
      if (bs.delta) {  // same lobe and direction for every wavelength; only the colour differs
        const auto sk = b.sample(wo, uc, u, mode);
        f = sk ? sk->f[0] : 0.0f;
      } else {
        f = b.eval(wo, bs.wi, mode)[0];
      }
    } else if (!bs.transmission) {  // smooth dispersive reflection: the same mirror direction
      f = mk[k].color.r * fresnel_dielectric(cos_theta(wo), mk[k].ior) / std::abs(bs.wi.z);
    } else {  // smooth dispersive refraction: no other wavelength goes this way
      f = 0;
      refracted = true;
    }
    factor[k] = f * cos_pdf;
  }
  if (refracted) {
    if (!hero_only) factor[0] *= static_cast<float>(C);  // pdfs (hero, 0, ..., 0): balance heuristic
    hero_only = true;
    for (int k = 1; k < C; ++k) factor[k] = 0;
  }
  bool alive = false;
  for (int k = 0; k < C; ++k) alive |= factor[k] > 0 && std::isfinite(factor[k]);
  return alive;
}

}  // namespace

SampledWavelengths ProgressivePhotonMapping::pass_wavelengths(uint64_t pass) const {
  // The hero of pass j: van der Corput point j (base 2) shifted by one random offset per render
  // (Cranley-Patterson rotation). Each pass's hero stays uniform, but the passes stratify the
  // spectrum: a dispersive caustic, which is the hero's alone, gets its colour right in far
  // fewer passes than with independent heroes.
  uint32_t bits = static_cast<uint32_t>(pass);
  bits = (bits << 16) | (bits >> 16);
  bits = ((bits & 0x00ff00ffu) << 8) | ((bits & 0xff00ff00u) >> 8);
  bits = ((bits & 0x0f0f0f0fu) << 4) | ((bits & 0xf0f0f0f0u) >> 4);
  bits = ((bits & 0x33333333u) << 2) | ((bits & 0xccccccccu) >> 2);
  bits = ((bits & 0x55555555u) << 1) | ((bits & 0xaaaaaaaau) >> 1);
  Rng rng = Rng::for_key(seed_ ^ 0x7370656374726cULL, 0, 0x776cULL);
  double u = bits * 0x1p-32 + rng.uniform();
  u -= std::floor(u);
  return SampledWavelengths::sample_uniform(std::min(static_cast<float>(u), 0x1.fffffep-1f), wl_.count);
}

// The eye path at the pass's wavelengths (trace_eye's colour): the hero drives every sampling
// decision, the others follow with their factors (scatter_factors); `hero_only` once a smooth
// dispersive refraction leaves the hero alone.
struct SpectralEye {
  const SpectraAtWavelengths& spectra;
  const int C;
  SpectralValues beta{}, Ld{};
  bool hero_only = false;
  WavelengthParams local;
  const BsdfParams* mk = nullptr;
  SpectralEye(const SpectraAtWavelengths& s, int count) : spectra(s), C(count) {
    for (int k = 0; k < C; ++k) beta[k] = 1.0f;
  }
  void add_light(const float* spec, float grey) {
    for (int k = 0; k < C; ++k) Ld[k] += beta[k] * grey * spec[k];
  }
  void environment(const RGB& Le, int env) {
    float spec[kMaxWavelengths];  // this direction's colour, for an image (light_spectrum)
    spectra.emitted(env, Le, spec);
    add_light(spec, 1.0f);
  }
  void area_light(const RGB& Le, int l, const LightSet& lights) {
    add_light(spectra.light(l), grey_factor(Le, lights.lights()[l].emit));
  }
  RGB vp_beta() const { return RGB(1.0f); }  // unused: the spectral throughput is vp_beta_
};

RGB ProgressivePhotonMapping::eye_nee(SpectralEye& c, const SurfaceHit& hit, const Bsdf&, const Vec3& wo,
                                      float u_light, const Vec2& u2, int64_t& rays) const {
  const LightSet& lights = scene_.light_set();
  if (auto ls = lights.sample_li(hit.p, u_light, u2); ls && ls->pdf > 0 && !ls->L.is_black()) {
    const Vec3 wi = hit.frame.to_local(ls->wi);
    // Only the lobes that see the light; the World by its own rule (direct_light).
    const Light* light = ls->light >= 0 ? &lights.lights()[ls->light] : nullptr;
    SpectralValues f{};
    bool any = false;
    for (int k = 0; k < c.C; ++k) {
      f[k] = nee_only_f(scene_.bsdf(c.mk[k], hit), wo, wi, light)[0] * std::abs(wi.z);
      any |= f[k] > 0;
    }
    if (any) {
      ++rays;
      const bool blocked = scene_.occluded(hit.p, hit.ng, *ls);
      if (!blocked) {
        float spec[kMaxWavelengths];
        pass_spectra_.emitted(ls->light, ls->L, spec);
        for (int k = 0; k < c.C; ++k) c.Ld[k] += c.beta[k] * f[k] * spec[k] / ls->pdf;
      }
    }
  }
  return RGB(0.0f);  // no hooks watch the spectral eye path
}

std::optional<BsdfSample> ProgressivePhotonMapping::eye_scatter(SpectralEye& c, const SurfaceHit& hit, const Bsdf&,
                                                                const Vec3& wo, float uc, Vec2 u) const {
  const auto bs = scene_.bsdf(c.mk[0], hit).sample(wo, uc, u);
  if (!bs || bs->pdf <= 0) return std::nullopt;
  SpectralValues factor{};
  if (!scatter_factors(scene_, hit, c.mk, c.C, wo, *bs, uc, u, TransportMode::Radiance, factor, c.hero_only))
    return std::nullopt;
  for (int k = 0; k < c.C; ++k) c.beta[k] *= factor[k];
  return bs;
}

void ProgressivePhotonMapping::eye_prepare(SpectralEye& c, const SurfaceHit& hit) const {
  c.mk = pass_spectra_.material(hit, c.local);
}

bool ProgressivePhotonMapping::eye_survive(SpectralEye& c, float u, float*) const {
  float bmax = 0;
  for (int k = 0; k < c.C; ++k) bmax = std::max(bmax, c.beta[k]);
  const float q = std::max(0.05f, 1.0f - bmax);
  if (u < q) return false;
  for (int k = 0; k < c.C; ++k) c.beta[k] /= 1.0f - q;
  return true;
}

void ProgressivePhotonMapping::spectral_eye_pass(uint64_t pass, ProgressSink* sink, std::atomic<int64_t>& rays_out,
                                                 std::atomic<int64_t>& invalid_out) {
  const int C = wl_.count;
  parallel_for_tiles(
      width_, height_, tile_size_, threads_,
      [&](const Tile& tile) {
        int64_t rays = 0, invalid = 0;
        // The tile's camera rays are traced together (as in eye_pass).
        std::vector<PixelStart> starts = tile_pixel_starts(scene_.camera, seed_, pass, tile);
        CameraRays first(scene_, starts.data(), starts.size());
        const std::vector<Ray>& camera = first.rays;
        std::vector<std::optional<SurfaceHit>>& hits = first.hits;
        const Vec2 ext = scene_.camera.half_extent();
        size_t i = 0;
        EyePathHooks none;
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x, ++i) {
            const size_t pixel = static_cast<size_t>(y) * width_ + x;
            SpectralEye eye(pass_spectra_, C);
            const EyeEnd end = trace_eye(camera[i], starts[i].rng, rays, eye, none, &hits[i], false);
            const SpectralValues& Ld = eye.Ld;
            const SpectralValues& beta = eye.beta;
            const bool hero_only = eye.hero_only, escaped = end.escaped;
            const float path_length = end.path_length;
            VisiblePoint vp = end.vp;
            RGB Lrgb = spectral_to_rgb(Ld);
            if (!Lrgb.is_finite()) {
              ++invalid;
              Lrgb = RGB(0.0f);
            }
            bool beta_ok = true;
            for (int k = 0; k < C; ++k) beta_ok &= std::isfinite(beta[k]);
            if (vp.material >= 0 && !beta_ok) {
              ++invalid;
              vp.material = -1;
            }
            pass_direct_[pixel] = Lrgb;
            pass_covered_[pixel] = escaped ? 0 : 1;
            vp_[pixel] = vp;
            vp_beta_[pixel] = beta;
            vp_hero_[pixel] = hero_only ? 1 : 0;
            first_r_[pixel] = vp.material >= 0 ? footprint_radius(path_length, ext) : 0.0f;
          }
        rays_out += rays;
        invalid_out += invalid;
      },
      [sink] { return sink && sink->cancelled(); });
}

PhotonPassStats ProgressivePhotonMapping::spectral_trace(uint64_t pass, const std::function<bool()>& cancelled) {
  PhotonPassStats stats;
  const int64_t count = photons_for_pass(pass);
  stats.emitted = count;
  const LightSet& lights = scene_.light_set();
  const int C = wl_.count;
  const int min_deposit_bounce = nee_ ? 1 : 0;
  const int64_t kChunk = PhotonTracer::kChunk;
  const size_t n_chunks = static_cast<size_t>((count + kChunk - 1) / kChunk);
  if (spectral_chunks_.size() < n_chunks) spectral_chunks_.resize(n_chunks);
  std::atomic<int64_t> rays_total{0}, invalid_total{0};
  if (!lights.empty() && count > 0) {
    parallel_for(n_chunks, threads_, [&](size_t lo, size_t hi) {
      int64_t rays = 0, invalid = 0;
      for (size_t c = lo; c < hi; ++c) {
        std::vector<SpectralPhoton>& dst = spectral_chunks_[c];
        dst.clear();
        if (cancelled && cancelled()) continue;  // abandoned pass (PhotonTracer::trace)
        Rng rng = Rng::for_key(seed_ ^ 0x73706870686fULL, c, pass);
        const int64_t begin = static_cast<int64_t>(c) * kChunk, end = std::min(count, begin + kChunk);
        for (int64_t n = begin; n < end; ++n) {
          const float us = rng.uniform();
          const float up0 = rng.uniform(), up1 = rng.uniform(), ud0 = rng.uniform(), ud1 = rng.uniform();
          const auto em = lights.sample_le(us, Vec2(up0, up1), Vec2(ud0, ud1));
          if (!em || em->power.is_black()) continue;
          SpectralValues beta{};
          float spec[kMaxWavelengths];  // the photon's power as a spectrum (light_spectrum)
          pass_spectra_.emitted(em->light, em->power, spec);
          for (int k = 0; k < C; ++k) beta[k] = spec[k];
          bool hero_only = false;
          Ray ray = em->n.x != 0 || em->n.y != 0 || em->n.z != 0
                        ? Ray(offset_ray_origin(em->o, em->n, em->d), em->d)
                        : Ray(em->o, em->d);
          // Per-kind switches and light objects as PhotonTracer::trace_path (photon_tracer.cpp):
          // `arrive` the kinds the segment may be, a surface hidden from some of them crossed
          // or scattered at by a coin, light objects not counted as scattering.
          uint8_t arrive = lights.lights()[em->light].visible_lobes;
          int scattered = 0, crossed = 0;
          for (int bounce = 0; bounce + 1 <= max_depth_; ++bounce) {
            ++rays;
            const auto hit = scene_.intersect(ray);
            if (!hit) break;
            const Material& base = scene_.material(hit->material);
            const Bsdf bsdf = scene_.bsdf(*hit);
            const uint8_t seen_by = base.visible_lobes & kAllLobes;
            const uint8_t hidden = base.is_pass_through() ? 0 : arrive & ~seen_by;
            if (bsdf.is_black() && !hidden) break;
            if (scattered >= min_deposit_bounce && !bsdf.is_black() && bsdf.is_diffuse_for_photons(threshold_)) {
              bool ok = true;
              for (int k = 0; k < C; ++k) ok &= std::isfinite(beta[k]);
              if (ok) dst.push_back(SpectralPhoton{Photon{hit->p, -ray.d, RGB(1.0f), 0, arrive}, beta, hero_only});
              else ++invalid;
            }
            if (hidden && crossed < PhotonTracer::kMaxCrossed) {
              const float q = crossing_probability(seen_by, bsdf.is_black(), bounce + 2 > max_depth_);
              const float w = q == 1.0f || rng.uniform() < q ? 1.0f / q : -1.0f / (1.0f - q);
              for (int k = 0; k < C; ++k) beta[k] *= std::abs(w);
              if (w > 0) {  // cross it
                arrive = hidden;
                ++crossed;
                ray = Ray(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
                --bounce;
                continue;
              }
            }
            if (bsdf.is_black() || (seen_by == 0 && !base.is_pass_through())) break;
            if (bounce + 2 > max_depth_) break;
            const Vec3 wo_world = -ray.d;
            const Vec3 wo = hit->frame.to_local(wo_world);
            if (wo.z == 0) break;
            WavelengthParams local;
            const BsdfParams* mk = pass_spectra_.material(*hit, local);
            const float uc = rng.uniform();
            const Vec2 u(rng.uniform(), rng.uniform());
            const Bsdf hero = scene_.bsdf(mk[0], *hit);  // with the hit's normals, as Scene::bsdf(hit)
            const auto bs = hero.sample(wo, uc, u, TransportMode::Importance);
            if (!bs || bs->pdf <= 0) break;
            const Vec3 wi_world = hit->frame.to_world(bs->wi);
            const float correction = adjoint_shading_correction(wo_world, wi_world, hit->ng, hit->ns);
            if (correction == 0) break;
            // The photon's own C factor is applied at the gather (once per full path), so the
            // hero-only factor from scatter_factors is undone here.
            const bool was_hero_only = hero_only;
            SpectralValues factor{};
            if (!scatter_factors(scene_, *hit, mk, C, wo, *bs, uc, u, TransportMode::Importance, factor, hero_only))
              break;
            if (hero_only && !was_hero_only) factor[0] /= static_cast<float>(C);
            if (!base.is_pass_through() && arrive != kAllLobes) {  // only the lobes of the segment's kinds
              if (!(bs->lobe & arrive)) break;
              if (!bs->delta) {  // f_V / p_V per wavelength, p_V the hero's restricted density
                const float pdf_v = hero.pdf(wo, bs->wi, arrive);
                if (!(pdf_v > 0)) break;
                for (int k = 0; k < C; ++k)
                  factor[k] = scene_.bsdf(mk[k], *hit).eval(wo, bs->wi, TransportMode::Importance, arrive)[0] * std::abs(bs->wi.z) / pdf_v;
              }
            }
            float m_old = 0, m_new = 0;
            SpectralValues beta_new{};
            for (int k = 0; k < C; ++k) {
              beta_new[k] = beta[k] * factor[k] * correction;
              m_old = std::max(m_old, beta[k]);
              m_new = std::max(m_new, beta_new[k]);
            }
            if (!(m_new > 0) || !(m_old > 0)) break;
            const float p_continue = std::min(1.0f, m_new / m_old);
            if (rng.uniform() >= p_continue) break;
            for (int k = 0; k < C; ++k) beta[k] = beta_new[k] / p_continue;
            ray = Ray(offset_ray_origin(hit->p, hit->ng, wi_world), wi_world);
            crossed = 0;
            if (!base.is_pass_through()) {
              ++scattered;
              arrive = seen_by;
            }
          }
        }
      }
      rays_total += rays;
      invalid_total += invalid;
    });
  }
  // ---- Concatenate in chunk order (independent of the thread count) ----
  std::vector<size_t> offset(n_chunks + 1, 0);
  for (size_t c = 0; c < n_chunks; ++c) offset[c + 1] = offset[c] + spectral_chunks_[c].size();
  const size_t total = offset[n_chunks];
  photons_.resize(total);
  photon_power_.resize(total);
  photon_hero_.resize(total);
  parallel_for(n_chunks, threads_, [&](size_t lo, size_t hi) {
    for (size_t c = lo; c < hi; ++c)
      for (size_t k = offset[c]; k < offset[c + 1]; ++k) {
        const SpectralPhoton& sp = spectral_chunks_[c][k - offset[c]];
        photons_[k] = sp.photon;
        photons_[k].index = static_cast<uint32_t>(k);
        photon_power_[k] = sp.power;
        photon_hero_[k] = sp.hero_only ? 1 : 0;
      }
  });
  for (size_t c = 0; c < n_chunks; ++c) spectral_chunks_[c].clear();
  stats.stored = static_cast<int64_t>(total);
  stats.rays = rays_total;
  stats.invalid = invalid_total;
  return stats;
}

void ProgressivePhotonMapping::spectral_gather(const std::function<bool()>& cancelled) {
  const size_t n_pixels = px_.size();
  const int C = wl_.count;
  const bool have_photons = !photons_.empty();
  parallel_for(n_pixels, threads_, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i) {
      if (i % kCancelPollPixels == 0 && cancelled()) return;  // abandoned pass (iterate checks)
      gather_m_[i] = 0;
      gather_lap_[i] = 0;
      gather_phi_[i] = RGB(0.0f);
      const VisiblePoint& vp = vp_[i];
      if (!have_photons || vp.material < 0 || !(px_[i].r2 > 0)) continue;
      WavelengthParams local;
      const BsdfParams* mk = pass_spectra_.material(vp.material, vp.uv, local);
      // The point's BSDFs, with the normals a normal or bump map needs (as Scene::bsdf).
      std::array<std::optional<Bsdf>, kMaxWavelengths> bk;
      for (int k = 0; k < C; ++k) bk[k] = scene_.bsdf(mk[k], vp.material, vp.uv, vp.frame, vp.ng, vp.n_smooth);
      const SpectralValues& beta = vp_beta_[i];
      const bool eye_hero = vp_hero_[i] != 0;
      const float R = static_cast<float>(std::sqrt(px_[i].r2));
      double m = 0, lap = 0;
      RGB phi(0.0f);
      grid_.query(vp.p, R, [&](const Photon& ph, float d2, float weight) {
        const Vec3 wi = vp.frame.to_local(ph.wi);
        if (!same_hemisphere(vp.wo, wi)) return;
        m += weight;
        const SpectralValues& power = photon_power_[ph.index];
        SpectralValues c{};
        const float w = weight * gather_shading_correction(ph.wi, vp.n_smooth, vp.frame.n);  // as the RGB gather
        for (int k = 0; k < C; ++k)
          c[k] = beta[k] * bk[k]->eval(vp.wo, wi, TransportMode::Radiance, ph.lobes)[0] * power[k] * w;
        if (photon_hero_[ph.index] && !eye_hero) c[0] *= static_cast<float>(C);  // C once per full path
        const RGB contrib = spectral_to_rgb(c);  // eq. 7.4 at this pass's wavelengths, as RGB
        phi += contrib;
        lap += contrib.luminance() * error_kernel::laplacian(d2, R);
      });
      gather_m_[i] = static_cast<float>(m);
      gather_lap_[i] = static_cast<float>(lap);
      gather_phi_[i] = phi;
    }
  });
}

}  // namespace gp
