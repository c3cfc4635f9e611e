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
#include "core/sobol.h"
#include "integrators/lobe_split.h"
#include "integrators/photon/photon_walk.h"
#include "integrators/photon/progressive_photon.h"
#include "materials/bsdf.h"
#include "integrators/photon/photon_estimate.h"

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
      } else if (bs.stochastic) {  // a random walk: the same walk's weight at this wavelength
        const auto sk = b.sample(wo, uc, u, mode);
        f = sk && sk->wi.x == bs.wi.x && sk->wi.y == bs.wi.y && sk->wi.z == bs.wi.z ? sk->f[0] * (bs.pdf / sk->pdf)
                                                                                    : 0.0f;
      } else {
        f = b.eval(wo, bs.wi, mode)[0];
      }
    } else if (!bs.transmission) {  // smooth dispersive reflection: the same mirror direction
      f = dielectric_reflection_color(mk[k], cos_theta(wo)).r * fresnel_dielectric(cos_theta(wo), mk[k].ior) /
          std::abs(bs.wi.z);
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
  // The wavelengths of pass j, from its hero u: sample_uniform places the other C - 1 at
  // u + k/C, so the set is fixed by u modulo 1/C (the comb's offset) and u picks the set's
  // member floor(C u) as the hero, which alone carries light past a smooth dispersive
  // refraction. Shifted by one random offset per render (Cranley-Patterson rotation; each
  // pass's hero stays uniform), the passes stratify:
  //  - with dispersion, the heroes: van der Corput point j (base 2). The first 2^k passes'
  //    heroes are evenly spaced, which a spectrum seen only by heroes (a dispersive caustic,
  //    anything behind dispersive water) needs: pool.json at 16 passes, the means' spread over
  //    seeds is 0.06 (R) so, 0.32 with the heroes of the next rule. But points that differ by a
  //    multiple of 1/C give one set, and the first C points (0, 1/2, 1/4, 3/4 for C = 4) do:
  //    all other light sees only 2^k wavelengths in 2^k passes, not C 2^k;
  //  - without dispersion (no path is hero-only), the sets: the offset is van der Corput point
  //    j / C, so the first 2^k passes' sets interleave into C 2^k evenly spaced wavelengths
  //    (red.json, the heroes above: red 0.13 for spt's 0.34 after 4 passes, every pixel seeing
  //    the same 4 wavelengths; panes.json a negative red mean), and the member Sobol dimension
  //    1's point j (a (0,2)-net with dimension 0: one hero in each 1/2^k of the spectrum), so
  //    that the wavelength that samples the directions covers the whole spectrum.
  //  docs/spectral.md "Stratified wavelengths across passes" has the measurements.
  const int C = wl_.count;
  const uint32_t x = reverse_bits(static_cast<uint32_t>(pass));  // Sobol dimension 0 (van der Corput)
  double hero = x * 0x1p-32;
  if (!dispersive_) {
    const uint32_t y = reverse_bits(sobol_reversed(x, 1));  // Sobol dimension 1
    hero = (std::floor(y * 0x1p-32 * C) + hero) / C;
  }
  Rng rng = Rng::for_key(seed_ ^ 0x7370656374726cULL, 0, 0x776cULL);
  double u = hero + rng.uniform();
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
  // ---- Participating media (trace_eye), at the pass's wavelengths ----
  const std::vector<MediumChannels>* media = nullptr;
  int channels() const { return C; }
  const MediumChannels& medium_channels(int m) const { return (*media)[m]; }
  ChannelValues channel_weights() const { return beta_channels(beta, C); }
  void medium_weight(const ChannelValues& w) {
    scale_by_channels(beta, w, C);
    alpha.scale(w, C);
  }
  // Film > Transparent: the RGB weight of the camera's transparent passes (paths/medium_walk.h).
  RgbTransparency alpha;
  const RgbTransparency& rgb_transparency() const { return alpha; }  // path_transparency
  // A pass through a photon-diffuse surface's Transparent BSDF (trace_eye): t per wavelength, rgb
  // the same weight from the closure's RGB colour.
  void transparent_weight(const ChannelValues& t, const RGB& rgb) {
    scale_by_channels(beta, t, C);
    alpha.pass(rgb);
  }
  void medium_emission(const ChannelValues& e) {
    for (int k = 0; k < C; ++k) Ld[k] += beta[k] * e[k];
  }
  bool is_hero_only() const { return hero_only; }
};

