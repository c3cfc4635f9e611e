#include "integrators/photon/progressive_photon.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "core/parallel.h"
#include "core/sampling.h"
#include "integrators/lobe_split.h"
#include "integrators/photon/photon_estimate.h"
#include "materials/bsdf.h"

namespace gp {

namespace {
using clock_type = std::chrono::steady_clock;
}  // namespace

int64_t auto_photons_per_pass(int width, int height, uint64_t pass) {
  const int64_t target = std::clamp<int64_t>(2 * static_cast<int64_t>(width) * height, 100000, 1000000);
  const double ramp = 100000.0 * std::exp2(std::min(static_cast<double>(pass), 1000.0) / 8.0);
  return static_cast<int64_t>(std::min(static_cast<double>(target), ramp));
}

ProgressivePhotonMapping::ProgressivePhotonMapping(const Scene& scene, const Params& params,
                                                   const PhotonMethodOptions& options)
    : scene_(scene),
      retrace_(options.retrace),
      nee_(options.nee),
      alpha_(params.get<double>("alpha")),
      radius_(params.get<double>("radius")),
      footprint_pixels_(params.get<double>("footprint")),
      confidence_(params.get<double>("confidence")),
      photons_per_pass_(params.get<int64_t>("photons")),
      max_depth_(params.get<int>("max_depth")),
      rr_depth_(params.get<int>("rr_depth")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      threshold_(params.get<float>("specular_threshold")),
      seed_(params.get<uint64_t>("seed")),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      tracer_(scene, max_depth_, threshold_, seed_, threads_) {
  // Values are checked against their declarations (methods.cpp) before a method is built.
  thesis_bound_ = params.get<std::string>("error_bound") == "thesis";
  boundary_bound_ = params.get<std::string>("error_bound") == "boundary";
  folded_ = FoldedNormalQuantile(confidence_);
  hash_mode_ = params.get<std::string>("hash") == "stochastic" ? PhotonHashMode::Stochastic : PhotonHashMode::Exact;
  tracer_.set_world_by_closure_share(options.world_by_closure_share);
  if (options.adaptive_photons && params.get<std::string>("photon_sampler") == "adaptive")
    adaptive_ = std::make_unique<AdaptivePhotonSampler>(tracer_, params.get<int>("chains"), seed_);
  // With the adaptive sampler, V(u) sees volume photons near the camera segments too
  // (BeamVisibility, adaptive_photons.h). Grid media too: photons fly through them by delta tracking (photon_walk.h), the eye segments
  // take their transmittance by ratio tracking (MediumSegment::transmittance), and the beam
  // gather reads it at each photon (volume_gather).
  media_ = options.media && scene.has_media();
  tracer_.set_media(media_);
  if (media_) camera_media_ = CameraMedia(scene);
  check_image_size(width_, height_);
  const size_t n = static_cast<size_t>(width_) * height_;
  px_.assign(n, PixelState{});
  vp_.assign(n, VisiblePoint{});
  pass_direct_.assign(n, RGB(0.0f));
  pass_covered_.assign(n, 1.0f);
  first_r_.assign(n, 0.0f);
  gather_m_.assign(n, 0.0f);
  gather_lap_.assign(n, 0.0f);
  gather_boundary_.assign(n, {0.0f, 0.0f, 0.0f});
  gather_phi_.assign(n, RGB(0.0f));
  error_.assign(n, 0.0f);
  if (options.spectral_photons && !adaptive_ &&
      use_spectral(parse_spectral_mode(params.get<std::string>("spectral")), scene)) {
    spectral_ = true;
    spectra_ = std::make_unique<SceneSpectra>(scene);
    const int c = params.get<int>("wavelengths");
    wl_.count = c;
    dispersive_ = !first_dispersive_material(scene).empty();
    stats_.extra["spectral wavelengths"] = c;  // the CLI lists it: this run used spectral photons
    vp_beta_.assign(n, SpectralValues{});
    vp_hero_.assign(n, 0);
  }
  if (media_) {
    for (const Medium& m : scene.media) media_rgb_.push_back(rgb_channels(m));
    beams_.assign(n * kMaxBeams, EyeBeam{});
    n_beams_.assign(n, 0);
    first_vr_.assign(n, 0.0f);
    gather_vm_.assign(n, 0.0f);
    gather_vphi_.assign(n, RGB(0.0f));
  }
  if (scene.light_set().empty())
    stats_.extra["warning: no lights"] = 1;  // the image is black; reported, never a hang
}

void ProgressivePhotonMapping::set_initial_radii() {
  const float min_r = 1e-5f * std::max(1e-3f, length(scene_.bounds().diagonal()));
  for (size_t i = 0; i < px_.size(); ++i)
    if (px_[i].r2 == 0 && vp_[i].material >= 0) {
      const double r = radius_ > 0 ? radius_ : std::max(first_r_[i], min_r);
      px_[i].r2 = r * r;
    }
  if (media_ && radius_ > 0)  // the cylinder's first radius: `radius` if given, else volume_gather's
    for (size_t i = 0; i < px_.size(); ++i)
      if (px_[i].vr2 == 0 && n_beams_[i] > 0) px_[i].vr2 = radius_ * radius_;
}

void ProgressivePhotonMapping::build_beam_visibility(const std::function<bool()>& cancelled) {
  // The cylinders' radii: each pixel's, or before volume_gather has set it (the first pass) the
  // largest it may set there: its footprint or a tenth of the scene's diagonal.
  Bounds3 region = scene_.bounds();
  const float diag = region.empty() ? 0.0f : length(region.diagonal());
  float max_r = 0;
  for (size_t i = 0; i < px_.size(); ++i)
    if (n_beams_[i] > 0)
      max_r = std::max(max_r, px_[i].vr2 > 0 ? static_cast<float>(std::sqrt(px_[i].vr2))
                                             : std::max(first_vr_[i], 0.1f * diag));
  if (!region.empty()) {
    const float pad = 0.01f * diag + 1e-4f;
    region.lo = region.lo - Vec3(pad);
    region.hi = region.hi + Vec3(pad);
  }
  beam_visibility_.begin(region, max_r);
  for (size_t i = 0; i < px_.size(); ++i) {
    if (i % kCancelPollPixels == 0 && cancelled()) return;  // abandoned pass (iterate checks)
    for (int k = 0; k < n_beams_[i]; ++k) {
      const EyeBeam& b = beams_[i * kMaxBeams + k];
      beam_visibility_.add(b.o, b.d, b.t_max);
    }
  }
  beam_visibility_.finish();
}

void ProgressivePhotonMapping::store_beams(size_t pixel, const EyeEnd& end, Vec2 half_extent) {
  if (!media_) return;
  n_beams_[pixel] = static_cast<uint8_t>(end.n_beams);
  for (int b = 0; b < end.n_beams; ++b) beams_[pixel * kMaxBeams + b] = end.beams[b];
  first_vr_[pixel] = end.n_beams > 0 ? footprint_radius(end.beam_length, half_extent) : 0.0f;
}

RGB direct_light(const Scene& scene, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo, float u_light,
                 const Vec2& u2, int64_t& rays, const ShadowTest* shadow, const std::vector<MediumChannels>* media) {
  const auto ls = scene.light_set().sample_li(hit.p, u_light, u2);
  if (!ls || !(ls->pdf > 0) || ls->L.is_black()) return RGB(0.0f);
  const Vec3 wi = hit.frame.to_local(ls->wi);
  // A light hidden from some kinds of bounce ray lights only the lobes of the others (Cycles'
  // closure exclusion, as the path tracer's next-event estimation); the World by its own rule.
  const RGB f = nee_only_f(bsdf, wo, wi, ls->light >= 0 ? &scene.light_set().lights()[ls->light] : nullptr) *
                std::abs(wi.z);
  if (f.is_black()) return RGB(0.0f);
  ++rays;
  // With media (shadow given): through volume boundaries, with the media's transmittance; and
  // through transparent surfaces, filtered (paths/medium_walk.h).
  const ShadowTest plain(scene, nullptr);
  const ChannelValues T = (shadow ? *shadow : plain).transmittance(
      hit.p, &hit.ng, *ls, {.count = 3, .media = media && !media->empty() ? media->data() : nullptr, .state = hit.ray});
  if (is_blocked(T, 3)) return RGB(0.0f);
  return f * ls->L / ls->pdf * RGB(T[0], T[1], T[2]);
}

bool ProgressivePhotonMapping::eye_tiles(ProgressSink* sink, bool may_pause, const std::function<void(const Tile&)>& fn) {
  return eye_tiles_.run(width_, height_, tile_size_, threads_, sink, may_pause, fn);
}

bool ProgressivePhotonMapping::eye_tile_done(size_t pixel) const { return eye_tiles_.done(pixel); }

// ---- Eye pass: one camera path per pixel to its measurement point ----
bool ProgressivePhotonMapping::eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause,
                                        std::atomic<int64_t>& rays_out, std::atomic<int64_t>& invalid_out) {
  return eye_tiles(
      sink, may_pause,
      [&](const Tile& tile) {
        int64_t rays = 0, invalid = 0;
        EyePathHooks none;
        // The tile's camera rays are traced together (Embree packets: the same hits, several
        // times faster than one by one), then each path goes on alone from its first hit.
        std::vector<PixelStart> starts = tile_pixel_starts(scene_.camera, seed_, pass, tile);
        CameraRays first(scene_, starts.data(), starts.size());
        const std::vector<Ray>& camera = first.rays;
        std::vector<std::optional<SurfaceHit>>& hits = first.hits;
        const Vec2 ext = scene_.camera.half_extent();
        size_t k = 0;
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x, ++k) {
            const size_t pixel = static_cast<size_t>(y) * width_ + x;
            RgbEye c;
            c.media = &media_rgb_;
            const EyeEnd end = trace_eye(camera[k], starts[k].rng, rays, c, none, &hits[k], false);
            EyePath path;
            path.Ld = c.Ld;
            path.vp = end.vp;
            path.path_length = end.path_length;
            path.escaped = end.escaped;
            path.transparent = end.transparent;
            store_beams(pixel, end, ext);
            if (!path.Ld.is_finite()) {
              ++invalid;
              path.Ld = RGB(0.0f);
            }
            if (path.vp.material >= 0 && !path.vp.beta.is_finite()) {
              ++invalid;
              path.vp.material = -1;
            }
            pass_direct_[pixel] = path.Ld;
            // Alpha: 1 - the transparency of a path that escaped after transparent bounces only
            // (paths/medium_walk.h path_transparency), times 1 - a Holdout's weight in a mix.
            pass_covered_[pixel] = (path.escaped ? 1.0f - path.transparent : 1.0f) * first.coverage[k];
            vp_[pixel] = path.vp;
            first_r_[pixel] = path.vp.material >= 0 ? footprint_radius(path.path_length, ext) : 0.0f;
          }
        rays_out += rays;
        invalid_out += invalid;
      });
}

