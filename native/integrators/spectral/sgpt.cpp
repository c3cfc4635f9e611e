#include "integrators/spectral/sgpt.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>

#include "core/frame.h"
#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/paths/medium_walk.h"
#include "integrators/shift/spectral_shift.h"
#include "materials/bsdf.h"

namespace gp {

namespace {

// One vertex of the base path: the surface x_k, the direction back to x_{k-1}, and how the
// base continued from it.
struct BaseVertex {
  SurfaceHit hit;
  Vec3 wo;                    // local, towards x_{k-1}
  bool scattered = false;     // has a sampled continuation (wi below is set)
  Vec3 wi;                    // local sampled direction
  uint8_t kind = 0;           // the kind of the ray it sends on (Ray::bounce: the lobe sampled)
  float uc = 0;               // the sampler's random numbers (delta lobes are re-sampled with them)
  Vec2 u;
  bool delta = false, transmission = false;
  float pdf = 0;              // BSDF pdf (solid angle, or lobe probability for delta lobes)
  float rr = 1;               // Russian roulette survival probability after this vertex
  // Next-event estimation from this vertex (shared by the offsets: same random numbers, so the
  // same point on an area light or direction of a distant light).
  bool nee_eligible = false;  // NEE was possible here (non-delta BSDF, a light, depth left)
  bool nee = false;           // ... and drew a light sample ls
  bool nee_visible = false;   // ls is unoccluded from x_k
  // The BSDF sample passed straight through a Transparent BSDF, which shadow rays pass too
  // (paths/medium_walk.h): crossed like a light object for MIS (the vertex before competes with
  // NEE for what the ray finds), its factor and density folded into the throughput.
  bool transparent = false;
  // The shadow ray's transmittance at the path's wavelengths (transparent surfaces filter it,
  // paths/medium_walk.h); 1 where it is visible and crosses none.
  ChannelValues nee_T{};
  float u_light = 0;
  Vec2 u_light2;
  LightSample ls;
};

struct BasePath {
  Ray camera_ray;
  std::vector<BaseVertex> v;
  bool escaped = false;       // the last ray left the scene
  Ray escape_ray;             // that ray (world space), from v.back() or the camera
};

// BSDF value (times |cos wi|) and sampling pdf of the pair (wo, wi) for the BSDF b (one
// wavelength's, with the hit's normals: Scene::bsdf), where `delta` says the base sampled a Dirac
// lobe: then f and pdf are the lobe's Dirac weight and selection probability (a dielectric's, a
// smooth mirror's, or a Dirac lobe of a mix's part).
struct Scatter {
  float f_cos = 0, pdf = 0;
};
Scatter delta_scatter(const Bsdf& b, const Vec3& wo, const Vec3& wi, bool transmission, float uc, Vec2 u) {
  Scatter s;
  const BsdfParams& m = b.params();
  if (m.type == MaterialType::Dielectric) {
    const float R = fresnel_dielectric(cos_theta(wo), m.ior);
    if (!transmission) {
      s.f_cos = dielectric_reflection_color(m, cos_theta(wo)).r * R;
      s.pdf = R;
    } else {
      const Etas e = dielectric_etas(m.ior, wo.z, true);
      s.f_cos = m.color.r * (1.0f - R) / sqr(e.wi / e.wo);  // radiance crossing, [Veach97] 5.2
      s.pdf = 1.0f - R;
    }
    return s;
  }
  // A smooth conductor, or a mix: the lobe the base's numbers pick, if it goes the same way (a
  // mix's dispersive glass sends other wavelengths elsewhere).
  if (auto bs = b.sample(wo, uc, u);
      bs && bs->delta && bs->transmission == transmission && dot(bs->wi, wi) > 1.0f - 1e-5f) {
    s.f_cos = bs->f[0] * std::abs(bs->wi.z);
    s.pdf = bs->pdf;
  }
  return s;
}
// `lobes`: only the lobes of those kinds (a light hidden from the others; LobeScatter).
Scatter smooth_scatter(const Bsdf& b, const Vec3& wo, const Vec3& wi, uint8_t lobes = kAllLobes) {
  return {b.eval(wo, wi, TransportMode::Radiance, lobes)[0] * std::abs(wi.z), b.pdf(wo, wi, lobes)};
}

// ---- Lights hidden from some kinds of ray (Light::visible_lobes) ----
// As spt and GPT do (lobe_split.h), per wavelength: emission found by a BSDF ray from a light
// visible to the kinds V counts only when the lobe sampled there is one of V, with f and the
// BSDF strategy's density restricted to V's lobes (f_V, p_V); next-event estimation evaluates
// f_V and p_V. An offset follows its base's lobe, so the shift stays invertible, and weighs the
// light it meets by the lobes that see it at its own vertex. Where the two paths of a pair meet
// lights seen by different kinds, each path's term takes both paths' densities restricted to
// its own light's kinds (eq. 10-11 per term: the other side's pair, base and offset swapped,
// then gets the complementary weight), so every event keeps its density per lobe kind.

// The index of a lobe kind bit (kRayDiffuse, kRayGlossy, kRayTransmission) among the three.
int lobe_index(uint8_t lobe) { return lobe == kRayDiffuse ? 0 : lobe == kRayGlossy ? 1 : 2; }
bool has_lobe(uint8_t kinds, int l) { return (kinds & (kRayDiffuse << l)) != 0; }

// One event of a path (emission found by a BSDF ray, or a light sample) at C wavelengths: f (the
// measurement contribution in the product solid-angle measure) and the path's density under each
// strategy that can produce it, p_bsdf and p_light (the balance heuristic over strategies and
// wavelengths: eq. 3-4 with NEE).
struct Event {
  bool valid = false;
  uint8_t vis = kAllLobes;  // the kinds of ray that see its light: f and p_bsdf are restricted to them
  SpectralValues f{}, p_bsdf{}, p_light{};
  std::array<SpectralValues, 3> p_lobe{};  // p_bsdf per lobe kind (filled where some light is hidden)
  // The BSDF strategy's density through the lobes of the kinds `kinds` only.
  SpectralValues p_bsdf_in(uint8_t kinds, int C) const {
    if (kinds == vis) return p_bsdf;
    SpectralValues p{};
    for (int l = 0; l < 3; ++l)
      if (has_lobe(kinds, l))
        for (int j = 0; j < C; ++j) p[j] += p_lobe[l][j];
    return p;
  }
};

// A vertex's scattering along one direction pair (the sampled one, or towards a light sample),
// split by lobe kind, per wavelength, with the path's f and density before it.
struct LobeScatter {
  std::array<SpectralValues, 3> f{}, pdf{};  // f |cos| and pdf of each lobe kind (a Dirac lobe's weights)
  std::array<float, 3> cpdf{};               // Cycles' closure-choice density of each kind (RGB: Bsdf::closure_pdf)
  SpectralValues F{}, P{};                   // the path's f and density before the vertex
  float rr = 1;                              // roulette's survival after it (the BSDF strategy's)
  uint8_t lobe = kAllLobes;                  // the lobe sampled (a BSDF ray's kind; next-event estimation: all)