RGB ProgressivePhotonMapping::eye_nee(SpectralEye& c, const SurfaceHit& hit, const Bsdf&, const Vec3& wo,
                                      float u_light, const Vec2& u2, int64_t& rays, const ShadowTest* shadow) const {
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
      // With media: through volume boundaries, with their transmittance; transparent surfaces
      // filter it at the pass's wavelengths (paths/medium_walk.h).
      const ShadowTest plain(scene_, nullptr);
      const ChannelValues T = (shadow ? *shadow : plain).transmittance(
          hit.p, &hit.ng, *ls,
          {.count = c.C, .lambda = wl_.lambda.data(), .media = pass_media_.empty() ? nullptr : pass_media_.data(),
           .state = hit.ray});
      if (!is_blocked(T, c.C)) {
        float spec[kMaxWavelengths];
        pass_spectra_.emitted(ls->light, ls->L, spec);
        for (int k = 0; k < c.C; ++k) spec[k] *= T[k];
        for (int k = 0; k < c.C; ++k) c.Ld[k] += c.beta[k] * f[k] * spec[k] / ls->pdf;
      }
    }
  }
  return RGB(0.0f);  // no hooks watch the spectral eye path
}

std::optional<BsdfSample> ProgressivePhotonMapping::eye_scatter(SpectralEye& c, const SurfaceHit& hit, const Bsdf& rgb,
                                                                const Vec3& wo, float uc, Vec2 u) const {
  const auto bs = scene_.bsdf(c.mk[0], hit).sample(wo, uc, u);
  if (!bs || bs->pdf <= 0) return std::nullopt;
  c.alpha.scatter(&rgb, wo, uc, u, *bs);  // eye_bsdf's RGB BSDF of the same hit
  SpectralValues factor{};
  if (!scatter_factors(scene_, hit, c.mk, c.C, wo, *bs, uc, u, TransportMode::Radiance, factor, c.hero_only))
    return std::nullopt;
  for (int k = 0; k < c.C; ++k) c.beta[k] *= factor[k];
  return bs;
}

ChannelValues ProgressivePhotonMapping::eye_transparency(SpectralEye& c, const SurfaceHit& hit, const Bsdf&) const {
  ChannelValues t{};
  for (int k = 0; k < c.C; ++k) t[k] = scene_.bsdf(c.mk[k], hit).transparency()[0];
  return t;
}

Bsdf ProgressivePhotonMapping::eye_bsdf(SpectralEye& c, const SurfaceHit& hit) const {
  const Material& m = scene_.material(hit.material);
  if (!m.graph || !pass_spectra_.per_point(hit.material)) {
    c.mk = pass_spectra_.material(hit, c.local);  // shared per pass, or legacy textures at uv
    return scene_.bsdf(hit);
  }
  // One run of the node graph for both (it ran twice: Scene::bsdf, then the wavelengths'): the
  // RGB BSDF is Scene::bsdf(hit)'s, made from the same parameters at the same shading context.
  const shading::ShadingContext ctx = scene_.shading_context(hit);
  BsdfParams rgb;
  c.mk = pass_spectra_.material(hit.material, ctx, c.local, &rgb);
  Bsdf b(rgb, ctx);
  if (m.perturbs_normal()) b.set_surface_normals(hit.frame.to_local(hit.ng), hit.frame.to_local(hit.n_smooth));
  return b;
}

bool ProgressivePhotonMapping::eye_survive(SpectralEye& c, float u, float*) const {
  float bmax = 0;
  for (int k = 0; k < c.C; ++k) bmax = std::max(bmax, c.beta[k]);
  const float q = std::max(0.05f, 1.0f - bmax);
  if (u < q) return false;
  for (int k = 0; k < c.C; ++k) c.beta[k] /= 1.0f - q;
  c.alpha.scale(1.0f / (1.0f - q));
  return true;
}