void ProgressivePhotonMapping::iterate(ProgressSink* sink) {
  const auto start = clock_type::now();
  const uint64_t pass = static_cast<uint64_t>(stats_.passes);
  // ---- Motion blur (thesis ch. 7): one shutter time per pass, drawn from the pass's seed and
  // shared by its eye paths and photons (and so by the statistics they update), so that the
  // shared radius and flux average over the shutter. PPM keeps the measurement points of its
  // first pass: its passes all take that pass's time (no blur; Method::supports says so). ----
  const ShutterTime at_time(scene_.pass_shutter_time(seed_, retrace_ ? pass : 0));
  const size_t n_pixels = px_.size();
  // The first pass stops between eye tiles and between its stages when the sink asks
  // (ProgressSink::pause: Blender's F12 window shows what it has, develop()'s preview); the next
  // call goes on where it stopped, with the same random numbers, so the pass is a whole one's.
  const bool may_pause = sink && stats_.passes == 0;
  PassPause open_pass(open_, stats_.seconds, start, sink, may_pause);
  std::atomic<int64_t>& rays = open_pass.rays;
  std::atomic<int64_t>& invalid = open_pass.invalid;
  PhotonPassStats ps;
  if (stage_ == Stage::Eye) {
    // ---- Measurement points (every pass for SPPM, once for PPM) ----
    const auto t_eye = clock_type::now();
    if (spectral_) {
      wl_ = pass_wavelengths(pass);
      pass_spectra_.evaluate(scene_, *spectra_, wl_);
      if (media_) {
        pass_media_.clear();
        for (const MediumSpectra& m : spectra_->media) pass_media_.push_back(m.at(wl_));
      }
      for (int k = 0; k < wl_.count; ++k) {
        SpectralValues e{};
        e[k] = 1.0f;
        wl_basis_[k] = sample_to_rgb(e, wl_);
      }
    }
    if (retrace_ || !have_points_) {
      const bool done = spectral_ ? spectral_eye_pass(pass, sink, may_pause, rays, invalid)
                                  : eye_pass(pass, sink, may_pause, rays, invalid);
      if (sink && sink->cancelled()) return;  // abandoned pass: statistics untouched
      stats_.extra["eye seconds"] += seconds_since(t_eye);
      if (!done) {  // paused between tiles (the sink asked)
        open_pass.leave_open();
        return;
      }
      have_points_ = true;
      set_initial_radii();
    } else {
      stats_.extra["eye seconds"] += seconds_since(t_eye);
    }
    stage_ = Stage::Photons;
    if (open_pass.pause_here()) return;
  }

  const std::function<bool()> cancelled = [sink] { return sink && sink->cancelled(); };
  if (stage_ == Stage::Photons) {
    // ---- Photon pass ----
    const auto t_trace = clock_type::now();
    if (adaptive_) {
      // ---- Adaptive MCMC photon tracing (thesis ch. 8): V(u) against this pass's points ----
      visibility_points_.clear();
      for (size_t i = 0; i < n_pixels; ++i)
        if (vp_[i].material >= 0)
          visibility_points_.push_back({vp_[i].p, vp_[i].frame.n, vp_[i].wo.z, static_cast<float>(std::sqrt(px_[i].r2))});
      visibility_.build(visibility_points_, threads_, cancelled);
      if (cancelled()) return;  // the grid of 2 M points at 1080p takes a few hundred ms
      if (media_) build_beam_visibility(cancelled);
      if (cancelled()) return;
      ps = adaptive_->trace(photons_for_pass(pass), pass, nee_ ? 1 : 0, visibility_, photons_, cancelled,
                            media_ ? &beam_visibility_ : nullptr, media_ ? &volume_photons_ : nullptr);
    } else if (spectral_) {
      ps = spectral_trace(pass, cancelled);
    } else {
      ps = tracer_.trace(photons_for_pass(pass), pass, nee_ ? 1 : 0, photons_, nullptr, nullptr, cancelled,
                         media_ ? &volume_photons_ : nullptr);
    }
    stats_.extra["trace seconds"] += seconds_since(t_trace);
    if (sink && sink->cancelled()) return;
    open_ps_ = ps;
    stage_ = Stage::Gather;
    if (open_pass.pause_here()) return;
  }
  ps = open_ps_;
  stage_ = Stage::Eye;  // this call ends the pass (or a cancel abandons it)
  open_pass.close();

  // ---- Lookup: hash grid of this pass's photons, gathered by every measurement point ----
  const auto t_lookup = clock_type::now();
  // Cells are twice the largest radius (§10.2.2) of the pixels that have received photons: a
  // pixel that never does keeps its initial radius, and letting it set the cells made every
  // query scan many times the photons it finds (and left the stochastic grid few buckets to
  // keep photons in). Such a pixel's query still finds everything in range (more cells).
  // Before any pixel has received photons, every pixel with a point counts.
  double max_r2 = 0, max_r2_all = 0;
  for (size_t i = 0; i < n_pixels; ++i)
    if (vp_[i].material >= 0) {
      max_r2_all = std::max(max_r2_all, px_[i].r2);
      if (px_[i].n > 0) max_r2 = std::max(max_r2, px_[i].r2);
    }
  if (max_r2 == 0) max_r2 = max_r2_all;
  const float max_r = static_cast<float>(std::sqrt(max_r2));
  const bool have_photons = !photons_.empty() && max_r > 0;
  if (have_photons) grid_.build(photons_, 2.0f * max_r, hash_mode_, seed_, pass, threads_, 0, cancelled);  // §10.2.2
  if (cancelled()) return;
  if (spectral_) spectral_gather(cancelled);
  else parallel_for(n_pixels, threads_, [&](size_t lo, size_t hi) {
    for (size_t i = lo; i < hi; ++i) {
      if (i % kCancelPollPixels == 0 && cancelled()) return;  // abandoned pass: checked below
      gather_m_[i] = 0;
      gather_lap_[i] = 0;
      gather_phi_[i] = RGB(0.0f);
      gather_boundary_[i] = {0.0f, 0.0f, 0.0f};
      const VisiblePoint& vp = vp_[i];
      if (!have_photons || vp.material < 0) continue;
      const Bsdf bsdf = scene_.bsdf(vp.material, vp.uv, vp.p, vp.frame.to_world(vp.wo), vp.frame, vp.ng,
                                    vp.n_smooth);  // as Scene::bsdf(hit)
      const float R = static_cast<float>(std::sqrt(px_[i].r2));
      const bool transmits = bsdf.transmits();
      double m = 0, lap = 0, foreign = 0, mu = 0, mv = 0;
      RGB phi(0.0f);
      const float off_plane = kOffPlane * R;
      const Frame geo = boundary_frame(vp);
      grid_.query(vp.p, R, [&](const Photon& ph, float d2, float weight) {
        const Vec3 wi = vp.frame.to_local(ph.wi);
        if (!photon_gather_side(transmits, vp.wo, wi)) return;  // the far side of a thin wall
        m += weight;
        const float shading = gather_shading_correction(ph.wi, vp.n_smooth, vp.frame.n);  // a map's bent cosine, as pt
        const RGB contrib = vp.beta * gathered_f(bsdf, vp.wo, wi, ph.lobes, ph.world_share) * ph.power *
                            (weight * shading);  // eq. 5.11 / 7.4
        phi += contrib;
        lap += contrib.luminance() * error_kernel::laplacian(d2, R);  // §6.4, eq. 6.31 (2nd order)
        // Boundary terms (record_error_sample, error_bound=boundary only: the default keeps this
        // per-photon work out of the gather): another surface's photon, or this one's first moment.
        if (!boundary_bound_) return;
        const Vec3 off = ph.p - vp.p;
        const double y = contrib.luminance();
        const float height = dot(off, geo.n);
        if (height > kInFront * R || height < -off_plane) {
          foreign += y;
        } else {
          mu += y * dot(off, geo.s);
          mv += y * dot(off, geo.t);
        }
      });
      gather_m_[i] = static_cast<float>(m);
      gather_lap_[i] = static_cast<float>(lap);
      gather_boundary_[i] = {static_cast<float>(foreign), static_cast<float>(mu), static_cast<float>(mv)};
      gather_phi_[i] = phi;
    }
  });
  if (media_) volume_gather(pass, cancelled);
  stats_.extra["lookup seconds"] += seconds_since(t_lookup);
  if (sink && sink->cancelled()) return;  // a partial gather: the pass is abandoned, statistics untouched

  // ---- Update: radius, count, flux and the error statistics of every pixel ----
  const auto t_update = clock_type::now();
  emitted_total_ += ps.emitted;
  const double ne_pass = static_cast<double>(ps.emitted);
  std::atomic<int64_t> invalid_phi{0}, cut_rays{0};
  parallel_for(n_pixels, threads_, [&](size_t lo, size_t hi) {
    int64_t bad = 0, probe_rays = 0;
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
      if (media_)  // the beam radiance estimate's radius and flux
        bad += progressive_beam_update(s.vn, s.vr2, s.vtau, gather_vphi_[i], gather_vm_[i], alpha_);
      s.lap = (s.lap + lap_j) * u.ratio;  // thesis eq. 6.32: derivatives scale like the flux
      s.n = u.n_new;
      s.r2 = u.r2_new;
      // The boundary bias (calibrated bound, RGB photons): the disc's part with photons this pass.
      PassBoundary boundary;
      const bool with_boundary = boundary_bound_ && vp_[i].material >= 0 && r2_query > 0 && !spectral_;
      if (with_boundary) {
        Rng rng = Rng::for_key(seed_, pass, i);
        boundary.shape = disc_shape(vp_[i], std::sqrt(r2_query), rng, probe_rays);
        const auto& g = gather_boundary_[i];
        if (std::isfinite(g[0]) && std::isfinite(g[1]) && std::isfinite(g[2])) boundary = {boundary.shape, g[0], g[1], g[2]};
      }
      record_error_sample(s, Ld.luminance(), phi.luminance(), lap_j, vp_[i].material >= 0 ? r2_query : 0.0, ne_pass,
                          with_boundary ? &boundary : nullptr);
    }
    invalid_phi += bad;
    cut_rays += probe_rays;
  });
  rays += cut_rays;
  if (media_) {  // the beam radiance estimate's figures (the CLI lists them)
    double sum_r = 0, n_r = 0;
    for (const PixelState& s : px_)
      if (s.vr2 > 0) { sum_r += std::sqrt(s.vr2); n_r += 1; }
    stats_.extra["volume photons stored"] += static_cast<double>(volume_photons_.size());
    stats_.extra["average cylinder radius"] = n_r > 0 ? sum_r / n_r : 0.0;
  }
  end_pass(t_update, ps, rays, invalid + invalid_phi);
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

