#include "integrators/spectral/spectral_pt.h"

#include <chrono>

#include "core/frame.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/lobe_split.h"
#include "materials/bsdf.h"

namespace gp {

std::string first_dispersive_material(const Scene& scene) {
  for (const Material& m : scene.materials)
    if (is_dispersive(m)) return m.name.empty() ? "(unnamed)" : m.name;
  return "";
}

SpectralMode parse_spectral_mode(const std::string& s) {
  if (s == "auto") return SpectralMode::Auto;
  if (s == "rgb") return SpectralMode::Rgb;
  if (s == "spectral") return SpectralMode::Spectral;
  throw ParamError("spectral mode must be auto, rgb or spectral, got '" + s + "'");
}

bool use_spectral(SpectralMode mode, const Scene& scene) {
  switch (mode) {
    case SpectralMode::Rgb: return false;
    case SpectralMode::Spectral: return true;
    case SpectralMode::Auto: return !first_dispersive_material(scene).empty();
  }
  return false;
}

SceneSpectra::SceneSpectra(const Scene& scene) {
  for (const Material& m : scene.materials) albedo.push_back(RgbSpectrum::reflectance(m.color));
  for (const Light& l : scene.light_set().lights()) {
    if (l.lines.empty()) {
      light.push_back(RgbSpectrum::illuminant(l.emit));
    } else {  // luminance from emit = the lines' unit-luminance RGB x luminance
      const RGB unit = spectral_lines_rgb(l.lines, l.line_fwhm);
      const float m = unit.max_component();
      light.push_back(RgbSpectrum::lines(l.lines, l.line_fwhm, m > 0 ? l.emit.max_component() / m : 0.0f));
    }
  }
}

BsdfParams monochromatic(const Material& m, const RgbSpectrum& albedo, Vec2 uv, float lambda) {
  return SpectralSurface(m, uv, &albedo).at(lambda);
}

void SpectraAtWavelengths::evaluate(const Scene& scene, const SceneSpectra& spectra, const SampledWavelengths& wl) {
  count_ = wl.count;
  scene_ = &scene;
  spectra_ = &spectra;
  wl_ = wl;
  bsdf_.resize(scene.materials.size() * count_);
  per_point_.resize(scene.materials.size());
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    per_point_[m] = scene.materials[m].has_bsdf_textures();
    if (per_point_[m]) continue;  // made per point (material())
    const SpectralSurface surface(scene.materials[m], Vec2(), &spectra.albedo[m]);
    for (int k = 0; k < count_; ++k) bsdf_[m * count_ + k] = surface.at(wl.lambda[k]);
  }
  light_.resize(spectra.light.size() * count_);
  for (size_t l = 0; l < spectra.light.size(); ++l)
    for (int k = 0; k < count_; ++k) light_[l * count_ + k] = spectra.light[l](wl.lambda[k]);
}

const BsdfParams* SpectraAtWavelengths::at_point(int m, Vec2 uv, WavelengthParams& local) const {
  const SpectralSurface surface(scene_->materials[static_cast<size_t>(m)], uv, &spectra_->albedo[static_cast<size_t>(m)]);
  BsdfParams* params = local.make();
  for (int k = 0; k < count_; ++k) params[k] = surface.at(wl_.lambda[k]);
  return params;
}

SpectralPathTracer::SpectralPathTracer(const Scene& scene, const Params& params, bool hero)
    : scene_(scene),
      spectra_(scene),
      hero_(hero),
      max_depth_(params.get<int>("max_depth")),
      rr_depth_(params.get<int>("rr_depth")),
      count_(params.get<int>("wavelengths")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      seed_(params.get<uint64_t>("seed")),
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

}  // namespace

float light_scale(const LightSample& ls, const Light& l) {
  const float m = l.emit.max_component();
  if (m <= 0) return 0.0f;
  const int c = l.emit.r == m ? 0 : (l.emit.g == m ? 1 : 2);
  return ls.L[c] / l.emit[c];
}

