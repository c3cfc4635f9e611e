#include "integrators/spectral/spectral_pt.h"

#include <chrono>

#include "core/frame.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/lobe_split.h"
#include "integrators/paths/camera_path.h"
#include "materials/bsdf.h"

namespace gp {

SpectralPathTracer::SpectralPathTracer(const Scene& scene, const Params& params, bool hero)
    : scene_(scene),
      spectra_(scene),
      hero_(hero),
      settings_{.max_depth = params.get<int>("max_depth"), .rr_depth = params.get<int>("rr_depth"),
                .film_transparent = params.get<bool>("film_transparent"), .camera_media = CameraMedia(scene)},
      count_(params.get<int>("wavelengths")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      seed_(params.get<uint64_t>("seed")),
      pattern_(parse_sampling_pattern(params.get<std::string>("sampling_pattern"))),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      estimate_(std::max(1, width_), std::max(1, height_), &scene.camera) {  // sizes checked just below
  check_image_size(width_, height_);  // the parameters are checked by their declarations (methods.cpp)
}

namespace {

float mean(const SpectralValues& v, int n) {
  float s = 0;
  for (int k = 0; k < n; ++k) s += v[k];
  return s / n;
}

// Cycles' per-kind ray visibility of lights, as the path tracer applies it (path_tracer.cpp,
// LobeSplit), per wavelength: what a BSDF ray that meets a light visible only to some kinds of
// bounce ray needs from the vertex that sampled it. The hit counts only when the sampled lobe
// sees the light, weighted f_V cos / p_V (the restricted BSDF and its density), and the
// balance heuristic over wavelengths and {BSDF, light} strategies uses p_V as the BSDF
// strategy's density, as next-event estimation does (f and pdf restricted to the lobes V).
struct SpectralLobeSplit {
  std::array<std::array<float, 3>, kMaxWavelengths> f{}, pdf{};  // per wavelength, per lobe kind
  SpectralValues beta{}, r_u{};  // throughput and pdf ratios before the vertex
  float cos = 0;
  uint8_t lobe = 0;
  // The hero's P_C(lobe | wi) / P(lobe | wi), Cycles' probability that the direction came
  // through the sampled lobe over the sampler's, for the World (LobeSplit::weigh_world; the
  // hero's stands for every wavelength: only a dispersive part of a mix would differ).
  float world_reweight = 1.0f;

  void fill(const std::array<std::optional<Bsdf>, kMaxWavelengths>& bk, int C, bool dispersive, const Vec3& wo,
            const Vec3& wi) {
    for (int k = 0; k < C; ++k) {
      const Bsdf& b = *bk[k];
      for (int l = 0; l < 3; ++l) {
        const uint8_t bit = static_cast<uint8_t>(kRayDiffuse << l);
        f[k][l] = b.eval(wo, wi, TransportMode::Radiance, bit)[0];
        pdf[k][l] = (k == 0 || dispersive) ? b.pdf(wo, wi, bit) : pdf[0][l];
      }
    }
    cos = std::abs(wi.z);
    LobeSplit hero;
    hero.lobe = lobe;
    hero.fill(*bk[0], wo, wi);
    const float p = hero.lobe_share(lobe);
    world_reweight = p > 0 ? hero.cycles_lobe_share(lobe) / p : 0.0f;
  }
  // The emission `spec` found by the BSDF ray from a light visible to `vis` (not all kinds),
  // added to L; pdf_light is the light strategy's density of the point.
  void add(const RgbSpectrum& spec, uint8_t vis, float pdf_light, const SampledWavelengths& wl,
           SpectralValues& L) const {
    if (!(vis & lobe)) return;
    const int C = wl.count;
    SpectralValues fv{};
    float denom = 0;
    for (int k = 0; k < C; ++k) {
      float pv = 0;
      for (int l = 0; l < 3; ++l)
        if (vis & (kRayDiffuse << l)) {
          fv[k] += f[k][l];
          pv += pdf[k][l];
        }
      denom += r_u[k] * (pv + pdf_light);  // eq. 3-4 with the BSDF strategy restricted to V
    }
    denom /= C;
    if (!(denom > 0)) return;
    for (int j = 0; j < C; ++j) L[j] += beta[j] * fv[j] * cos * spec(wl.lambda[j]) / denom;
  }
};


// The path at C wavelengths (paths/camera_path.h). beta: throughput divided by the hero's path
// pdf. r_u: p(x | lambda_k) / p(x | hero) of the BSDF-sampled path (eq. 4's ratios). r_l: the
// same without the last BSDF pdf, divided by the hero's last pdf, times which the light pdf
// gives the NEE strategy's ratio. Emission is combined by the balance heuristic over C
// wavelengths x {BSDF, light} strategies (eq. 3-4).
struct SpectralPath {
  const Scene& scene;
  const LightSet& lights;
  const SceneSpectra& spectra;
  const SampledWavelengths& wl;
  const int C;
  const bool split_lobes;
  SpectralValues L{}, beta{}, r_u{}, r_l{};
  bool specular_bounce = true;  // as RgbPath: the camera ray's (only a transparent pass carries it on)
  Vec3 prev_p;
  std::array<BsdfParams, kMaxWavelengths> mk;
  std::array<std::optional<Bsdf>, kMaxWavelengths> bk;  // mk's BSDFs at the hit
  bool dispersive = false;
  SpectralLobeSplit prev;  // the previous vertex's lobes, where some light is hidden from some kinds
  int64_t shadow_rays = 0;
  bool medium_vertex = false;          // the ray was scattered by a medium (every light sees it)
  std::vector<MediumChannels> media;   // the scene's media at the path's wavelengths
  // Film > Transparent: the RGB weight of the camera's transparent passes (paths/medium_walk.h),
  // and the RGB BSDF of the hit while that walk lasts (a glass whose IOR a graph drives may be a
  // transparent pass at a hit: Material::has_transparent_closure does not know).
  RgbTransparency alpha;
  std::optional<Bsdf> rgb_bsdf;

  SpectralPath(const Scene& s, const SceneSpectra& sp, const SampledWavelengths& w)
      : scene(s), lights(s.light_set()), spectra(sp), wl(w), C(w.count), split_lobes(s.lights_hidden_from_some_lobes()) {
    for (int k = 0; k < C; ++k) beta[k] = r_u[k] = 1.0f;
    if (s.has_media())
      for (const MediumSpectra& m : sp.media) media.push_back(m.at(w));
  }

  // Emission found by a ray: balance heuristic over C wavelengths x {BSDF, light} strategies.
  void add_emission(const RgbSpectrum& spec, float pdf_light, bool full, float scale = 1.0f) {
    float denom = 0;
    for (int k = 0; k < C; ++k) denom += full ? r_u[k] : r_u[k] + r_l[k] * pdf_light;
    denom /= C;
    if (denom <= 0) return;
    for (int j = 0; j < C; ++j) L[j] += beta[j] * spec(wl.lambda[j]) * scale / denom;  // eq. 3-4
  }
  // Emission of a light visible to the kinds `vis` found by a bounce ray (Cycles' per-kind
  // visibility, as in the path tracer).
  void add_bounce_emission(const RgbSpectrum& spec, uint8_t vis, float pdf_light) {
    if (vis == kAllLobes || medium_vertex) return add_emission(spec, pdf_light, specular_bounce);
    if (!(vis & prev.lobe)) return;
    if (specular_bounce) return add_emission(spec, 0.0f, true);
    prev.add(spec, vis, pdf_light, wl, L);
  }
  // The spectrum light l sends as RGB `value()`: its own spectrum (SceneSpectra::light), or, for
  // a World whose colour varies with direction, value() upsampled per hit (light_spectrum),
  // kept in `varying`; value() is evaluated only then.
  template <class Value>
  const RgbSpectrum& light_seen(int l, Value value, std::optional<RgbSpectrum>& varying) const {
    if (varies_with_direction(lights, l)) varying = light_spectrum(spectra, lights, l, value());
    return varying ? *varying : spectra.light[l];
  }
  // The grey factor of a light sample on its light's spectrum (1 for a varying World, whose
  // light_seen spectrum is the sample's own colour).
  float sample_scale(const LightSample& ls, const std::optional<RgbSpectrum>& varying) const {
    return varying ? 1.0f : light_scale(ls, lights.lights()[ls.light]);
  }
  // A point or spot light's disk met by a BSDF ray adds nothing here: next-event estimation
  // takes such a light at full weight (a delta sample, next_event), where the RGB path shares it
  // with BSDF hits by MIS (LightSample::mis_pdf). Either way the disk's light is counted once.
  void disk_light(int, int, const RGB&, float) {}
  // An environment whose colour varies with direction is upsampled per hit (light_spectrum).
  void environment(int depth, const Ray& ray) {
    const int env = lights.environment();
    if (env < 0) return;
    const Light& e = lights.lights()[env];  // the World's Ray Visibility
    std::optional<RgbSpectrum> varying;
    const RgbSpectrum& spec = light_seen(env, [&] { return lights.environment_radiance(ray); }, varying);
    if (depth == 0) {
      if (e.visible_to_camera) add_emission(spec, 0.0f, true);
    } else if (e.lit_by_bsdf_rays_only()) {  // Cycles' rule for the World (lobe_split.h): full weight
      if (medium_vertex) add_emission(spec, 0.0f, true);  // a phase-sampled ray: not sampled by NEE
      else if (e.visible_lobes & prev.lobe) add_emission(spec, 0.0f, true, specular_bounce ? 1.0f : prev.world_reweight);
    } else {
      add_bounce_emission(spec, e.visible_lobes, specular_bounce ? 0.0f : lights.pdf_environment(ray.d));
    }
  }
  void area_light(int depth, const SurfaceHit& hit, const Ray& ray) {
    if (lights.area_radiance(hit.light, -ray.d).is_black()) return;
    // A graph-driven emission is evaluated at the hit, for the ray that met it (Light Path).
    std::optional<RgbSpectrum> varying;
    const RgbSpectrum& spec =
        light_seen(hit.light, [&] { return lights.area_radiance(hit.light, -ray.d, hit.p, &hit.ray); }, varying);
    if (depth == 0) return add_emission(spec, 0.0f, true);
    add_bounce_emission(spec, lights.lights()[hit.light].visible_lobes,
                        specular_bounce ? 0.0f : lights.pdf_area(hit.light, prev_p, hit.p, ray.d));
  }
  bool prepare(const SurfaceHit& hit, const ClosureFilter& filter) {
    const Material& base = scene.material(hit.material);
    dispersive = is_dispersive(base);
    // Textures and node graphs read once, at the hit's full shading context.
    const SpectralSurface surface(base, scene.shading_context(hit), &spectra.albedo[hit.material]);
    for (int k = 0; k < C; ++k) {
      mk[k] = surface.at(wl.lambda[k]);
      filter_closures(mk[k], filter);  // Light Paths > Caustics (camera_path.h)
      bk[k] = scene.bsdf(mk[k], hit);  // with the hit's normals (a normal map's bump shadowing)
    }
    // The RGB parameters the surface already holds (its graph run once per hit, not again).
    rgb_bsdf.emplace(surface.rgb());
    const bool black = rgb_bsdf->is_black();
    if (!alpha.walking()) rgb_bsdf.reset();  // kept for the camera's walk only
    return !black;
  }
  bool is_delta() const { return bk[0]->is_delta(); }
  // A light hidden from some kinds of bounce ray lights only the lobes of the kinds it is
  // visible to, with their density for MIS (as the path tracer).
  void next_event(int, const SurfaceHit& hit, const Vec3& wo, const LightSample& ls, const ShadowTest& shadow) {
    const uint8_t vis = lights.lights()[ls.light].visible_lobes;
    const Vec3 wi = hit.frame.to_local(ls.wi);
    SpectralValues f{}, pdf{};
    bool any = false;
    for (int k = 0; k < C; ++k) {
      const Bsdf& b = *bk[k];
      f[k] = b.eval(wo, wi, TransportMode::Radiance, vis)[0] * std::abs(wi.z);  // grey material: any channel
      // The pdf only depends on the wavelength through a dispersive IOR.
      pdf[k] = (k == 0 || dispersive) ? b.pdf(wo, wi, vis) : pdf[0];
      any |= f[k] > 0;
    }
    if (!any) return;
    ++shadow_rays;
    const ChannelValues T = shadow.transmittance(hit.p, &hit.ng, ls, shadow_channels(hit.ray));
    if (is_blocked(T, C)) return;
    for (int k = 0; k < C; ++k) f[k] *= T[k];  // media and transparent surfaces (1 where there are none)
    float denom = 0;  // mean over wavelengths of (light + BSDF strategy) pdf ratios
    for (int k = 0; k < C; ++k) denom += r_u[k] * (ls.pdf + (ls.delta ? 0.0f : pdf[k]));
    denom /= C;
    std::optional<RgbSpectrum> varying;
    const RgbSpectrum& spec = light_seen(ls.light, [&] { return ls.L; }, varying);
    const float scale = sample_scale(ls, varying);
    if (denom > 0)
      for (int j = 0; j < C; ++j) L[j] += beta[j] * f[j] * scale * spec(wl.lambda[j]) / denom;
  }
  // Driven by the hero wavelength; the others follow with their own factors and pdfs.
  std::optional<BsdfSample> scatter(const SurfaceHit& hit, const Vec3& wo, float uc, Vec2 u) {
    const auto bs = bk[0]->sample(wo, uc, u);
    if (!bs || bs->pdf <= 0) return std::nullopt;
    alpha.scatter(rgb_bsdf ? &*rgb_bsdf : nullptr, wo, uc, u, *bs);
    // Through a Transparent BSDF: the MIS state of the vertex before it stays (as RgbPath).
    const bool transparent = is_transparent_pass(*bs) && scene.material(hit.material).transparent_shadow();
    if (split_lobes && !transparent) {
      prev.beta = beta;
      prev.r_u = r_u;
      prev.lobe = bs->lobe;
      if (!bs->delta) prev.fill(bk, C, dispersive, wo, bs->wi);
    }
    SpectralValues f{}, pdf{};
    f[0] = bs->f[0];
    pdf[0] = bs->pdf;
    for (int k = 1; k < C; ++k) {
      const Bsdf& b = *bk[k];
      if (!dispersive) {
        // Same direction and pdf for every wavelength; delta lobes are re-sampled with the
        // same random numbers (lobe choice and direction do not depend on the colour).
        if (bs->delta) {
          const auto sk = b.sample(wo, uc, u);
          f[k] = sk ? sk->f[0] : 0.0f;
        } else if (bs->stochastic) {
          // A random walk (Multiscatter GGX): its density is unknown, so each wavelength takes
          // its own weight of the same walk (same numbers, same path: the colour only scales it).
          const auto sk = b.sample(wo, uc, u);
          f[k] = sk && sk->wi.x == bs->wi.x && sk->wi.y == bs->wi.y && sk->wi.z == bs->wi.z
                     ? sk->f[0] * (bs->pdf / sk->pdf) : 0.0f;
        } else {
          f[k] = b.eval(wo, bs->wi)[0];
        }
        pdf[k] = bs->pdf;
      } else if (!bs->delta) {  // rough dispersive dielectric: evaluate each wavelength
        f[k] = b.eval(wo, bs->wi)[0];
        pdf[k] = b.pdf(wo, bs->wi);
      } else if (!bs->transmission) {  // smooth dispersive reflection: same mirror direction
        const float R = fresnel_dielectric(cos_theta(wo), mk[k].ior);
        f[k] = dielectric_reflection_color(mk[k], cos_theta(wo)).r * R / std::abs(bs->wi.z);
        pdf[k] = R;  // lobe selection probability R / (R + T)
      } else {  // smooth dispersive refraction: no other wavelength goes this way
        f[k] = 0.0f;
        pdf[k] = 0.0f;
      }
    }
    bool alive = false;
    for (int k = 0; k < C; ++k) {
      const float w = f[k] * std::abs(bs->wi.z) / bs->pdf;
      beta[k] *= w;
      if (transparent) {
        if (split_lobes) prev.beta[k] *= w;
        r_l[k] *= pdf[k] / bs->pdf;  // the light strategy's ratio as it was, over this pass
      } else {
        r_l[k] = r_u[k] / bs->pdf;
      }
      r_u[k] *= pdf[k] / bs->pdf;
      alive |= beta[k] > 0;
    }
    if (!alive) return std::nullopt;
    if (transparent) return bs;
    specular_bounce = bs->delta;
    medium_vertex = false;
    prev_p = hit.p;
    return bs;
  }
  // Russian roulette on the MIS-weighted throughput.
  bool survive(float u_rr, float eta_scale) {
    const float ru = mean(r_u, C);
    float bmax = 0;
    for (int k = 0; k < C; ++k) bmax = std::max(bmax, beta[k]);
    const float survival = camera_path_survival(ru > 0 ? bmax / ru * eta_scale : 0.0f);
    if (!(u_rr < survival)) return false;
    for (int k = 0; k < C; ++k) {
      beta[k] /= survival;
      prev.beta[k] /= survival;
    }
    alpha.scale(1.0f / survival);
    return true;
  }

  // ---- Participating media (paths/camera_path.h), at the path's C wavelengths ----
  // Free-flight distances are sampled from the mean over wavelengths (MediumSegment), the same
  // density for every wavelength: the ratios r_u of eq. 4 are unchanged by them; the phase
  // function's density does not depend on the wavelength either.
  int channels() const { return C; }
  const MediumChannels& medium_channels(int m) const { return media[m]; }
  ShadowChannels shadow_channels(const RayState& state) const {
    return {.count = C, .lambda = wl.lambda.data(), .media = media.empty() ? nullptr : media.data(), .state = state};
  }
  ChannelValues channel_weights() const { return beta_channels(beta, C); }
  const RgbTransparency& rgb_transparency() const { return alpha; }  // path_transparency
  struct Saved {
    SpectralValues beta, prev_beta;
    RgbTransparency alpha;
  };
  Saved save() const { return {beta, prev.beta, alpha}; }
  void restore(const Saved& s) {
    beta = s.beta;
    prev.beta = s.prev_beta;
    alpha = s.alpha;
  }
  void medium_weight(const ChannelValues& w) {
    scale_by_channels(beta, w, C);
    scale_by_channels(prev.beta, w, C);
    alpha.scale(w, C);
  }
  // Emission found by the ray only (the BSDF strategy's full weight, as add_emission).
  void medium_emission(int, const ChannelValues& e) {
    const float ru = mean(r_u, C);
    if (!(ru > 0)) return;
    for (int j = 0; j < C; ++j) L[j] += beta[j] * e[j] / ru;
  }
  void medium_next_event(int, const LightSample& ls, const ChannelValues& phase, float phase_pdf,
                         const ChannelValues& T) {
    ++shadow_rays;
    float denom = 0;  // as next_event, the phase function in the BSDF's place
    for (int k = 0; k < C; ++k) denom += r_u[k] * (ls.pdf + (ls.delta ? 0.0f : phase_pdf));
    denom /= C;
    if (!(denom > 0)) return;
    std::optional<RgbSpectrum> varying;
    const RgbSpectrum& spec = light_seen(ls.light, [&] { return ls.L; }, varying);
    const float scale = sample_scale(ls, varying);
    for (int j = 0; j < C; ++j) L[j] += beta[j] * phase[j] * T[j] * scale * spec(wl.lambda[j]) / denom;
  }
  void medium_scattered(const Vec3& p, float phase_pdf, const ChannelValues& ratio) {
    for (int k = 0; k < C; ++k) {
      beta[k] *= ratio[k];
      r_l[k] = r_u[k] / phase_pdf;
    }
    alpha.end();
    specular_bounce = false;
    medium_vertex = true;
    prev_p = p;
  }
};

}  // namespace

template <class S>
SpectralValues SpectralPathTracer::Li(Ray ray, const SampledWavelengths& wl, S& sampler, RayCounts& rays,
                                      const std::optional<SurfaceHit>* first, float* transparent) const {
  SpectralPath path(scene_, spectra_, wl);
  return camera_path_radiance(scene_, settings_, ray, sampler, rays, path, first, transparent);
}
template SpectralValues SpectralPathTracer::Li(Ray, const SampledWavelengths&, SobolSampler&, RayCounts&,
                                               const std::optional<SurfaceHit>*, float*) const;
template SpectralValues SpectralPathTracer::Li(Ray, const SampledWavelengths&, IndependentSampler&, RayCounts&,
                                               const std::optional<SurfaceHit>*, float*) const;

SpectralValues SpectralPathTracer::Li(Ray ray, const SampledWavelengths& wl, Rng& rng, RayCounts& rays,
                                      const std::optional<SurfaceHit>* first, float* transparent) const {
  IndependentSampler sampler{rng};
  return Li(ray, wl, sampler, rays, first, transparent);
}

void SpectralPathTracer::iterate(ProgressSink* sink) {
  estimate_.run_camera_pass(scene_, seed_, tile_size_, threads_, sink, stats_, pattern_,
                            [this](const Ray& ray, auto& rng, RayCounts& rays, const std::optional<SurfaceHit>* first) {
                              // The hero wavelength: a camera dimension of the pattern.
                              const SampledWavelengths wl =
                                  SampledWavelengths::sample_uniform(rng.get1d(kDimWavelength), count_);
                              float transparent = 0.0f;  // Cycles' transparent pass: alpha 1 - it
                              const RGB L = sample_to_rgb(Li(ray, wl, rng, rays, first, &transparent), wl);
                              return PixelSample{L, 1.0f - transparent};
                            });
}

void SpectralPathTracer::develop(Film& film) const {
  estimate_.develop(film, pass::kCombined);
  if (writes_alpha(settings_.film_transparent, scene_)) estimate_.develop_alpha(film);
}

}  // namespace gp