size_t ProgressivePhotonMapping::memory_bytes() const {
  size_t b = photons_.capacity() * sizeof(Photon) + volume_photons_.capacity() * sizeof(Photon) +
             photon_power_.capacity() * sizeof(SpectralValues) + volume_power_.capacity() * sizeof(SpectralValues) +
             photon_hero_.capacity() + volume_hero_.capacity() + beams_.capacity() * sizeof(EyeBeam) +
             grid_.capacity_bytes() + volume_grid_.capacity_bytes() + tracer_.capacity_bytes() +
             (adaptive_ ? adaptive_->capacity_bytes() : 0);
  for (const auto& c : spectral_chunks_) b += c.capacity() * sizeof(SpectralPhoton);
  for (const auto& c : spectral_volume_chunks_) b += c.capacity() * sizeof(SpectralPhoton);
  return b;
}

void ProgressivePhotonMapping::end_pass(std::chrono::steady_clock::time_point t_update, const PhotonPassStats& ps,
                                        int64_t rays, int64_t invalid) {
  stats_.passes += 1;
  update_error_estimate();
  stats_.extra["update seconds"] += seconds_since(t_update);
  double sum_r = 0, n_r = 0;
  for (const PixelState& s : px_)
    if (s.r2 > 0) { sum_r += std::sqrt(s.r2); n_r += 1; }
  stats_.rays += rays + ps.rays;
  stats_.paths += ps.emitted;
  stats_.invalid_samples += invalid + ps.invalid;
  stats_.extra["photons traced"] += static_cast<double>(ps.emitted);
  stats_.extra["photons stored"] += static_cast<double>(ps.stored);
  stats_.extra["photon rays"] += static_cast<double>(ps.rays);
  stats_.extra["average radius"] = n_r > 0 ? sum_r / n_r : 0.0;
  stats_.extra["estimated error"] = estimated_error();  // -1 with media: none
}

