#include "integrators/photon/progressive_photon.h"

#include <atomic>
#include <chrono>

#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/photon/photon_estimate.h"
#include "materials/bsdf.h"

namespace gp {

namespace {
using clock_type = std::chrono::steady_clock;
}  // namespace

ProgressivePhotonMapping::ProgressivePhotonMapping(const Scene& scene, const Params& params, bool retrace, bool nee,
                                                   const std::string& default_sampler, bool allow_spectral)
    : scene_(scene),
      retrace_(retrace),
      nee_(nee),
      alpha_(params.get<double>("alpha", 0.7)),
      radius_(params.get<double>("radius", 0.0)),
      footprint_pixels_(params.get<double>("footprint", 2.0)),
      confidence_(params.get<double>("confidence", 0.5)),
      photons_per_pass_(params.get<int64_t>("photons", 100000)),
      max_depth_(params.get<int>("max_depth", 32)),
      rr_depth_(params.get<int>("rr_depth", 3)),
      threads_(params.get<int>("threads", 0)),
      tile_size_(params.get<int>("tile_size", 16)),
      threshold_(params.get<float>("specular_threshold", kDefaultSpecularThreshold)),
      seed_(params.get<uint64_t>("seed", 0)),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      tracer_(scene, max_depth_, threshold_, seed_, threads_) {
  const std::string hash = params.get<std::string>("hash", "exact");
  if (hash == "exact") hash_mode_ = PhotonHashMode::Exact;
  else if (hash == "stochastic") hash_mode_ = PhotonHashMode::Stochastic;
  else throw ParamError("parameter 'hash' must be 'exact' or 'stochastic' (got '" + hash + "')");
  const std::string sampler = params.get<std::string>("photon_sampler", default_sampler);
  if (sampler == "adaptive") {
    const int chains = params.get<int>("chains", 64);
    if (chains < 1) throw ParamError("parameter 'chains' must be at least 1");
    adaptive_ = std::make_unique<AdaptivePhotonSampler>(tracer_, chains, seed_);
  } else if (sampler != "uniform") {
    throw ParamError("parameter 'photon_sampler' must be 'uniform' or 'adaptive' (got '" + sampler + "')");
  }
  if (!(alpha_ > 0 && alpha_ < 1)) throw ParamError("parameter 'alpha' must be in (0, 1)");
  if (!(radius_ >= 0) || !std::isfinite(radius_)) throw ParamError("parameter 'radius' must be >= 0 (0 = from the pixel footprint)");
  if (!(footprint_pixels_ > 0) || !std::isfinite(footprint_pixels_))
    throw ParamError("parameter 'footprint' must be > 0 (pixels)");
  if (!(confidence_ > 0 && confidence_ < 1)) throw ParamError("parameter 'confidence' must be in (0, 1)");
  if (photons_per_pass_ < 1) throw ParamError("parameter 'photons' must be at least 1");
  check_common_params(max_depth_, rr_depth_, threads_, tile_size_, width_, height_);
  if (!(threshold_ >= 0)) throw ParamError("parameter 'specular_threshold' must be >= 0");
  const size_t n = static_cast<size_t>(width_) * height_;
  px_.assign(n, PixelState{});
  vp_.assign(n, VisiblePoint{});
  pass_direct_.assign(n, RGB(0.0f));
  pass_covered_.assign(n, 1);
  first_r_.assign(n, 0.0f);
  gather_m_.assign(n, 0.0f);
  gather_lap_.assign(n, 0.0f);
  gather_phi_.assign(n, RGB(0.0f));
  error_.assign(n, 0.0f);
  if (allow_spectral && !adaptive_ &&
      use_spectral(parse_spectral_mode(params.get<std::string>("spectral", "auto")), scene)) {
    spectral_ = true;
    spectra_ = std::make_unique<SceneSpectra>(scene);
    const int c = params.get<int>("wavelengths", 4);
    if (c < 1 || c > kMaxWavelengths) throw ParamError("wavelengths must be in 1.." + std::to_string(kMaxWavelengths));
    wl_.count = c;
    stats_.extra["spectral wavelengths"] = c;  // the CLI lists it: this run used spectral photons
    vp_beta_.assign(n, SpectralValues{});
    vp_hero_.assign(n, 0);
  }
  if (scene.light_set().empty())
    stats_.extra["warning: no lights"] = 1;  // the image is black; reported, never a hang
}

RGB direct_light(const Scene& scene, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo, float u_light,
                 const Vec2& u2, int64_t& rays) {
  const auto ls = scene.light_set().sample_li(hit.p, u_light, u2);
  if (!ls || !(ls->pdf > 0) || ls->L.is_black()) return RGB(0.0f);
  const Vec3 wi = hit.frame.to_local(ls->wi);
  const RGB f = bsdf.eval(wo, wi) * std::abs(wi.z);
  if (f.is_black()) return RGB(0.0f);
  ++rays;
  return scene.occluded(hit.p, hit.ng, *ls) ? RGB(0.0f) : f * ls->L / ls->pdf;
}

// ---- Eye pass: one camera path per pixel to its measurement point ----
void ProgressivePhotonMapping::eye_pass(uint64_t pass, ProgressSink* sink, std::atomic<int64_t>& rays_out,
                                        std::atomic<int64_t>& invalid_out) {
  parallel_for_tiles(
      width_, height_, tile_size_, threads_,
      [&](const Tile& tile) {
        int64_t rays = 0, invalid = 0;
        EyePathHooks none;
        // The tile's camera rays are traced together (Embree packets: the same hits, several
        // times faster than one by one), then each path goes on alone from its first hit.
        std::vector<PixelStart> starts;
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x) starts.push_back(start_pixel(scene_.camera, seed_, pass, x, y));
        std::vector<Ray> camera(starts.size());
        std::vector<std::optional<SurfaceHit>> hits(starts.size());
        trace_camera_rays(scene_, starts.data(), starts.size(), camera.data(), hits.data());
        const Vec2 ext = scene_.camera.half_extent();
        size_t k = 0;
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x, ++k) {
            const size_t pixel = static_cast<size_t>(y) * width_ + x;
            EyePath path = trace_eye_path(camera[k], starts[k].rng, rays, none, &hits[k]);
            if (!path.Ld.is_finite()) {
              ++invalid;
              path.Ld = RGB(0.0f);
            }
            if (path.vp.material >= 0 && !path.vp.beta.is_finite()) {
              ++invalid;
              path.vp.material = -1;
            }
            pass_direct_[pixel] = path.Ld;
            pass_covered_[pixel] = path.escaped ? 0 : 1;
            vp_[pixel] = path.vp;
            first_r_[pixel] = path.vp.material >= 0 ? footprint_radius(path.path_length, ext) : 0.0f;
          }
        rays_out += rays;
        invalid_out += invalid;
      },
      [sink] { return sink && sink->cancelled(); });
}