bool ProgressivePhotonMapping::spectral_eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause,
                                                 std::atomic<int64_t>& rays_out, std::atomic<int64_t>& invalid_out) {
  const int C = wl_.count;
  return eye_tiles(
      sink, may_pause,
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
            eye.media = &pass_media_;
            const EyeEnd end = trace_eye(camera[i], starts[i].rng, rays, eye, none, &hits[i], false);
            store_beams(pixel, end, ext);
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
            // As the RGB eye pass: 1 - an escaped path's transparency, times 1 - a mixed Holdout's weight.
            pass_covered_[pixel] = (escaped ? 1.0f - end.transparent : 1.0f) * first.coverage[i];
            vp_[pixel] = vp;
            vp_beta_[pixel] = beta;
            vp_hero_[pixel] = hero_only ? 1 : 0;
            first_r_[pixel] = vp.material >= 0 ? footprint_radius(path_length, ext) : 0.0f;
          }
        rays_out += rays;
        invalid_out += invalid;
      });
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
  if (media_ && spectral_volume_chunks_.size() < n_chunks) spectral_volume_chunks_.resize(n_chunks);

  // The photon at the pass's wavelengths (photon_walk.h's power type): the hero samples every
  // direction, the others follow with their factors (scatter_factors), as the eye path.
  struct SpectralPhotonPower {
    const Scene& scene;
    const SpectraAtWavelengths& spectra;
    const int C;
    std::vector<SpectralPhoton>& dst;
    std::vector<SpectralPhoton>* volume;        // volume photons (media)
    const std::vector<MediumChannels>& media;  // the scene's media at the pass's wavelengths
    SpectralValues beta{}, pending{};
    bool hero_only = false;
    WavelengthParams local;
    const BsdfParams* mk = nullptr;
    std::optional<Bsdf> hero;  // the hero's BSDF at the last hit
    // The spectral tracer's direction numbers in the order it has always used them: it drew
    // them as Vec2(rng.uniform(), rng.uniform()), whose arguments GCC evaluates right to left,
    // so its first number went to y. Kept, so that images stay bit for bit (issue 35's check);
    // either order samples the same distribution.
    static Vec2 drawn(Vec2 u) { return Vec2(u.y, u.x); }

    bool emit(const PhotonEmission& em) {
      float spec[kMaxWavelengths];  // the photon's power as a spectrum (light_spectrum)
      spectra.emitted(em.light, em.power, spec);
      for (int k = 0; k < C; ++k) beta[k] = spec[k];
      return true;
    }
    bool finite() const {
      bool ok = true;
      for (int k = 0; k < C; ++k) ok &= std::isfinite(beta[k]);
      return ok;
    }
    void deposit(const SurfaceHit& hit, const Vec3& wi, uint8_t lobes, bool /*world_share: lights' rule*/) {
      dst.push_back(SpectralPhoton{Photon{hit.p, wi, RGB(1.0f), 0, lobes}, beta, hero_only});
    }
    void scale(float s) {
      for (int k = 0; k < C; ++k) beta[k] *= s;
    }
    void prepare(const SurfaceHit& hit) { mk = spectra.material(hit.material, hit.uv, local); }
    std::optional<BsdfSample> sample(const SurfaceHit& hit, const Bsdf&, const Vec3& wo, float uc, Vec2 u) {
      u = drawn(u);
      hero.emplace(scene.bsdf(mk[0], hit));  // with the hit's normals, as Scene::bsdf(hit)
      auto bs = hero->sample(wo, uc, u, TransportMode::Importance);
      if (!bs || bs->pdf <= 0) return std::nullopt;
      return bs;
    }
    bool weigh(const SurfaceHit& hit, const Bsdf&, const Vec3& wo, const BsdfSample& bs, float uc, Vec2 u,
               float correction, uint8_t lobes) {
      u = drawn(u);
      // The photon's own C factor is applied at the gather (once per full path), so the
      // hero-only factor from scatter_factors is undone here.
      const bool was_hero_only = hero_only;
      SpectralValues factor{};
      if (!scatter_factors(scene, hit, mk, C, wo, bs, uc, u, TransportMode::Importance, factor, hero_only))
        return false;
      if (hero_only && !was_hero_only) factor[0] /= static_cast<float>(C);
      if (lobes != kAllLobes) {  // only the lobes of the segment's kinds
        if (!(bs.lobe & lobes)) return false;
        if (!bs.delta) {  // f_V / p_V per wavelength, p_V the hero's restricted density
          const float pdf_v = hero->pdf(wo, bs.wi, lobes);
          if (!(pdf_v > 0)) return false;
          for (int k = 0; k < C; ++k)
            factor[k] = scene.bsdf(mk[k], hit).eval(wo, bs.wi, TransportMode::Importance, lobes)[0] *
                        std::abs(bs.wi.z) / pdf_v;
        }
      }
      for (int k = 0; k < C; ++k) pending[k] = beta[k] * factor[k] * correction;
      return true;
    }
    float max_old() const {
      float m = 0;
      for (int k = 0; k < C; ++k) m = std::max(m, beta[k]);
      return m;
    }
    float max_new() const {
      float m = 0;
      for (int k = 0; k < C; ++k) m = std::max(m, pending[k]);
      return m;
    }
    void commit(float p_continue) {
      for (int k = 0; k < C; ++k) beta[k] = pending[k] / p_continue;
    }
    RGB origin_scale(float) const { return RGB(0.0f); }  // GPM's origins: RGB photons only
    // ---- Participating media (photon_walk.h) ----
    int channels() const { return C; }
    const MediumChannels& medium_channels(int m) const { return media[m]; }
    ChannelValues channel_weights() const { return beta_channels(beta, C); }
    void medium_weight(const ChannelValues& w) { scale_by_channels(beta, w, C); }
    void deposit_volume(const Vec3& p, const Vec3& wi) {
      if (volume) volume->push_back(SpectralPhoton{Photon{p, wi, RGB(1.0f), 0, kAllLobes}, beta, hero_only});
    }
  };

  std::atomic<int64_t> rays_total{0}, invalid_total{0};
  if (!lights.empty() && count > 0)
    for_photon_chunks(
        count, seed_ ^ 0x73706870686fULL, pass, threads_, cancelled, rays_total, invalid_total,
        [&](size_t c) {
          spectral_chunks_[c].clear();
          if (media_) spectral_volume_chunks_[c].clear();
        },
        [&](size_t c, PrimarySamples& u, int64_t& invalid) {
          SpectralPhotonPower power{scene_, pass_spectra_, C, spectral_chunks_[c],
                                    media_ ? &spectral_volume_chunks_[c] : nullptr, pass_media_};
          return tracer_.walk(u, min_deposit_bounce, power, invalid);
        });
  // ---- Concatenate in chunk order (independent of the thread count) ----
  auto concatenate = [&](std::vector<std::vector<SpectralPhoton>>& chunks, std::vector<Photon>& photons,
                         std::vector<SpectralValues>& power, std::vector<uint8_t>& hero) {
    std::vector<size_t> offset(n_chunks + 1, 0);
    for (size_t c = 0; c < n_chunks; ++c) offset[c + 1] = offset[c] + chunks[c].size();
    const size_t total = offset[n_chunks];
    photons.resize(total);
    power.resize(total);
    hero.resize(total);
    parallel_for(n_chunks, threads_, [&](size_t lo, size_t hi) {
      for (size_t c = lo; c < hi; ++c)
        for (size_t k = offset[c]; k < offset[c + 1]; ++k) {
          const SpectralPhoton& sp = chunks[c][k - offset[c]];
          photons[k] = sp.photon;
          photons[k].index = static_cast<uint32_t>(k);
          power[k] = sp.power;
          hero[k] = sp.hero_only ? 1 : 0;
        }
    });
    for (size_t c = 0; c < n_chunks; ++c) chunks[c].clear();
    return total;
  };
  const size_t total = concatenate(spectral_chunks_, photons_, photon_power_, photon_hero_);
  if (media_) concatenate(spectral_volume_chunks_, volume_photons_, volume_power_, volume_hero_);
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
      // Both sides where the point's BSDF transmits (at the hero wavelength: the lobes are the
      // same at every one).
      const bool transmits = bk[0]->transmits();
      double m = 0, lap = 0;
      RGB phi(0.0f);
      grid_.query(vp.p, R, [&](const Photon& ph, float d2, float weight) {
        const Vec3 wi = vp.frame.to_local(ph.wi);
        if (!photon_gather_side(transmits, vp.wo, wi)) return;
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