DiscShape ProgressivePhotonMapping::disc_shape(const VisiblePoint& vp, double R, Rng& rng, int64_t& rays) const {
  const Frame geo = boundary_frame(vp);
  // Lifted off the surface by a small share of R; the downward probe reaches kOffPlane R below
  // the plane, which keeps a surface curved with a radius above 2 R at the rim (R^2 / 2 rho).
  const float lift = static_cast<float>(0.02 * R), reach = static_cast<float>(kOffPlane * R);
  const Vec3 above = vp.p + geo.n * lift;
  DiscShape d = DiscShape::whole(R);
  for (int k = 0; k < kCutProbes; ++k) {
    const double phi = 2 * M_PI * (k + rng.uniform()) / kCutProbes, rho = R * std::sqrt(rng.uniform());
    const double u = rho * std::cos(phi), v = rho * std::sin(phi);
    const Vec3 offset = geo.s * static_cast<float>(u) + geo.t * static_cast<float>(v);
    const float len = length(offset);
    ++rays;
    // Glass in the way lets photons through (the floor under a glass block): not a blocker.
    bool missing = false;
    if (len > 0)
      if (const auto hit = scene_.intersect_point(Ray(above, offset / len, 0.0f, len)))
        missing = hit->material < 0 || scene_.material(hit->material).type != MaterialType::Dielectric;
    if (!missing) {
      ++rays;
      missing = !scene_.intersect_point(Ray(above + offset, -geo.n, 0.0f, lift + reach));
    }
    if (!missing) continue;
    // Each probe stands for 1 / kCutProbes of the disc (uniform in its sector).
    const double w = 1.0 / kCutProbes;
    d.a -= w;
    d.cu -= w * u;
    d.cv -= w * v;
    d.suu -= w * u * u;
    d.suv -= w * u * v;
    d.svv -= w * v * v;
  }
  return d;
}