void ProgressivePhotonMapping::iterate(ProgressSink* sink) {
  const auto start = clock_type::now();
  const uint64_t pass = static_cast<uint64_t>(stats_.passes);
  const size_t n_pixels = px_.size();
  std::atomic<int64_t> rays{0}, invalid{0};

  // ---- Measurement points (every pass for SPPM, once for PPM) ----
  const auto t_eye = clock_type::now();
  if (spectral_) {
    wl_ = pass_wavelengths(pass);
    for (int k = 0; k < wl_.count; ++k) {
      SpectralValues e{};
      e[k] = 1.0f;
      wl_basis_[k] = sample_to_rgb(e, wl_);
    }
  }
  if (retrace_ || !have_points_) {
    if (spectral_) spectral_eye_pass(pass, sink, rays, invalid);
    else eye_pass(pass, sink, rays, invalid);
    if (sink && sink->cancelled()) return;  // abandoned pass: statistics untouched
    have_points_ = true;
    const float min_r = 1e-5f * std::max(1e-3f, length(scene_.bounds().diagonal()));
    for (size_t i = 0; i < n_pixels; ++i)
      if (px_[i].r2 == 0 && vp_[i].material >= 0) {
        const double r = radius_ > 0 ? radius_ : std::max(first_r_[i], min_r);
        px_[i].r2 = r * r;
      }
  }
  stats_.extra["eye seconds"] += seconds_since(t_eye);

  // ---- Photon pass ----
  const auto t_trace = clock_type::now();
  const std::function<bool()> cancelled = [sink] { return sink && sink->cancelled(); };
  PhotonPassStats ps;
  if (adaptive_) {
    // ---- Adaptive MCMC photon tracing (thesis ch. 8): V(u) against this pass's points ----
    visibility_points_.clear();
    for (size_t i = 0; i < n_pixels; ++i)
      if (vp_[i].material >= 0)
        visibility_points_.push_back({vp_[i].p, vp_[i].frame.n, vp_[i].wo.z, static_cast<float>(std::sqrt(px_[i].r2))});
    visibility_.build(visibility_points_, threads_);
    if (cancelled()) return;  // the grid of 2 M points at 1080p takes a few hundred ms
    ps = adaptive_->trace(photons_per_pass_, pass, nee_ ? 1 : 0, visibility_, photons_, cancelled);
  } else if (spectral_) {
    ps = spectral_trace(pass, cancelled);
  } else {
    ps = tracer_.trace(photons_per_pass_, pass, nee_ ? 1 : 0, photons_, nullptr, nullptr, cancelled);
  }
  stats_.extra["trace seconds"] += seconds_since(t_trace);
  if (sink && sink->cancelled()) return;

  // ---- Lookup: hash grid of this pass's photons, gathered by every measurement point ----
  const auto t_lookup = clock_type::now();
  double max_r2 = 0;
  for (size_t i = 0; i < n_pixels; ++i)
    if (vp_[i].material >= 0) max_r2 = std::max(max_r2, px_[i].r2);
  const float max_r = static_cast<float>(std::sqrt(max_r2));
  const bool have_photons = !photons_.empty() && max_r > 0;
  if (have_photons) grid_.build(photons_, 2.0f * max_r, hash_mode_, seed_, pass, threads_);  // §10.2.2
  if (cancelled()) return;
  if (spectral_) spectral_gather(cancelled);
  else parallel_for(n_pixels, threads_, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i) {
      if (i % kCancelPollPixels == 0 && cancelled()) return;  // abandoned pass: checked below
      gather_m_[i] = 0;
      gather_lap_[i] = 0;
      gather_phi_[i] = RGB(0.0f);
      const VisiblePoint& vp = vp_[i];
      if (!have_photons || vp.material < 0) continue;
      const Bsdf bsdf(scene_.material(vp.material));
      const float R = static_cast<float>(std::sqrt(px_[i].r2));
      double m = 0, lap = 0;
      RGB phi(0.0f);
      grid_.query(vp.p, R, [&](const Photon& ph, float d2, float weight) {
        const Vec3 wi = vp.frame.to_local(ph.wi);
        if (!same_hemisphere(vp.wo, wi)) return;  // the far side of a thin wall
        m += weight;
        const RGB contrib = vp.beta * bsdf.eval(vp.wo, wi) * ph.power * weight;  // eq. 5.11 / 7.4
        phi += contrib;
        lap += contrib.luminance() * error_kernel::laplacian(d2, R);  // §6.4, eq. 6.31 (2nd order)
      });
      gather_m_[i] = static_cast<float>(m);
      gather_lap_[i] = static_cast<float>(lap);
      gather_phi_[i] = phi;
    }
  });
  stats_.extra["lookup seconds"] += seconds_since(t_lookup);
  if (sink && sink->cancelled()) return;  // a partial gather: the pass is abandoned, statistics untouched

  // ---- Update: radius, count, flux and the error statistics of every pixel ----
  const auto t_update = clock_type::now();
  emitted_total_ += ps.emitted;
  const double ne_pass = static_cast<double>(ps.emitted);
  const double ne_total = static_cast<double>(emitted_total_);
  const double scale = photon_scale();  // V_c (eq. 8.11) or 1
  std::atomic<int64_t> invalid_phi{0};
  parallel_for(n_pixels, threads_, [&](size_t lo, size_t hi) {
    int64_t bad = 0;
    for (size_t i = lo; i < hi; ++i) {
      PixelState& s = px_[i];
      RGB phi = gather_phi_[i];
      double lap_j = gather_lap_[i];
      if (!phi.is_finite() || !std::isfinite(lap_j)) {  // discard and count: NaN/Inf never reaches a pass
        ++bad;
        phi = RGB(0.0f);
        lap_j = 0;
      }
      const RGB Ld = pass_direct_[i];  // PPM: its fixed eye path's emission, every pass
      const double r2_query = s.r2;
      const PhotonStatsUpdate u = progressive_update(s.n, s.r2, gather_m_[i], alpha_);
      for (int c = 0; c < 3; ++c) {
        s.tau[c] = (s.tau[c] + phi[c]) * u.ratio;  // thesis eq. 5.12 / 7.5
        s.direct[c] += Ld[c];
      }
      s.coverage += pass_covered_[i];
      s.lap = (s.lap + lap_j) * u.ratio;  // thesis eq. 6.32: derivatives scale like the flux
      s.n = u.n_new;
      s.r2 = u.r2_new;
      // Bias-corrected sample of this pass, x_j = L_p,j - B'_j (eq. 6.22): the pass's own
      // estimate with the query radius, minus the disc-kernel bias at that radius (eq. 6.17)
      // from the progressive Laplacian (eq. 6.20).
      double x = Ld.luminance();
      if (r2_query > 0 && ne_pass > 0 && ne_total > 0) {
        const double lap_L = s.r2 > 0 ? scale * s.lap / (ne_total * error_kernel::kK1 * s.r2) : 0.0;
        x += scale * phi.luminance() / (ne_pass * M_PI * r2_query) - error_kernel::kBiasDisc * r2_query * lap_L;
      }
      s.err.add(x);
    }
    invalid_phi += bad;
  });
  stats_.passes += 1;
  update_error_estimate();
  stats_.extra["update seconds"] += seconds_since(t_update);

  // ---- Statistics ----
  double sum_r = 0, n_r = 0;
  for (const PixelState& s : px_)
    if (s.r2 > 0) { sum_r += std::sqrt(s.r2); n_r += 1; }
  stats_.rays += rays + ps.rays;
  stats_.paths += ps.emitted;
  stats_.invalid_samples += invalid + invalid_phi + ps.invalid;
  stats_.extra["photons traced"] += static_cast<double>(ps.emitted);
  stats_.extra["photons stored"] += static_cast<double>(ps.stored);
  stats_.extra["photon rays"] += static_cast<double>(ps.rays);
  stats_.extra["average radius"] = n_r > 0 ? sum_r / n_r : 0.0;
  stats_.extra["estimated error"] = estimated_error_;
  if (adaptive_) {
    stats_.extra["acceptance rate"] = adaptive_->acceptance_rate();
    stats_.extra["mutation size"] = adaptive_->mean_theta();
    stats_.extra["V_c"] = adaptive_->vc();
    stats_.extra["uniform count"] = static_cast<double>(adaptive_->uniform_count());
    stats_.extra["visible count"] = static_cast<double>(adaptive_->visible_count());
    stats_.extra["photon paths traced"] = static_cast<double>(adaptive_->paths_traced());
  }
  stats_.seconds += seconds_since(start);
}