SpectralValues SpectralPathTracer::Li(Ray ray, const SampledWavelengths& wl, Rng& rng, RayCounts& rays,
                                      const std::optional<SurfaceHit>* first) const {
  const LightSet& lights = scene_.light_set();
  const int C = wl.count;
  const bool split_lobes = scene_.lights_hidden_from_some_lobes();
  // beta: throughput divided by the hero's path pdf. r_u: p(x | lambda_k) / p(x | hero) of the
  // BSDF-sampled path (eq. 4's ratios). r_l: the same without the last BSDF pdf, divided by
  // the hero's last pdf, times which the light pdf gives the NEE strategy's ratio.
  SpectralValues L{}, beta{}, r_u{}, r_l{};
  for (int k = 0; k < C; ++k) beta[k] = r_u[k] = 1.0f;
  bool specular_bounce = false;
  Vec3 prev_p;
  std::array<BsdfParams, kMaxWavelengths> mk;
  std::array<std::optional<Bsdf>, kMaxWavelengths> bk;  // mk's BSDFs at the hit
  SpectralLobeSplit prev;  // the previous vertex's lobes, where some light is hidden from some kinds

  // Emission found by a ray: balance heuristic over C wavelengths x {BSDF, light} strategies.
  auto add_emission = [&](const RgbSpectrum& spec, float pdf_light, bool full, float scale = 1.0f) {
    float denom = 0;
    for (int k = 0; k < C; ++k) denom += full ? r_u[k] : r_u[k] + r_l[k] * pdf_light;
    denom /= C;
    if (denom <= 0) return;
    for (int j = 0; j < C; ++j) L[j] += beta[j] * spec(wl.lambda[j]) * scale / denom;  // eq. 3-4
  };
  // Emission of a light visible to the kinds `vis` found by a bounce ray (Cycles' per-kind
  // visibility, as in the path tracer).
  auto add_bounce_emission = [&](const RgbSpectrum& spec, uint8_t vis, float pdf_light) {
    if (vis == kAllLobes) return add_emission(spec, pdf_light, specular_bounce);
    if (!(vis & prev.lobe)) return;
    if (specular_bounce) return add_emission(spec, 0.0f, true);
    prev.add(spec, vis, pdf_light, wl, L);
  };

  constexpr int kMaxPassThrough = 8;  // as the path tracer (Cycles' Transparent bounces)
  int pass_through = 0;
  for (int depth = 0;; ++depth) {
    ++rays.closest;
    const std::optional<SurfaceHit> traced = first ? std::nullopt : scene_.intersect(ray);
    const std::optional<SurfaceHit>& hit = first ? *first : traced;
    first = nullptr;  // only the camera ray's hit is given

    // ---- Emission found by the ray ----
    if (!hit) {
      const int env = lights.environment();
      if (env >= 0) {
        const Light& e = lights.lights()[env];  // the World's Ray Visibility
        if (depth == 0) {
          if (e.visible_to_camera && !ray.held_out) add_emission(spectra_.light[env], 0.0f, true);
        } else if (e.lit_by_bsdf_rays_only()) {  // Cycles' rule for the World (lobe_split.h): full weight
          if (e.visible_lobes & prev.lobe)
            add_emission(spectra_.light[env], 0.0f, true, specular_bounce ? 1.0f : prev.world_reweight);
        } else {
          add_bounce_emission(spectra_.light[env], e.visible_lobes, specular_bounce ? 0.0f : lights.pdf_environment(ray.d));
        }
      }
      break;
    }
    if (hit->light >= 0 && !lights.area_radiance(hit->light, -ray.d).is_black()) {
      if (depth == 0) {
        add_emission(spectra_.light[hit->light], 0.0f, true);
      } else {
        add_bounce_emission(spectra_.light[hit->light], lights.lights()[hit->light].visible_lobes,
                            specular_bounce ? 0.0f : lights.pdf_area(hit->light, prev_p, hit->p, ray.d));
      }
    }
    const Material& base = scene_.material(hit->material);
    // ---- A pass-through surface (a light object): crossed as the path tracer crosses it,
    // keeping the path's state and its kind of ray ----
    if (base.is_pass_through() && pass_through < kMaxPassThrough) {
      ++pass_through;
      Ray on(offset_ray_origin(hit->p, hit->ng, ray.d), ray.d);
      on.camera = ray.camera;
      on.bounce = ray.bounce;
      ray = on;
      --depth;
      continue;
    }
    if (depth + 1 >= max_depth_) break;

    const bool dispersive = is_dispersive(base);
    const SpectralSurface surface(base, hit->uv, &spectra_.albedo[hit->material]);  // textures read once
    for (int k = 0; k < C; ++k) {
      mk[k] = surface.at(wl.lambda[k]);
      bk[k] = scene_.bsdf(mk[k], *hit);  // with the hit's normals (a normal map's bump shadowing)
    }
    const Bsdf& hero_bsdf = *bk[0];
    if (scene_.bsdf(*hit).is_black()) break;
    const Vec3 wo = hit->frame.to_local(-ray.d);
    if (wo.z == 0) break;

    // ---- Emitter sampling (next-event estimation) ----
    // A light hidden from some kinds of bounce ray lights only the lobes of the kinds it is
    // visible to, with their density for MIS (as the path tracer).
    if (!hero_bsdf.is_delta() && !lights.empty()) {
      const float u_light = rng.uniform();
      const Vec2 u2(rng.uniform(), rng.uniform());
      if (auto ls = lights.sample_li(hit->p, u_light, u2);
          ls && ls->pdf > 0 && !ls->L.is_black() && !lights.lights()[ls->light].lit_by_bsdf_rays_only()) {
        const uint8_t vis = lights.lights()[ls->light].visible_lobes;
        const Vec3 wi = hit->frame.to_local(ls->wi);
        SpectralValues f{}, pdf{};
        bool any = false;
        for (int k = 0; k < C; ++k) {
          const Bsdf& b = *bk[k];
          f[k] = b.eval(wo, wi, TransportMode::Radiance, vis)[0] * std::abs(wi.z);  // grey material: any channel
          // The pdf only depends on the wavelength through a dispersive IOR.
          pdf[k] = (k == 0 || dispersive) ? b.pdf(wo, wi, vis) : pdf[0];
          any |= f[k] > 0;
        }
        if (any) {
          ++rays.shadow;
          const bool blocked = scene_.occluded(hit->p, hit->ng, *ls);
          if (!blocked) {
            float denom = 0;  // mean over wavelengths of (light + BSDF strategy) pdf ratios
            for (int k = 0; k < C; ++k) denom += r_u[k] * (ls->pdf + (ls->delta ? 0.0f : pdf[k]));
            denom /= C;
            const float scale = light_scale(*ls, lights.lights()[ls->light]);
            const RgbSpectrum& spec = spectra_.light[ls->light];
            if (denom > 0)
              for (int j = 0; j < C; ++j) L[j] += beta[j] * f[j] * scale * spec(wl.lambda[j]) / denom;
          }
        }
      }
    }

    // ---- BSDF sampling (driven by the hero wavelength) ----
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto bs = hero_bsdf.sample(wo, uc, u);
    if (!bs || bs->pdf <= 0) break;
    if (split_lobes) {
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
        } else {
          f[k] = b.eval(wo, bs->wi)[0];
        }
        pdf[k] = bs->pdf;
      } else if (!bs->delta) {  // rough dispersive dielectric: evaluate each wavelength
        f[k] = b.eval(wo, bs->wi)[0];
        pdf[k] = b.pdf(wo, bs->wi);
      } else if (!bs->transmission) {  // smooth dispersive reflection: same mirror direction
        const float R = fresnel_dielectric(cos_theta(wo), mk[k].ior);
        f[k] = mk[k].color.r * R / std::abs(bs->wi.z);
        pdf[k] = R;  // lobe selection probability R / (R + T)
      } else {  // smooth dispersive refraction: no other wavelength goes this way
        f[k] = 0.0f;
        pdf[k] = 0.0f;
      }
    }
    bool alive = false;
    for (int k = 0; k < C; ++k) {
      beta[k] *= f[k] * std::abs(bs->wi.z) / bs->pdf;
      r_l[k] = r_u[k] / bs->pdf;
      r_u[k] *= pdf[k] / bs->pdf;
      alive |= beta[k] > 0;
    }
    if (!alive) break;
    specular_bounce = bs->delta;
    prev_p = hit->p;
    const Vec3 wi = hit->frame.to_world(bs->wi);
    ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
    ray.bounce = bs->lobe;  // surfaces hidden from this kind of ray let it through

    // ---- Russian roulette (on the MIS-weighted throughput) ----
    if (depth + 1 >= rr_depth_) {
      const float ru = mean(r_u, C);
      float bmax = 0;
      for (int k = 0; k < C; ++k) bmax = std::max(bmax, beta[k]);
      const float q = std::max(0.05f, 1.0f - (ru > 0 ? bmax / ru : 0.0f));
      if (rng.uniform() < q) break;
      for (int k = 0; k < C; ++k) {
        beta[k] /= 1.0f - q;
        prev.beta[k] /= 1.0f - q;
      }
    }
  }
  return L;
}

void SpectralPathTracer::iterate(ProgressSink* sink) {
  // A tile's camera rays are traced together (as in PathTracer::iterate).
  estimate_.run_pass_tiles(seed_, tile_size_, threads_, sink, stats_,
                           [this](PixelStart* starts, size_t n, RayCounts& rays, PixelSample* out) {
                             CameraRays first(scene_, starts, n);
                             const std::vector<Ray>& camera = first.rays;
                             std::vector<std::optional<SurfaceHit>>& hits = first.hits;
                             for (size_t i = 0; i < n; ++i) {
                               Rng& rng = starts[i].rng;
                               const SampledWavelengths wl = SampledWavelengths::sample_uniform(rng.uniform(), count_);
                               out[i].L = sample_to_rgb(Li(camera[i], wl, rng, rays, &hits[i]), wl);
                             }
                           });
}

void SpectralPathTracer::develop(Film& film) const { estimate_.develop(film, pass::kCombined); }

}  // namespace gp