void ProgressivePhotonMapping::record_error_sample(PixelState& s, double Ld, double phi, double lap_j, double r2_query,
                                                   double ne_pass, const PassBoundary* boundary) const {
  const double ne_total = static_cast<double>(emitted_total_);
  const double scale = photon_scale();  // V_c (eq. 8.11) or 1
  // Bias-corrected sample of this pass, x_j = L_p,j - B'_j (eq. 6.22): the pass's own estimate
  // with the query radius, minus the disc-kernel bias at that radius (eq. 6.17) from the
  // progressive Laplacian (eq. 6.20).
  double x = Ld, y = Ld, r = 0;
  if (r2_query > 0 && ne_pass > 0 && ne_total > 0) {
    const double lap_L = s.r2 > 0 ? scale * s.lap / (ne_total * error_kernel::kK1 * s.r2) : 0.0;
    y += scale * phi / (ne_pass * M_PI * r2_query);
    r = r2_query;
    x = y - error_kernel::kBiasDisc * r2_query * lap_L;
    s.lap_err.add(scale * lap_j / (ne_pass * error_kernel::kK1 * r2_query));  // this pass's Lap L (eq. 6.31)
    s.r2_sum += r2_query;
    // This pass's boundary data (BoundarySums), offsets in units of the radius; a whole disc
    // where none was probed.
    const double to_radiance = scale / (ne_pass * M_PI * r2_query), R = std::sqrt(r2_query);
    if (boundary) {
      DiscShape u = boundary->shape;
      u.cu /= R; u.cv /= R;
      u.suu /= r2_query; u.suv /= r2_query; u.svv /= r2_query;
      s.boundary.add(u, (phi - boundary->foreign) * to_radiance, boundary->foreign * to_radiance,
                     boundary->mu * to_radiance / R, boundary->mv * to_radiance / R);
    } else {
      s.boundary.add(DiscShape::whole(1), phi * to_radiance, 0, 0, 0);
    }
    if (phi > 0) ++s.photon_passes;
  }
  s.err.add(x);
  s.pass.add(y, r);
}