  // Restricts event e, made with the whole BSDF and the emission Le (per wavelength) of a light
  // visible to `vis`, to the lobes that see it, and keeps its density per lobe kind.
  void restrict(Event& e, uint8_t vis, const SpectralValues& Le, int C) const {
    e.vis = vis;
    for (int l = 0; l < 3; ++l)
      for (int j = 0; j < C; ++j) e.p_lobe[l][j] = P[j] * pdf[l][j] * rr;
    if (vis == kAllLobes) return;
    const bool seen = (vis & lobe) != 0;  // the sampled lobe sees it (next-event estimation: always)
    for (int j = 0; j < C; ++j) {
      float fv = 0, pv = 0;
      for (int l = 0; l < 3; ++l)
        if (has_lobe(vis, l)) {
          fv += f[l][j];
          pv += e.p_lobe[l][j];
        }
      e.f[j] = seen ? F[j] * fv * Le[j] : 0.0f;
      e.p_bsdf[j] = pv;
    }
  }

  // Event e, emission found by the BSDF ray from a World visible to `vis` only (lit by BSDF rays
  // only: Light::lit_by_bsdf_rays_only), made with the whole BSDF (e.f = F f Le, e.p_bsdf its
  // density), by Cycles 3.4's rule (lobe_split.h): a ray of a visible kind carries the whole f,
  // times P_C(k | wi) / P(k | wi) for the sampled lobe k. Here as an event of the path extended
  // by its lobe choice: f F Le P_C(k | wi) with density p_k (the sampled kind's share of the
  // density, per wavelength: p_lobe[k]), so the balance heuristic over wavelengths and over a
  // pair's two paths compares densities of the same lobe (e.vis: that kind alone). A Dirac lobe's
  // pair is all its kind's (P_C = P = 1). No light strategy: next-event estimation skips it.
  void world(Event& e, uint8_t vis, int C) const {
    const int k = lobe_index(lobe);
    e.vis = lobe;
    float c_all = 0;
    for (int l = 0; l < 3; ++l) c_all += cpdf[l];
    const float pc = c_all > 0 ? cpdf[k] / c_all : 0.0f;  // P_C(k | wi), Cycles' closure choice (RGB)
    for (int j = 0; j < C; ++j) {
      for (int l = 0; l < 3; ++l) e.p_lobe[l][j] = P[j] * pdf[l][j] * rr;
      e.f[j] = (vis & lobe) ? e.f[j] * pc : 0.0f;
      e.p_bsdf[j] = e.p_lobe[k][j];
      e.p_light[j] = 0.0f;
    }
  }
};

Etas etas_of(const BsdfParams& m, const Vec3& wo, bool transmission) {
  return m.type == MaterialType::Dielectric ? dielectric_etas(m.ior, wo.z, transmission) : Etas{};
}

}  // namespace

bool connectable(const Material& m) {
  switch (m.type) {
    case MaterialType::Diffuse:
    case MaterialType::Emission:
    case MaterialType::Plastic:
    case MaterialType::Principled:
    case MaterialType::Translucent:
    case MaterialType::Velvet: return true;  // a diffuse lobe (the other lobe may be smooth)
    case MaterialType::Conductor:
    case MaterialType::Clearcoat: return m.roughness >= kDefaultSpecularThreshold;
    case MaterialType::Dielectric: return !is_dispersive(m) && m.roughness >= kDefaultSpecularThreshold;
    case MaterialType::Mix:
      // By its parts' lobes (a mix made by hand, without parts, is diffuse: Bsdf::kind).
      return !m.mix_a || !m.mix_b || connectable(*m.mix_a) || connectable(*m.mix_b);
  }
  return false;
}

SpectralGradientPathTracer::SpectralGradientPathTracer(const Scene& scene, const Params& params)
    : scene_(scene),
      spectra_(scene),
      bins_(params.get<int>("bins")),
      count_(params.get<int>("wavelengths")),
      stride_(1),
      max_depth_(params.get<int>("max_depth")),
      rr_depth_(params.get<int>("rr_depth")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      delta_(params.get<double>("delta")),
      tau_(params.get<double>("tau")),
      lambda_(params.get<double>("lambda")),
      seed_(params.get<uint64_t>("seed")),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      poisson_(2, 1, 1.0) {
  check_image_size(width_, height_);  // the parameters are checked by their declarations (methods.cpp)
  stride_ = std::clamp(static_cast<int>(std::lround(delta_ * bins_)), 1, bins_ - 1);
  poisson_ = SpectralPoisson(bins_, stride_, lambda_);
  // RGB of each bin's unit integral: the bin's mean CMF (1 nm steps) through the XYZ matrix.
  const double width = double(kLambdaRange) / bins_;
  for (int j = 0; j < bins_; ++j) {
    Vec3 xyz(0, 0, 0);
    const int steps = std::max(4, static_cast<int>(width));
    for (int i = 0; i < steps; ++i)
      xyz = xyz + cie_xyz_bar(static_cast<float>(kLambdaMin + width * (j + (i + 0.5) / steps)));
    bin_rgb_.push_back(xyz_to_rgb(xyz * static_cast<float>(1.0 / (steps * cie_y_integral()))));
  }
  const size_t n = static_cast<size_t>(width_) * height_;
  primal_.assign(n * bins_, 0.0);
  rgb_.assign(n * 3, 0.0);
  gradient_.assign(n * bins_, 0.0);
  samples_.assign(n, 0);
}

namespace {

// What one sample needs of the integrator: the scene and the parameters.
struct SampleSetup {
  const Scene& scene;
  const SceneSpectra& spectra;
  int bins, C, stride, max_depth, rr_depth;
  double tau;
};

// Per-thread scratch reused from sample to sample (no allocations per sample).
struct SampleScratch {
  BasePath base;
  std::vector<Event> hit_ev, nee_ev;  // per base vertex k: emission found there, NEE from there
  std::vector<double> G;              // this sample's gradient estimates, per bin
  std::vector<float> f_max_from;      // largest base contribution from vertex k on
};

using Values = SpectralValues;
using Bins = std::array<int, kMaxWavelengths>;

// One sample of a pixel, in the order the estimator takes it: the base path at the hero
// wavelength and its rotations (trace_base), its events with their densities under both
// strategies (base_events), the primal estimate and the bound that stops offsets early
// (base_estimates), then the two offsets lambda + delta and lambda - delta (shift, OffsetPath).
class SpectralSample {
 public:
  SpectralSample(const SampleSetup& setup, Rng& rng, RayCounts& rays, SpectralGradientPathTracer::ShiftCounts& counts)
      : s_(setup), lights_(setup.scene.light_set()), C(setup.C), bin_width_(double(kLambdaRange) / setup.bins),
        rng_(rng), rays_(rays), counts_(counts), sc_(scratch()), base_(sc_.base), hit_ev_(sc_.hit_ev),
        nee_ev_(sc_.nee_ev), G_(sc_.G), f_max_from_(sc_.f_max_from),
        split_lobes_(setup.scene.lights_hidden_from_some_lobes()),
        world_rule_(lights_.environment() >= 0 && lights_.lights()[lights_.environment()].lit_by_bsdf_rays_only()) {
    // Hero wavelength and its C - 1 rotations (§3.4; C = 1 is plain §3). Each keeps its position
    // inside its bin, so lambda_j +- delta lands in bin b_j +- s.
    wl_ = SampledWavelengths::sample_uniform(rng_.uniform(), C);
    lambda_ = wl_.lambda[0];
    for (int j = 0; j < C; ++j)
      bin_[j] = std::min(s_.bins - 1, static_cast<int>((wl_.lambda[j] - kLambdaMin) / bin_width_));
  }

  void trace_base(Ray ray);
  void base_events();
  void base_estimates();
  void shift(int sign);

  // Adds the sample to the pixel's sums (primal bins I, gradient bins Gp, RGB); false (and
  // nothing added) when any estimate is NaN/Inf.
  bool add_to(double* I, double* Gp, double* rgb) const {
    bool finite = true;
    for (int j = 0; j < C; ++j) finite &= std::isfinite(primal_[j]);
    for (double g : G_) finite &= std::isfinite(g);
    if (!finite) return false;
    Vec3 xyz(0, 0, 0);
    for (int j = 0; j < C; ++j) {
      I[bin_[j]] += primal_[j];
      // The same sample with the exact CMF at lambda_j (no binning), for the primal colour.
      xyz = xyz + cie_xyz_bar(wl_.lambda[j]) * static_cast<float>(primal_[j]);
    }
    for (int j = 0; j < s_.bins; ++j) Gp[j] += G_[j];
    const RGB c = xyz_to_rgb(xyz * (1.0f / cie_y_integral()));
    for (int k = 0; k < 3; ++k) rgb[k] += c[k];
    return true;
  }

 private:
  friend struct OffsetPath;
  static SampleScratch& scratch() {
    thread_local SampleScratch s;
    return s;
  }

  // Russian roulette's survival probability after vertex k of a path whose hero throughput
  // ratio is beta (prod f |cos| / pdf, divided by the survival probabilities so far, as pbrt's
  // beta): roulette on the compensated throughput keeps survivors' weights near 1 (on the raw
  // ratio the kills compound and the few survivors carry weights 1 / prod(beta), a heavy tail).
  // The same rule gives the base's and, from the offset's own throughput, the offset's density:
  // the density a base path sampled at lambda' would have had, which eq. 10-11 need.
  float survival(size_t k, float beta) const {
    return k + 1 >= static_cast<size_t>(s_.rr_depth) ? std::min(1.0f, std::max(0.05f, beta)) : 1.0f;
  }
  // Emission reaching x_{k-1} from x_k (or from the environment) at wavelength l; `camera`: the
  // ray is a camera ray (the World's Camera switch).
  float emitted(const SurfaceHit* h, const Vec3& dir_in, float l, bool camera) const {
    if (!h) {
      const int env = lights_.environment();
      if (env < 0 || (camera && !lights_.environment_visible_to_camera())) return 0.0f;
      if (lights_.environment_textured())  // an image: this direction's colour (light_spectrum)
        return RgbSpectrum::illuminant_interpolated(lights_.environment_radiance(dir_in, camera))(l);
      return s_.spectra.light[env](l);
    }
    if (h->light < 0 || lights_.area_radiance(h->light, -dir_in).is_black()) return 0.0f;
    return s_.spectra.light[h->light](l);
  }
  // Whether the ray reaching vertex k of the base (and of an offset: it takes the base's kinds)
  // is a camera ray: the first, or one that crossed light objects only (which keep its kind).
  bool camera_ray_to(size_t k) const { return k == 0 || base_.v[k - 1].kind == 0; }
  // Solid-angle pdf with which next-event estimation from p would pick the emission found
  // along dir (at h, or the environment when h is null): the light strategy of the MIS.
  // A World lit by BSDF rays only is not sampled (trace_base).
  float light_pdf(const Vec3& p, const SurfaceHit* h, const Vec3& dir) const {
    if (!h) return world_rule_ ? 0.0f : lights_.pdf_environment(dir);
    return h->light >= 0 ? lights_.pdf_area(h->light, p, h->p, dir) : 0.0f;
  }
  // BSDF value x |cos| and pdf of a recorded scattering pair at wavelength l (of its lobes of the
  // kinds `lobes` only, for a smooth pair). The direction was chosen for the hero (or the
  // offset's hero): a smooth dispersive refraction has no density for any other wavelength.
  Scatter scatter_at(const SurfaceHit& h, float l, const Vec3& wo, const Vec3& wi, bool delta, bool transmission,
                     float uc, Vec2 u, bool hero, uint8_t lobes = kAllLobes) const {
    const Material& mat = s_.scene.material(h.material);
    if (!hero && delta && transmission && is_dispersive(mat)) return {};
    const Bsdf b = s_.scene.bsdf(monochromatic(mat, s_.spectra.albedo[h.material], h.uv, l), h);
    return delta ? delta_scatter(b, wo, wi, transmission, uc, u) : smooth_scatter(b, wo, wi, lobes);
  }
  // ---- Lights hidden from some kinds of ray (LobeScatter above) ----
  // The kinds of ray that see the emission at h (the environment's where h is null).
  uint8_t light_vis(const SurfaceHit* h) const {
    const int l = h ? h->light : lights_.environment();
    return l >= 0 ? lights_.lights()[l].visible_lobes : kAllLobes;
  }
  // s's f and pdf per lobe kind for a smooth pair (wo, wi) at vertex h, at the wavelengths lw.
  // With Cycles' closure-choice densities per kind (RGB, so the hero's BSDF gives them) for a
  // World lit by BSDF rays only (LobeScatter::world).
  void split_smooth(LobeScatter& s, const SurfaceHit& h, const Values& lw, const Vec3& wo, const Vec3& wi) const {
    for (int l = 0; l < 3; ++l)
      for (int j = 0; j < C; ++j) {
        const Scatter sc = scatter_at(h, lw[j], wo, wi, false, false, 0, {}, j == 0, static_cast<uint8_t>(kRayDiffuse << l));
        s.f[l][j] = sc.f_cos;
        s.pdf[l][j] = sc.pdf;
      }
    if (world_rule_) {
      const Material& mat = s_.scene.material(h.material);
      const Bsdf b = s_.scene.bsdf(monochromatic(mat, s_.spectra.albedo[h.material], h.uv, lw[0]), h);
      for (int l = 0; l < 3; ++l) s.cpdf[l] = b.closure_pdf(wo, wi, static_cast<uint8_t>(kRayDiffuse << l));
    }
  }
  float sum_p(const Values& a, const Values& b) const {
    float s = 0;
    for (int i = 0; i < C; ++i) s += a[i] + b[i];
    return s;
  }
  // Standard sampling of event e's I_lambda term into the gradient bins (eq. 15).
  void standard(const Event& e, int sign, const Bins& gbin) {
    const float d = sum_p(e.p_bsdf, e.p_light);
    if (!e.valid || d <= 0) return;
    for (int j = 0; j < C; ++j)
      if (e.f[j] > 0) G_[gbin[j]] += (sign > 0 ? -1.0 : 1.0) * e.f[j] / d;
  }
  // Standard-sampling share of the base events from vertex k on (its NEE included, its
  // emission only if with_hit) once an offset has failed.
  void standard_rest(size_t from, bool with_hit, int sign, const Bins& gbin) {
    for (size_t r = from; r < K_; ++r) {
      if (r > from || with_hit) standard(hit_ev_[r], sign, gbin);
      standard(nee_ev_[r], sign, gbin);
    }
  }

  const SampleSetup& s_;
  const LightSet& lights_;
  const int C;
  // What the shadow test counts in: the C wavelengths at `lambda` (the base's or an offset's).
  ShadowChannels shadow_channels(const RayState& state, const float* lambda) const {
    return {.count = C, .lambda = lambda, .state = state};
  }
  const double bin_width_;
  Rng& rng_;
  RayCounts& rays_;
  SpectralGradientPathTracer::ShiftCounts& counts_;
  SampleScratch& sc_;
  BasePath& base_;
  std::vector<Event>& hit_ev_;
  std::vector<Event>& nee_ev_;
  std::vector<double>& G_;
  std::vector<float>& f_max_from_;
  const bool split_lobes_;
  // The World is hidden from some kinds of bounce ray and lit by BSDF rays only, by Cycles'
  // rule (lobe_split.h; LobeScatter::world), not by next-event estimation.
  const bool world_rule_;
  SampledWavelengths wl_;
  float lambda_ = 0;
  Bins bin_{};
  size_t K_ = 0;     // base vertices that may emit (the escape counts as one)
  Values primal_{};  // f(x, lambda_j) / sum over strategies and wavelengths of p (eq. 3-4)
};

// ---- Base path at the hero wavelength, recorded for the shifts ----
void SpectralSample::trace_base(Ray ray) {
  const Scene& scene = s_.scene;
  BasePath& base = base_;
  base.v.clear();
  base.escaped = false;
  base.camera_ray = ray;
  float beta = 1.0f;  // hero throughput ratio, for roulette
  for (int depth = 0;; ++depth) {
    ++rays_.closest;
    const auto hit = scene.intersect(ray);
    if (!hit) {
      base.escaped = true;
      base.escape_ray = ray;
      break;
    }
    BaseVertex bv;
    bv.hit = *hit;
    bv.wo = hit->frame.to_local(-ray.d);
    base.v.push_back(bv);
    // Light Paths > Transparent reached: this surface's emission is seen and the path ends
    // (Cycles' PATH_RAY_TERMINATE_ON_NEXT_SURFACE, as paths/camera_path.h).
    if (depth + 1 >= s_.max_depth || transparent_done(scene.transparent_bounces, ray.state)) break;
    const Material& mat = scene.material(hit->material);
    if (scene.bsdf(*hit).is_black() || bv.wo.z == 0) break;
    const Bsdf b = scene.bsdf(monochromatic(mat, s_.spectra.albedo[hit->material], hit->uv, lambda_), *hit);
    BaseVertex& v = base.v.back();
    // ---- Emitter sampling (next-event estimation), shared by the offsets ----
    if (!b.is_delta() && !lights_.empty()) {
      v.nee_eligible = true;
      v.u_light = rng_.uniform();
      v.u_light2 = Vec2(rng_.uniform(), rng_.uniform());
      // A World lit by BSDF rays only is not sampled (as camera_path.h); the offsets, drawing
      // the same light with the same numbers (the choice does not depend on the point), skip it too.
      if (auto ls = lights_.sample_li(hit->p, v.u_light, v.u_light2);
          ls && ls->pdf > 0 && !ls->L.is_black() && !lights_.lights()[ls->light].lit_by_bsdf_rays_only()) {
        v.ls = *ls;
        v.nee = true;
        ++rays_.shadow;
        v.nee_T = ShadowTest(scene, nullptr).transmittance(hit->p, &hit->ng, *ls, shadow_channels(hit->ray, wl_.lambda.data()));
        v.nee_visible = !is_blocked(v.nee_T, C);
      }
    }
    // ---- BSDF sampling ----
    v.uc = rng_.uniform();
    v.u = Vec2(rng_.uniform(), rng_.uniform());
    const auto bs = b.sample(v.wo, v.uc, v.u);
    if (!bs || bs->pdf <= 0 || bs->f[0] <= 0) break;
    v.scattered = true;
    v.wi = bs->wi;
    v.delta = bs->delta;
    v.transmission = bs->transmission;
    v.pdf = bs->pdf;
    v.transparent = is_transparent_pass(*bs) && mat.transparent_shadow();
    const Vec3 wi = hit->frame.to_world(bs->wi);
    // Surfaces hidden from a kind of ray let it through (the offsets' rays take the base's
    // kind, so both paths of a pair see the same surfaces); a light object keeps the kind.
    v.kind = mat.is_pass_through() ? ray.bounce : bs->lobe;
    const bool camera = ray.camera && mat.is_pass_through();
    RayState state = mat.is_pass_through()
                         ? ray.state
                         : next_ray_state(ray.state, bs->lobe, bs->transmission, bs->delta, bs->eta);
    if (v.transparent && mat.is_pass_through() && mat.interior < 0) ++state.transparent;  // a clear pane (as camera_path.h)
    ray = Ray(offset_ray_origin(hit->p, hit->ng, wi), wi);
    ray.bounce = v.kind;
    ray.state = state;
    ray.camera = camera;
    const Scatter s = v.delta ? delta_scatter(b, v.wo, v.wi, v.transmission, v.uc, v.u) : smooth_scatter(b, v.wo, v.wi);
    beta *= s.f_cos / s.pdf;
    // Roulette by the vertex's index, as the offsets take it (survival(k, ...)), not by depth,
    // which a transparent pass does not advance.
    v.rr = mat.is_pass_through() ? 1.0f : survival(base.v.size() - 1, beta);  // a light object crossed: no roulette (as spt)
    if (v.rr < 1.0f && rng_.uniform() >= v.rr) {
      v.scattered = false;  // roulette ended the path after NEE at this vertex
      break;
    }
    beta /= v.rr;
    // A pass through a Transparent BSDF counts against Light Paths > Transparent only, not as a
    // bounce (Cycles' path_state_next; the ray's state counted it), as in every other method.
    if (v.transparent) --depth;
  }
  K_ = base.v.size() + (base.escaped ? 1 : 0);
}

// ---- Base events: emission found at vertex k (BSDF strategy) and NEE at vertex k ----
void SpectralSample::base_events() {
  const BasePath& base = base_;
  const SampledWavelengths& wl = wl_;
  const size_t K = K_;
  hit_ev_.assign(K, Event{});
  nee_ev_.assign(K, Event{});
  Values F{}, P{}, P_prev{};
  for (int j = 0; j < C; ++j) {
    F[j] = 1.0f;
    P[j] = SampledWavelengths::pdf();
  }
  Vec3 dir = base.camera_ray.d;
  float beta_k = 1.0f;
  // The last vertex that scattered the path, before the light objects (pass-through
  // surfaces) it then crossed, if any: where its BSDF ray began, NEE competes for what the ray
  // finds, and its lobes see it (NEE from there is not shadowed by light objects either).
  const BaseVertex* from = nullptr;
  LobeScatter last;  // its scattering by lobe kind (split_lobes)
  for (size_t k = 0; k < K; ++k) {
    const bool is_escape = k == base.v.size();
    const SurfaceHit* h = is_escape ? nullptr : &base.v[k].hit;
    Event& e = hit_ev_[k];
    e.valid = true;
    // NEE competes for this emission unless a Dirac lobe found it (a mix's smooth part beside
    // a rough one: NEE-eligible, yet no density to compare).
    const bool nee_competes = from && from->nee_eligible && !from->delta;
    const float pl = nee_competes ? light_pdf(from->hit.p, h, dir) : 0.0f;
    Values Le{};
    for (int j = 0; j < C; ++j) {
      Le[j] = emitted(h, dir, wl.lambda[j], camera_ray_to(k));
      e.f[j] = F[j] * Le[j];
      e.p_bsdf[j] = P[j];
      e.p_light[j] = P_prev[j] * pl;
    }
    if (split_lobes_ && !camera_ray_to(k)) {
      if (!h && world_rule_) last.world(e, light_vis(h), C);
      else last.restrict(e, light_vis(h), Le, C);
    }
    if (is_escape) break;
    const BaseVertex& v = base.v[k];
    if (v.nee) {
      Event& n = nee_ev_[k];
      n.valid = true;
      const Vec3 wi = v.hit.frame.to_local(v.ls.wi);
      const Light& light = lights_.lights()[v.ls.light];
      const RgbSpectrum spec = light_spectrum(s_.spectra, lights_, v.ls.light, v.ls.L);
      Values Ls{};
      for (int j = 0; j < C; ++j) {
        const Scatter s = scatter_at(v.hit, wl.lambda[j], v.wo, wi, false, false, 0, {}, j == 0);
        Ls[j] = v.nee_visible ? spec(wl.lambda[j]) * v.nee_T[j] : 0.0f;
        n.f[j] = F[j] * s.f_cos * Ls[j];
        n.p_light[j] = P[j] * v.ls.pdf;
        n.p_bsdf[j] = v.ls.delta ? 0.0f : P[j] * s.pdf;
      }
      // The BSDF strategy's density includes the roulette it would have applied there.
      float rr = 1.0f;
      if (!v.ls.delta) {
        const Scatter s0 = scatter_at(v.hit, wl.lambda[0], v.wo, wi, false, false, 0, {}, true);
        rr = s0.pdf > 0 ? survival(k, beta_k * s0.f_cos / s0.pdf) : 1.0f;
        for (int j = 0; j < C; ++j) n.p_bsdf[j] *= rr;
      }
      if (split_lobes_) {  // f_V and p_V of the light's kinds (no sampled lobe to check)
        LobeScatter ns;
        ns.F = F;
        ns.P = P;
        ns.rr = rr;
        split_smooth(ns, v.hit, wl.lambda, v.wo, wi);
        if (v.ls.delta) ns.pdf = {};  // a Dirac light: no BSDF strategy
        ns.restrict(n, light.visible_lobes, Ls, C);
      }
    }
    if (!v.scattered) break;
    const bool crossing = s_.scene.material(v.hit.material).is_pass_through() || v.transparent;
    if (!crossing) {
      from = &v;
      P_prev = P;
    }
    if (split_lobes_ && !crossing) {
      last = LobeScatter{};
      last.F = F;
      last.P = P;
      last.rr = v.rr;
      last.lobe = v.kind;
      if (!v.delta) split_smooth(last, v.hit, wl.lambda, v.wo, v.wi);
    }
    float f0 = 0, p0 = 0;
    for (int j = 0; j < C; ++j) {
      const Scatter s = scatter_at(v.hit, wl.lambda[j], v.wo, v.wi, v.delta, v.transmission, v.uc, v.u, j == 0);
      if (v.transparent) {  // the densities stay those of the vertex before (as NEE's from there)
        F[j] *= s.pdf > 0 ? s.f_cos / (s.pdf * v.rr) : 0.0f;
      } else {
        F[j] *= s.f_cos;
        P[j] *= s.pdf * v.rr;
      }
      if (j == 0) f0 = s.f_cos, p0 = s.pdf;
      if (split_lobes_ && v.delta && v.kind != 0) {  // a Dirac pair is all its lobe's
        last.f[lobe_index(v.kind)][j] = s.f_cos;
        last.pdf[lobe_index(v.kind)][j] = s.pdf;
        last.cpdf[lobe_index(v.kind)] = 1.0f;
      }
    }
    beta_k *= p0 > 0 ? f0 / p0 / v.rr : 0.0f;
    dir = v.hit.frame.to_world(v.wi);
  }
}

// The primal estimate, f(x, lambda_j) / sum over strategies and wavelengths of p (eq. 3-4)
// into bin b_j, and the largest base contribution f(x) among the events from vertex k on: where
// it is <= tau, every remaining pair falls back to standard sampling whatever the offset gives
// (eq. 16 takes the smaller f of the pair), so the offset is not traced further (the cost
// saving of §3.3).
void SpectralSample::base_estimates() {
  G_.assign(s_.bins, 0.0);
  for (size_t k = 0; k < K_; ++k)
    for (const Event* e : {&hit_ev_[k], &nee_ev_[k]}) {
      const float d = sum_p(e->p_bsdf, e->p_light);
      if (e->valid && d > 0)
        for (int j = 0; j < C; ++j) primal_[j] += e->f[j] / d;
    }
  f_max_from_.assign(K_ + 1, 0.0f);
  for (size_t k = K_; k-- > 0;) {
    f_max_from_[k] = f_max_from_[k + 1];
    for (const Event* e : {&hit_ev_[k], &nee_ev_[k]})
      if (e->valid)
        for (int j = 0; j < C; ++j) f_max_from_[k] = std::max(f_max_from_[k], e->f[j]);
  }
}

// ---- One offset: lambda + delta (sign +1, the forward gradient of bin j) or lambda - delta ----
// The offset follows the base vertex by vertex (state Same), diverges at the first dispersive
// refraction (a half-vector copy, eq. 12-13), and reconnects to the base at two consecutive
// connectable vertices (Reconnected, then Same again).
struct OffsetPath {
  enum class State { Same, Reconnected, Diverged };

  OffsetPath(SpectralSample& sample, int sign) : s(sample), sign(sign) {
    for (int j = 0; j < s.C; ++j) {
      lambda2[j] = wrap_wavelength(static_cast<float>(s.wl_.lambda[j] + sign * s.s_.stride * s.bin_width_));
      gbin[j] = sign > 0 ? s.bin_[j] : (s.bin_[j] - s.s_.stride + s.s_.bins) % s.s_.bins;
      F2[j] = 1.0f;
      P2[j] = SampledWavelengths::pdf();
    }
    y_dir = s.base_.camera_ray.d;
  }

  // One pair of events (x, lambda_j), (y, lambda'_j): eq. 9-11 (C = 1) or eq. 17-18, with
  // both strategies (BSDF, light) of both paths in the balance heuristic's denominator and
  // the threshold of eq. 15-16 on the contributions f of the two paths.
  // Where the two paths meet lights seen by different kinds, each path's term has its own
  // denominator: both paths' densities through the lobes that see its light (LobeScatter).
  void pair(const Event& x, const Event& y, float Jy) {
    const int C = s.C;
    const float dx = s.sum_p(x.p_bsdf, x.p_light);
    float denom = dx;  // sum_k p(x, lambda_k) + p(y, lambda'_k) |S'|
    for (int i = 0; i < C; ++i) denom += (y.p_bsdf[i] + y.p_light[i]) * Jy;
    float denom_x = denom, denom_y = denom;  // of x's term and of y's
    if (x.vis != y.vis) {
      const Values py = y.p_bsdf_in(x.vis, C), px = x.p_bsdf_in(y.vis, C);
      denom_x = dx;
      denom_y = s.sum_p(px, x.p_light);
      for (int i = 0; i < C; ++i) {
        denom_x += (py[i] + y.p_light[i]) * Jy;
        denom_y += (y.p_bsdf[i] + y.p_light[i]) * Jy;
      }
    }
    for (int j = 0; j < C; ++j) {
      if (!(x.f[j] > 0 || y.f[j] > 0)) continue;
      if (std::min(x.f[j], y.f[j]) > s.s_.tau && denom_x > 0 && denom_y > 0) {  // w^s = 1, eq. 16 (f, not f / p)
        // w (f(y)|S'| - f(x)) / p(x), eq. 10 / 18
        const float g = denom_x == denom_y ? (y.f[j] * Jy - x.f[j]) / denom : y.f[j] * Jy / denom_y - x.f[j] / denom_x;
        s.G_[gbin[j]] += sign > 0 ? g : -g;
        ++s.counts_.shifted;
      } else if (dx > 0) {
        const float cx = x.f[j] / dx;  // standard sampling of the I_lambda term (eq. 15)
        s.G_[gbin[j]] += sign > 0 ? -cx : cx;
        ++s.counts_.below_tau;
      }
    }
  }

  // Where no base event from vertex k on has f > tau: w^s = 0 for every remaining pair (eq. 16),
  // so they are standard sampling and the offset stops; true if so.
  bool below_tau_from(size_t k) {
    if (s.f_max_from_[k] > s.s_.tau) return false;
    for (size_t r = k; r < s.K_; ++r)
      for (const Event* e : {&s.hit_ev_[r], &s.nee_ev_[r]})
        if (e->valid)
          for (int j = 0; j < s.C; ++j) s.counts_.below_tau += e->f[j] > 0;
    s.standard_rest(k, true, sign, gbin);
    return true;
  }

  // Offset vertex k's emission, paired with the base's emission found at x_k.
  void emission(size_t k) {
    const bool is_escape = k == s.base_.v.size();
    const SurfaceHit* yk = nullptr;
    if (state == State::Same || state == State::Reconnected) {
      yk = is_escape ? nullptr : &s.base_.v[k].hit;
      if (state == State::Same) wo_y = is_escape ? Vec3() : s.base_.v[k].wo;
    } else {
      yk = y_escaped ? nullptr : &*y;
    }
    Event ey;
    Values Le{};
    const float l_pdf = (k > 0 && y_prev_nee) ? s.light_pdf(y_prev_p, yk, y_dir) : 0.0f;
    for (int j = 0; j < s.C; ++j) {
      Le[j] = s.emitted(yk, y_dir, lambda2[j], s.camera_ray_to(k));
      ey.f[j] = F2[j] * Le[j];
      ey.p_bsdf[j] = P2[j];
      ey.p_light[j] = P2_prev[j] * l_pdf;
    }
    // The offset's light weighed by the lobes that see it at its own vertex (the base's lobe sampled).
    if (s.split_lobes_ && !s.camera_ray_to(k)) {
      if (!yk && s.world_rule_) y_last.world(ey, s.light_vis(yk), s.C);
      else y_last.restrict(ey, s.light_vis(yk), Le, s.C);
    }
    pair(s.hit_ev_[k], ey, J);
  }

  // The offset's vertex k: its surface (the base's until diverged) and BSDF at lambda'.
  struct Vertex {
    const BaseVertex& x;
    const SurfaceHit& yh;
    const Material& mat_y;
    BsdfParams my;
    bool y_delta;  // the offset hero's BSDF there is a Dirac one
    bool y_nee;    // next-event estimation is possible there
  };
  Vertex vertex(size_t k) const {
    const BaseVertex& x = s.base_.v[k];
    const SurfaceHit& yh = (state == State::Diverged) ? *y : x.hit;
    const Material& mat_y = s.s_.scene.material(yh.material);
    const BsdfParams my = monochromatic(mat_y, s.s_.spectra.albedo[yh.material], yh.uv, lambda2[0]);
    const bool y_delta = s.s_.scene.bsdf(my, yh).is_delta();
    const bool y_nee = x.nee_eligible && !y_delta && !s.s_.scene.bsdf(yh).is_black() && wo_y.z != 0;
    return {x, yh, mat_y, my, y_delta, y_nee};
  }

  // ---- NEE of the offset: the same light sample (point on an area light, direction of a
  // distant one), reconnected from y_k; Jacobian as a reconnection (KMA15 §5.2) ----
  void next_event(size_t k, const Vertex& v) {
    const BaseVertex& x = v.x;
    const SurfaceHit& yh = v.yh;
    const LightSet& lights = s.lights_;
    const int C = s.C;
    Event ey;
    float Jz = 1.0f;
    // Where the base's light sample gives f(x) <= tau at every wavelength the pair is
    // standard whatever the offset gives (eq. 16): no shadow ray for the offset.
    bool needed = false;
    for (int j = 0; j < C; ++j) needed |= s.nee_ev_[k].f[j] > s.s_.tau;
    if (v.y_nee && needed) {
      std::optional<LightSample> ls = x.ls;
      bool visible = x.nee_visible;
      // The offset's transmittance at its own wavelengths: through the base's shadow ray while
      // the paths share their vertices (its transparent surfaces' colours seen at lambda2; the
      // base's visibility where the scene has none), along its own after they diverge.
      ChannelValues T{};
      const ShadowTest shadow(s.s_.scene, nullptr);
      if (visible && state != State::Diverged) {
        if (s.s_.scene.has_transparent_shadows())
          T = shadow.transmittance(yh.p, &yh.ng, *ls, s.shadow_channels(yh.ray, lambda2.data()));
        else
          T.fill(1.0f);
        visible = !is_blocked(T, C);
      }
      if (state == State::Diverged) {
        ls = lights.sample_li(yh.p, x.u_light, x.u_light2);  // same u: same point / direction
        visible = false;
        if (ls && ls->pdf > 0 && !ls->L.is_black()) {
          ++s.rays_.shadow;
          T = shadow.transmittance(yh.p, &yh.ng, *ls, s.shadow_channels(yh.ray, lambda2.data()));
          visible = !is_blocked(T, C);
          if (lights.lights()[ls->light].type == LightType::Area)
            Jz = reconnection_jacobian<float>(x.hit.p, yh.p, ls->p, ls->n);
        }
      }
      if (ls && visible && ls->pdf > 0) {
        const Vec3 wi = yh.frame.to_local(ls->wi);
        const RgbSpectrum spec = light_spectrum(s.s_.spectra, lights, ls->light, ls->L);
        Scatter s0{};
        Values Ls{};
        for (int j = 0; j < C; ++j) {
          const Scatter sc = s.scatter_at(yh, lambda2[j], wo_y, wi, false, false, 0, {}, j == 0);
          if (j == 0) s0 = sc;
          Ls[j] = spec(lambda2[j]) * T[j];
          ey.f[j] = F2[j] * sc.f_cos * Ls[j];
          ey.p_light[j] = P2[j] * ls->pdf;
          ey.p_bsdf[j] = ls->delta ? 0.0f : P2[j] * sc.pdf;
        }
        const float rr = ls->delta || !(s0.pdf > 0) ? 1.0f : s.survival(k, beta2 * s0.f_cos / s0.pdf);
        for (int j = 0; j < C; ++j) ey.p_bsdf[j] *= rr;
        if (s.split_lobes_) {  // f_V and p_V of its light's kinds, at the offset's own vertex
          LobeScatter ns;
          ns.F = F2;
          ns.P = P2;
          ns.rr = rr;
          s.split_smooth(ns, yh, lambda2, wo_y, wi);
          if (ls->delta) ns.pdf = {};
          ns.restrict(ey, lights.lights()[ls->light].visible_lobes, Ls, C);
        }
      }
    }
    pair(s.nee_ev_[k], ey, J * Jz);
  }

  // ---- Scatter: the offset's outgoing direction at its vertex k (hero geometry), its BSDF
  // and roulette, and its vertex k + 1. False when the shift failed there (the rest of the
  // base's events are then standard sampling). ----
  bool scatter(size_t k, const Vertex& v) {
    const BaseVertex& x = v.x;
    const SurfaceHit& yh = v.yh;
    const int C = s.C;
    const Scene& scene = s.s_.scene;
    const Material& mat_x = scene.material(x.hit.material);
    const BsdfParams mx = monochromatic(mat_x, s.s_.spectra.albedo[x.hit.material], x.hit.uv, s.lambda_);
    Vec3 wi_y;  // local at the offset vertex
    bool ok = true, diverge_now = false, reconnect_now = false;
    bool delta_y = x.delta;  // the lobe the offset follows: the base's
    auto fail = [&](ShiftFailure why) {
      ok = false;
      s.counts_.fail(why);
    };
    if (state == State::Same || state == State::Reconnected) {
      if (is_dispersive(mat_x) && x.transmission) {
        // First wavelength-dependent interaction: copy the generalised half vector (eq. 12).
        const Etas e = etas_of(mx, x.wo, true), e2 = etas_of(v.my, wo_y, true);
        const auto h = half_vector(x.wo, x.wi, e, true);
        const auto wi2 = h ? copy_half_vector(wo_y, *h, e2, true) : std::nullopt;
        if (!wi2) {
          fail(ShiftFailure::TotalInternalReflection);
        } else {
          wi_y = *wi2;
          if (!x.delta) J *= half_vector_jacobian(x.wo, x.wi, e, wo_y, wi_y, e2, *h, true);  // eq. 13
          diverge_now = true;
        }
      } else {
        wi_y = x.wi;  // wavelength-independent direction: the offset follows the base
      }
    } else {  // Diverged
      // The base's continuation from x_{k+1} must be a lobe the offset can evaluate from its
      // new direction: not a Dirac one (a plastic's or principled's smooth coat).
      const std::vector<BaseVertex>& bv = s.base_.v;
      const bool next_connectable = k + 1 < bv.size() && !bv[k + 1].delta && connectable(scene.material(bv[k + 1].hit.material));
      if (connectable(mat_x) && connectable(v.mat_y) && next_connectable && !x.delta) {
        // ---- Reconnection to x_{k+1} ----
        const BaseVertex& xn = bv[k + 1];
        ++s.rays_.shadow;
        if (scene.hides_between(yh.p, yh.ng, xn.hit.p, xn.hit.ng, x.kind)) {
          fail(ShiftFailure::Occluded);
        } else {
          const Vec3 d = normalize(xn.hit.p - yh.p);
          wi_y = yh.frame.to_local(d);
          J *= reconnection_jacobian<float>(x.hit.p, yh.p, xn.hit.p, xn.hit.ng);
          reconnect_now = true;
          delta_y = false;
        }
      } else {
        // ---- Half-vector copy at the offset's own vertex ----
        if (v.y_delta != x.delta || (x.transmission && v.my.type != MaterialType::Dielectric)) {
          fail(ShiftFailure::NotInvertible);  // the vertex kinds differ
        } else {
          const Etas e = etas_of(mx, x.wo, x.transmission), e2 = etas_of(v.my, wo_y, x.transmission);
          const auto h = half_vector(x.wo, x.wi, e, x.transmission);
          const auto wi2 = h ? copy_half_vector(wo_y, *h, e2, x.transmission) : std::nullopt;
          if (!wi2) {
            fail(ShiftFailure::TotalInternalReflection);
          } else {
            wi_y = *wi2;
            if (!x.delta) J *= half_vector_jacobian(x.wo, x.wi, e, wo_y, wi_y, e2, *h, x.transmission);
          }
        }
      }
    }
    // The offset's BSDF at each of its wavelengths along the chosen direction.
    std::array<Scatter, kMaxWavelengths> s2{};
    if (ok)
      for (int j = 0; j < C; ++j)
        s2[j] = s.scatter_at(yh, lambda2[j], wo_y, wi_y, delta_y, x.transmission && !reconnect_now, x.uc, x.u, j == 0);
    if (!ok || s2[0].pdf <= 0 || !(J > 0) || !std::isfinite(J)) {
      if (ok) s.counts_.fail(ShiftFailure::NotInvertible);  // no density for the base's lobe
      s.standard_rest(k + 1, true, sign, gbin);
      return false;
    }
    // The offset's own roulette survival (eq. 10-11 need its density as a base path).
    beta2 *= s2[0].f_cos / s2[0].pdf;
    const bool crossing = v.mat_y.is_pass_through();  // a light object: as the base, no roulette
    // Through a Transparent BSDF where the base passed one (the same surface while the paths
    // share vertices): crossed for MIS as the base's (BaseVertex::transparent).
    const bool transparent = x.transparent && delta_y && x.transmission;
    const float rr2 = crossing ? 1.0f : s.survival(k, beta2);
    beta2 /= rr2;
    if (s.split_lobes_ && !crossing && !transparent) {  // along the base's lobe, from the offset's own vertex
      y_last = LobeScatter{};
      y_last.F = F2;
      y_last.P = P2;
      y_last.rr = rr2;
      y_last.lobe = x.kind;
      if (!delta_y) {
        s.split_smooth(y_last, yh, lambda2, wo_y, wi_y);
      } else if (x.kind != 0) {  // a Dirac pair is all its lobe's
        for (int j = 0; j < C; ++j) {
          y_last.f[lobe_index(x.kind)][j] = s2[j].f_cos;
          y_last.pdf[lobe_index(x.kind)][j] = s2[j].pdf;
        }
        y_last.cpdf[lobe_index(x.kind)] = 1.0f;
      }
    }
    if (!crossing && !transparent) {  // the vertex whose BSDF ray the next events come from (as the base's `from`)
      P2_prev = P2;
      y_prev_p = yh.p;
      y_prev_nee = v.y_nee && !delta_y;  // as nee_competes in base_events
    }
    for (int j = 0; j < C; ++j) {
      if (transparent) {
        F2[j] *= s2[j].pdf > 0 ? s2[j].f_cos / (s2[j].pdf * rr2) : 0.0f;
      } else {
        F2[j] *= s2[j].f_cos;
        P2[j] *= s2[j].pdf * rr2;
      }
    }
    if (state == State::Reconnected) state = State::Same;
    // ---- Next offset vertex ----
    if (reconnect_now) {
      const BaseVertex& xn = s.base_.v[k + 1];
      state = State::Reconnected;
      y_dir = normalize(xn.hit.p - yh.p);
      wo_y = xn.hit.frame.to_local(-y_dir);
      y.reset();
    } else if (state == State::Same && !diverge_now) {
      y_dir = x.hit.frame.to_world(x.wi);
    } else {  // diverged (now or before): trace the offset's own ray
      const Vec3 d = yh.frame.to_world(wi_y);
      Ray r(offset_ray_origin(yh.p, yh.ng, d), d);
      r.bounce = x.kind;
      ++s.rays_.closest;
      y = scene.intersect(r);
      y_dir = d;
      y_escaped = !y;
      if (y) wo_y = y->frame.to_local(-d);
      state = State::Diverged;
      // If the base ends in an escape at k + 1 while the offset hit something, the pair's
      // last event is the offset's emission at its hit, evaluated at the top of the loop.
    }
    return true;
  }

  SpectralSample& s;
  const int sign;
  Values lambda2{};
  Bins gbin{};  // G_gbin = I_{gbin+s} - I_gbin
  State state = State::Same;
  Values F2{}, P2{}, P2_prev{};
  LobeScatter y_last;  // the offset's previous vertex's scattering by lobe kind (split_lobes)
  float J = 1.0f, beta2 = 1.0f;
  std::optional<SurfaceHit> y;     // the offset's own vertex while diverged
  Vec3 wo_y;                       // offset's local wo at its current vertex
  Vec3 y_dir;                      // direction of the ray that reached the offset vertex
  Vec3 y_prev_p;                   // the offset's previous vertex
  bool y_prev_nee = false;         // ... and whether NEE was possible there
  bool y_escaped = false;
};

void SpectralSample::shift(int sign) {
  OffsetPath o(*this, sign);
  ++counts_.attempts;
  for (size_t k = 0; k < K_; ++k) {
    if (o.below_tau_from(k)) break;
    o.emission(k);
    if (k == base_.v.size()) break;  // the base escaped at k
    if (o.state == OffsetPath::State::Diverged && o.y_escaped) {  // the offset left the scene, the base did not
      counts_.fail(ShiftFailure::Missed);
      standard_rest(k, false, sign, o.gbin);
      break;
    }
    const OffsetPath::Vertex v = o.vertex(k);
    if (v.x.nee) o.next_event(k, v);
    if (!v.x.scattered) break;
    if (!o.scatter(k, v)) break;
  }
}

}  // namespace

bool SpectralGradientPathTracer::sample_pixel(size_t pixel, Rng& rng, Ray ray, RayCounts& rays,
                                              ShiftCounts& counts) {
  const SampleSetup setup{scene_, spectra_, bins_, count_, stride_, max_depth_, rr_depth_, tau_};
  SpectralSample sample(setup, rng, rays, counts);
  sample.trace_base(ray);
  sample.base_events();
  sample.base_estimates();
  for (int sign : {+1, -1}) sample.shift(sign);
  return sample.add_to(&primal_[pixel * bins_], &gradient_[pixel * bins_], &rgb_[3 * pixel]);
}

void SpectralGradientPathTracer::iterate(ProgressSink* sink) {
  const auto start = std::chrono::steady_clock::now();
  const uint64_t pass = static_cast<uint64_t>(stats_.passes);
  std::atomic<int64_t> closest{0}, shadow{0}, paths{0}, invalid{0};
  std::mutex counts_mutex;
  parallel_for_tiles(
      width_, height_, tile_size_, threads_,
      [&](const Tile& tile) {
        RayCounts tile_rays;
        ShiftCounts tc;
        int64_t tile_paths = 0;
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x) {
            const size_t pixel = static_cast<size_t>(y) * width_ + x;
            auto [rng, film, lens, time] = start_pixel(scene_.camera, seed_, pass, x, y);
            // Motion blur: the base path and its offsets at the base's shutter time (core/math.h).
            const ShutterTime at_time(time);
            if (!sample_pixel(pixel, rng, scene_.camera.generate_ray(film, lens), tile_rays, tc)) ++invalid;
            ++samples_[pixel];
            ++tile_paths;
          }
        closest += tile_rays.closest;
        shadow += tile_rays.shadow;
        paths += tile_paths;
        std::lock_guard<std::mutex> lock(counts_mutex);
        counts_.attempts += tc.attempts;
        counts_.shifted += tc.shifted;
        counts_.below_tau += tc.below_tau;
        for (int k = 0; k < kShiftFailureCount; ++k) counts_.failed[k] += tc.failed[k];
      },
      [sink] { return sink && sink->cancelled(); });
  stats_.invalid_samples += invalid;
  stats_.passes += 1;
  stats_.rays += closest + shadow;
  stats_.shadow_rays += shadow;
  stats_.paths += paths;
  stats_.extra["shift attempts"] = static_cast<double>(counts_.attempts);
  stats_.extra["shifted pairs"] = static_cast<double>(counts_.shifted);
  stats_.extra["standard pairs"] = static_cast<double>(counts_.below_tau);
  for (int k = 1; k < kShiftFailureCount; ++k)
    if (counts_.failed[k] > 0)
      stats_.extra[std::string(failure_stat_name(static_cast<ShiftFailure>(k)))] = static_cast<double>(counts_.failed[k]);
  stats_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void SpectralGradientPathTracer::image_totals(std::vector<double>* primal, std::vector<double>* gradient, int x0,
                                              int y0, int x1, int y1) const {
  primal->assign(bins_, 0.0);
  gradient->assign(bins_, 0.0);
  if (x1 < 0) x1 = width_;
  if (y1 < 0) y1 = height_;
  const double n = double(std::max(0, x1 - x0)) * std::max(0, y1 - y0);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const size_t i = static_cast<size_t>(y) * width_ + x;
      const double w = samples_[i] ? 1.0 / (samples_[i] * n) : 0.0;
      for (int j = 0; j < bins_; ++j) {
        (*primal)[j] += primal_[i * bins_ + j] * w;
        (*gradient)[j] += gradient_[i * bins_ + j] * w;
      }
    }
}

RGB SpectralGradientPathTracer::bins_to_rgb(const double* b) const {
  RGB c(0.0f);
  for (int j = 0; j < bins_; ++j) c += bin_rgb_[j] * static_cast<float>(b[j]);
  return c;
}

void SpectralGradientPathTracer::develop(Film& film) const {
  if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
  Pass& combined = film.add_pass(pass::kCombined, 3);
  Pass& primal = film.add_pass(pass::kSpectralPrimal, 3);
  Pass& grad = film.add_pass(pass::kSpectralGradient, 1);
  std::vector<double> I(bins_), G(bins_);
  for (size_t i = 0; i < samples_.size(); ++i) {
    const double inv = samples_[i] ? 1.0 / samples_[i] : 0.0;
    double g2 = 0;
    bool finite = true;
    for (int j = 0; j < bins_; ++j) {
      I[j] = primal_[i * bins_ + j] * inv;
      G[j] = gradient_[i * bins_ + j] * inv;
      g2 += G[j] * G[j];
      finite &= std::isfinite(I[j]) && std::isfinite(G[j]);
    }
    if (!finite) std::fill(G.begin(), G.end(), 0.0);
    std::vector<double> rec = poisson_.solve(I, G);  // eq. 14
    // The reconstruction is linear and unbiased, so its correction rec - I has zero mean: it
    // is added (at bin resolution) to the primal colour computed with the exact CMFs, which
    // keeps the binning out of the expected colour.
    for (int j = 0; j < bins_; ++j) rec[j] -= I[j];
    const RGB p(static_cast<float>(rgb_[3 * i] * inv), static_cast<float>(rgb_[3 * i + 1] * inv),
                static_cast<float>(rgb_[3 * i + 2] * inv));
    const RGB c = p + bins_to_rgb(rec.data());
    for (int k = 0; k < 3; ++k) {
      combined.data[3 * i + k] = c[k];
      primal.data[3 * i + k] = p[k];
    }
    grad.data[i] = static_cast<float>(std::sqrt(g2 / bins_));
  }
}

}  // namespace gp