void ProgressivePhotonMapping::update_error_estimate() {
  const double i = static_cast<double>(stats_.passes);
  const double ne_total = static_cast<double>(emitted_total_);
  // t(i, 1 - beta/2) with 1 - beta the user's confidence (eq. 6.10; the thesis uses i dof).
  const double t_q = student_t_quantile(i, 0.5 * (1.0 + confidence_));
  double sum = 0;
  size_t count = 0;
  for (size_t k = 0; k < px_.size(); ++k) {
    const PixelState& s = px_[k];
    const double L = pixel_radiance(k).luminance();
    double rel = 0;
    if (L > 0) {
      const double lap_L = s.r2 > 0 && ne_total > 0 ? photon_scale() * s.lap / (ne_total * error_kernel::kK1 * s.r2) : 0.0;
      const double bias = error_kernel::kBiasDisc * s.r2 * lap_L;            // eq. 6.20
      rel = relative_bound(interval_half_width(t_q, s.err), bias, L);     // eq. 6.10, 6.13
      sum += rel;
      ++count;
    }
    error_[k] = static_cast<float>(std::min(rel, 1e30));
  }
  if (count > 0) estimated_error_ = sum / count;                       // eq. 6.33
  else estimated_error_ = scene_.light_set().empty() ? 0.0 : INFINITY;  // no lights: black is exact
}