ProgressivePhotonMapping::ErrorTerms ProgressivePhotonMapping::bias_estimate(size_t k) const {
  const PixelState& s = px_[k];
  const double ne_total = static_cast<double>(emitted_total_);
  const double passes = static_cast<double>(stats_.passes);
  ErrorTerms e;
  e.radius = std::sqrt(s.r2);
  e.laplacian = s.r2 > 0 && ne_total > 0 ? photon_scale() * s.lap / (ne_total * error_kernel::kK1 * s.r2) : 0.0;
  // Bias of the progressive estimate: the mean of the passes' biases (eq. 6.14, 6.18), each
  // pass's with its own query radius; eq. 6.19 replaces them all by R_i^2, which underestimates
  // it while the radius shrinks (by 24 % at alpha 0.7 on the analytic scene of error_estimate_test).
  const double n_lap = static_cast<double>(s.lap_err.n);
  const double r2_bias = thesis_bound_ || n_lap == 0 ? s.r2 : s.r2_sum / n_lap;
  e.bias = error_kernel::kBiasDisc * r2_bias * e.laplacian;
  // Lap L_i is about (1 / i) sum of the n passes' own Laplacians: standard error sqrt(n V) / i.
  e.bias_sd = n_lap > 1 && passes > 0 ? error_kernel::kBiasDisc * r2_bias * std::sqrt(n_lap * s.lap_err.variance()) / passes : 0.0;
  return e;
}

void ProgressivePhotonMapping::edge_bias(size_t k, ErrorTerms& e) const {
  const BoundarySums& b = px_[k].boundary;
  const double passes = static_cast<double>(stats_.passes);
  if (b.n == 0 || !(passes > 0)) return;
  e.cut = 1 - b.shape.a / b.n;
  // L_i is the mean of every pass's estimate (eq. 6.14): the n passes with a point carry the bias.
  const BoundarySums::Bias bias = b.bias();
  e.edge_bias = bias.bias * b.n / passes;
  e.edge_bias_sd = bias.sd * b.n / passes;
  e.edge_variance = bias.variance_change * (b.n / passes) * (b.n / passes);
}

ProgressivePhotonMapping::ErrorTerms ProgressivePhotonMapping::error_terms(size_t k) const {
  const PixelState& s = px_[k];
  ErrorTerms e = bias_estimate(k);
  e.radiance = pixel_radiance(k).luminance();
  if (thesis_bound_) {
    e.noise_sd = s.err.n < 2 ? INFINITY : std::sqrt(s.err.variance() / s.err.n);
    e.half_width = interval_half_width(t_quantile_, s.err);
    e.bound = e.half_width + std::abs(e.bias);  // eq. 6.12
    e.sigma = e.noise_sd;
    e.corrected_mean = s.err.n > 0 ? s.err.sum / s.err.n : 0.0;
    e.mean_abs = folded_normal_mean(e.bias, e.noise_sd, s.err.n);
    e.photon_passes = s.photon_passes;
    return e;
  }
  // Eq. 6.22's samples with every pass's bias from the latest Laplacian (PassSamples).
  const double slope = error_kernel::kBiasDisc * e.laplacian;
  e.noise_sd = s.pass.n < 2 ? INFINITY : std::sqrt(s.pass.variance(slope) / s.pass.n);
  e.half_width = s.pass.n < 2 ? INFINITY : t_quantile_ * e.noise_sd;
  e.corrected_mean = s.pass.mean(slope);
  // B' is itself an estimate, and a noisy one: from the same photons, B' = R^2 Lap L / 8 with
  // the smooth kernel's weights (K'' + K'/t) is 2.1 times noisier than the disc estimate of L
  // (ratio of the weights' rms over the disc), and in most pixels the true Laplacian bias is far
  // below that noise. Added to every bound (eq. 6.12), or shrunk by its own signal-to-noise ratio
  // (kept where |B'| > sd, a third of the pixels of a bias-free scene), it widened the bound at
  // random: 61-65 % coverage at 50 % there, 59-60 % on cornell-box. So B' counts where it is
  // significant, |B'| > t sd with t Student's two-sided quantile (bias_significance_cut: 5 % of a
  // bias-free scene's pixels at any pass count), and then whole, with its uncertainty: |L_i - L| ~
  // |B' + sigma T|, sigma^2 = Var L_i + sd^2, and the bound is its quantile at the confidence, the
  // t correction taken at m = 0 (exact there).
  const uint32_t n_lap = s.lap_err.n;
  edge_bias(k, e);
  const double sd2 = e.bias_sd * e.bias_sd;
  const double cut = significance_cut(n_lap);
  double w = e.bias * e.bias > cut * cut * sd2 ? 1.0 : 0.0;
  // The boundary bias likewise: where it is not significant its noise would move the bound at
  // random (cornell-box at 50 %: 54-57 % covered with it everywhere). Kept, it comes from the same
  // photons as L_i, so the noise around it is that of the corrected estimate (edge_variance),
  // not L_i's plus the bias' own.
  const double edge_cut = significance_cut(px_[k].boundary.n);
  const double we = e.edge_bias * e.edge_bias > edge_cut * edge_cut * e.edge_bias_sd * e.edge_bias_sd ? 1.0 : 0.0;
  e.edge_bias *= we;
  // A cut disc's Laplacian estimate sees the cut (the missing rim weighs like a negative
  // curvature), so B' there counts the boundary bias a second time: the boundary term replaces it.
  if (we > 0) w = 0;
  e.bias = w * e.bias + e.edge_bias;
  const double sigma = std::sqrt(std::max(0.0, e.noise_sd * e.noise_sd + w * sd2 + we * e.edge_variance));
  e.sigma = sigma;
  e.bound = sigma > 0 && std::isfinite(sigma) ? sigma * t_over_z_ * folded_(std::abs(e.bias) / sigma)
                                               : (std::isfinite(sigma) ? std::abs(e.bias) : INFINITY);
  e.mean_abs = folded_normal_mean(e.bias, sigma, s.pass.n - 1.0);
  e.photon_passes = s.photon_passes;
  return e;
}

void ProgressivePhotonMapping::update_error_estimate() {
  // t(dof, 1 - beta/2) with 1 - beta the user's confidence (eq. 6.10; the thesis uses i dof,
  // the sample variance of i samples has i - 1).
  const double passes = static_cast<double>(stats_.passes);
  const double dof = thesis_bound_ ? passes : passes - 1;
  const double p = 0.5 * (1.0 + confidence_);
  t_quantile_ = dof >= 1 ? student_t_quantile(dof, p) : INFINITY;
  t_over_z_ = t_quantile_ / normal_quantile(p);
  // B''s significance cut-off for every count of per-pass Laplacians so far (one quantile per pass).
  while (bias_cut_.size() <= static_cast<size_t>(stats_.passes))
    bias_cut_.push_back(bias_significance_cut(static_cast<uint32_t>(bias_cut_.size())));
  double sum = 0;
  size_t count = 0;
  for (size_t k = 0; k < px_.size(); ++k) {
    const ErrorTerms e = error_terms(k);
    double rel = 0;
    if (e.radiance > 0) {
      rel = e.bound / e.radiance;  // eq. 6.13
      // The stop averages (eq. 6.33) what --target-error is measured by, the mean relative
      // error: the estimated E|e| / L_i, not the bound (with 50 % confidence the median of |e|,
      // 1.19 times smaller for a normal error: the stop overshot E by that much). The thesis'
      // form keeps eq. 6.33 of its bounds as written.
      sum += thesis_bound_ ? rel : e.mean_abs / e.radiance;
      ++count;
    }
    error_[k] = static_cast<float>(std::min(rel, 1e30));
  }
  if (count > 0) estimated_error_ = sum / count;                       // eq. 6.33
  else estimated_error_ = scene_.light_set().empty() ? 0.0 : INFINITY;  // no lights: black is exact
}