RGB ProgressivePhotonMapping::pixel_radiance(size_t i) const {
  const PixelState& s = px_[i];
  return progressive_radiance(s.direct, s.tau, s.r2, stats_.passes, emitted_total_, photon_scale());
}

void ProgressivePhotonMapping::develop(Film& film) const {
  if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
  Pass& combined = film.add_pass(pass::kCombined, 3);
  Pass& error = film.add_pass(pass::kError, 1);
  Pass& radius = film.add_pass(pass::kRadius, 1);
  Pass& count = film.add_pass(pass::kPhotonCount, 1);
  Pass* alpha = film_transparent_ ? &film.add_pass(pass::kAlpha, 1) : nullptr;
  const double passes = static_cast<double>(std::max<int64_t>(stats_.passes, 1));
  for (size_t i = 0; i < px_.size(); ++i) {
    const RGB L = pixel_radiance(i);
    for (int c = 0; c < 3; ++c) combined.data[3 * i + c] = L[c];
    error.data[i] = error_[i];
    radius.data[i] = static_cast<float>(std::sqrt(px_[i].r2));
    count.data[i] = static_cast<float>(px_[i].n);
    if (alpha) alpha->data[i] = static_cast<float>(px_[i].coverage / passes);
  }
}

}  // namespace gp