RGB ProgressivePhotonMapping::pixel_radiance(size_t i) const {
  const PixelState& s = px_[i];
  RGB L = progressive_radiance(s.direct, s.tau, s.r2, stats_.passes, emitted_total_, photon_scale());
  if (media_ && s.vr2 > 0 && emitted_total_ > 0) {
    // The beam radiance estimate: the cylinder's flux over pi R^2 and the photons emitted (§5.6).
    const double k = photon_scale() / (static_cast<double>(emitted_total_) * M_PI * s.vr2);
    for (int c = 0; c < 3; ++c) L[c] += static_cast<float>(s.vtau[c] * k);
  }
  return L;
}

void ProgressivePhotonMapping::develop(Film& film) const {
  if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
  Pass& combined = film.add_pass(pass::kCombined, 3);
  Pass& error = film.add_pass(pass::kError, 1);
  Pass& radius = film.add_pass(pass::kRadius, 1);
  Pass& count = film.add_pass(pass::kPhotonCount, 1);
  Pass* alpha = writes_alpha_ ? &film.add_pass(pass::kAlpha, 1) : nullptr;
  const double passes = static_cast<double>(std::max<int64_t>(stats_.passes, 1));
  if (first_pass_open()) {
    // The first pass paused before its end (iterate, ProgressSink::pause): a preview, the light
    // its camera paths have seen themselves (emission, and direct light where the method adds it
    // by next-event estimation), at the pixels they reached; nothing is left of it after the pass.
    const bool eye_done = stage_ != Stage::Eye;
    for (size_t i = 0; i < px_.size(); ++i) {
      const bool seen = eye_done || eye_tile_done(i);
      for (int c = 0; c < 3; ++c) combined.data[3 * i + c] = seen ? pass_direct_[i][c] : 0.0f;
      error.data[i] = radius.data[i] = count.data[i] = 0.0f;
      if (alpha) alpha->data[i] = seen ? pass_covered_[i] : 0.0f;
    }
    return;
  }
  for (size_t i = 0; i < px_.size(); ++i) {
    const RGB L = pixel_radiance(i);
    for (int c = 0; c < 3; ++c) combined.data[3 * i + c] = L[c];
    error.data[i] = media_ ? 0.0f : error_[i];  // not available with media (estimated_error)
    radius.data[i] = static_cast<float>(std::sqrt(px_[i].r2));
    count.data[i] = static_cast<float>(px_[i].n);
    if (alpha) alpha->data[i] = static_cast<float>(px_[i].coverage / passes);
  }
}

}  // namespace gp

namespace gp {

// ---- The beam radiance estimate (Jarosz et al. 2008) with a progressive radius (thesis §5.6) ----
// beam_estimate.h's gather over every pixel's segments (gather_pixel_beams, MSPPM's too); the flux
// sum (tau) and the count M found here enter the same update as the surface's (eq. 5.37-5.39: N + alpha M photons kept within the
// shrunk cylinder; tau scaled by the same ratio, eq. 5.12).
void ProgressivePhotonMapping::volume_gather(uint64_t pass, const std::function<bool()>& cancelled) {
  const int C = channels();
  gather_pixel_beams(
      scene_, volume_photons_, volume_grid_, PixelBeams{beams_, kMaxBeams, n_beams_, first_vr_}, radius_,
      [&](size_t i) -> double& { return px_[i].vr2; }, seed_, pass, threads_, C, cancelled,
      [&](int med) -> const MediumChannels& { return medium_channels(med); },
      [&](const EyeBeam& b, const Photon& ph, const ChannelValues& T, const ChannelValues& f) {
        if (spectral_) {
          const SpectralValues& power = volume_power_[ph.index];
          SpectralValues c{};
          for (int w = 0; w < C; ++w) c[w] = b.beta[w] * T[w] * f[w] * power[w];
          if (volume_hero_[ph.index] && !b.hero_only) c[0] *= static_cast<float>(C);  // C once per full path
          return spectral_to_rgb(c);
        }
        return RGB(b.beta[0] * T[0] * f[0], b.beta[1] * T[1] * f[1], b.beta[2] * T[2] * f[2]) * ph.power;
      },
      gather_vm_, gather_vphi_);
}

}  // namespace gp
