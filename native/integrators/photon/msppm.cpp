#include "integrators/photon/msppm.h"
#include "integrators/photon/msppm_densities.h"
#include "integrators/lobe_split.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "core/parallel.h"
#include "core/rng.h"
#include "integrators/photon/photon_estimate.h"
#include "integrators/photon/progressive_photon.h"  // progressive_update (eq. 5.7 / 5.9 / 5.12)
#include "materials/bsdf.h"

namespace gp {

namespace {
using clock_type = std::chrono::steady_clock;
}  // namespace

Msppm::Msppm(const Scene& scene, const Params& params)
    : scene_(scene),
      alpha_(params.get<double>("alpha")),
      radius_(params.get<double>("radius")),
      photons_per_pass_(params.get<int64_t>("photons")),
      max_depth_(params.get<int>("max_depth")),
      rr_depth_(params.get<int>("rr_depth")),
      threads_(params.get<int>("threads")),
      tile_size_(params.get<int>("tile_size")),
      seed_(params.get<uint64_t>("seed")),
      path_samples_(params.get<int>("path_samples")),
      path_samples_max_(params.get<int>("path_samples_max")),
      width_(scene.camera.film_width()),
      height_(scene.camera.film_height()),
      // §9.6: photons at every non-delta vertex, where the weights weigh them against path tracing
      tracer_(scene, max_depth_, kDefaultSpecularThreshold, seed_, threads_, DepositRule::NonDelta) {
  check_image_size(width_, height_);  // the parameters are checked by their declarations (methods.cpp)
  const size_t n = static_cast<size_t>(width_) * height_;
  if (photons_per_pass_ == 0) photons_per_pass_ = static_cast<int64_t>(n);  // §9.5
  px_.assign(n, PixelState{});
  // A camera path's vertices: max_depth_ bounces and, in a scene with Transparent BSDFs that
  // shadow rays pass, up to transparent_bounces + 1 passes through them (transparent_done), which
  // count no bounce.
  eye_stride_ = max_depth_ + (scene.has_transparent_shadows() ? std::max(scene.transparent_bounces, 0) + 1 : 0);
  const size_t tiles_x = (width_ + tile_size_ - 1) / tile_size_, tiles_y = (height_ + tile_size_ - 1) / tile_size_;
  tile_eye_.resize(tiles_x * tiles_y);
  eye_at_.assign(n, 0);
  eye_count_.assign(n, 0);
  eye_origin_.assign(n, Vec3());
  pass_direct_.assign(n, RGB(0.0f));
  pass_npm_.assign(n, 0.0);
  pass_npm_full_.assign(n, 0.0);
  pass_npt_.assign(n, 1);
  pass_traced_.assign(n, 0);
  first_r_.assign(n, 0.0f);
  gather_m_.assign(n, 0.0f);
  gather_phi_.assign(n, RGB(0.0f));
  if (scene.light_set().empty()) stats_.extra["warning: no lights"] = 1;
  // Participating media ("Participating media" in msppm.h): grid media too, by the same
  // MediumSegment, photon walk and beam gather as SPPM.
  media_ = scene.has_media();
  if (media_) camera_media_ = CameraMedia(scene);  // a camera inside a Volume cube
  tracer_.set_media(media_);
  if (media_) {
    for (const Medium& m : scene.media) media_rgb_.push_back(rgb_channels(m));
    beams_.assign(n * kMaxBeams, EyeBeam{});
    n_beams_.assign(n, 0);
    vpx_.assign(n, VolumeState{});
    first_vr_.assign(n, 0.0f);
    gather_vm_.assign(n, 0.0f);
    gather_vphi_.assign(n, RGB(0.0f));
  }
}

Msppm::PathVertex Msppm::path_vertex(const EyeVertex& e) {
  PathVertex v;
  v.p = e.p;
  v.ng = e.ng;
  v.frame = &e.frame;
  v.material = e.material;
  v.uv = e.uv;
  v.delta = e.delta;
  v.mergeable = e.mergeable;
  return v;
}

const Msppm::PhotonTail& Msppm::tail(uint32_t index) const {
  // The chunk holding the block's first photon, or one after it (a chunk is rarely shorter than
  // a block: then a few steps).
  size_t c = tail_block_[index >> kTailBlockBits];
  while (tail_base_[c + 1] <= index) ++c;
  return chunk_tails_[c][index - tail_base_[c]];
}

size_t Msppm::tile_of(size_t pixel) const {
  const size_t tiles_x = (width_ + tile_size_ - 1) / tile_size_;
  const size_t x = pixel % width_, y = pixel / width_;
  return (y / tile_size_) * tiles_x + x / tile_size_;
}

double Msppm::n_pm(size_t pixel) const {
  return static_cast<double>(photons_per_pass_) * M_PI * px_[pixel].r2;
}

// ---- Camera paths: measurement points at every vertex, path tracing with NEE ----
// Sample counts of the pass (§9.4.5, §9.5 step 5): n_pt path-tracing samples at the pixel, the
// first of them the camera path that also carries the measurement points. n_pt is fixed before
// the pass's random numbers are drawn (from the pixel's earlier passes, see path_samples()), so
// that the counts in the weights are those of the samples actually taken and do not depend on
// this pass's samples.
bool Msppm::eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause, std::atomic<int64_t>& rays_out,
                     std::atomic<int64_t>& invalid_out) {
  const LightSet& lights = scene_.light_set();
  const bool split_lobes = scene_.lights_hidden_from_some_lobes();
  return eye_tiles_.run(
      width_, height_, tile_size_, threads_, sink, may_pause,
      [&](const Tile& tile) {
        int64_t rays = 0, invalid = 0;
        std::vector<PathVertex> y;
        std::vector<double> cy(static_cast<size_t>(eye_stride_) + 2, 0.0);  // c_j of the path so far
        std::vector<EyeVertex> scratch(static_cast<size_t>(eye_stride_));   // vertices of the extra PT paths
        std::vector<EyeVertex> path(static_cast<size_t>(eye_stride_));      // the measurement path's
        std::vector<EyeVertex> list;                                        // the tile's paths
        // One camera path from `film`/`lens` samples of `rng`: weighted PT contribution returned,
        // vertices written to ev[0 .. count). `ratio` = n_pm / n_pt (see light_weight). With
        // `beams` (the pixel's measurement path, in media), its segments through scattering media
        // before its first mergeable vertex, n_beams of them, and the footprint radius first_vr at
        // the first one's middle.
        auto trace = [&](Rng& rng, int px, int py, double ratio, EyeVertex* ev, int& count, float& first_r,
                         Vec3& origin, EyeBeam* beams, uint8_t* n_beams, float* first_vr) -> RGB {
            const Vec2 film(px + scene_.camera.crop_x + rng.uniform(), py + scene_.camera.crop_y + rng.uniform());
            const Vec2 lens(rng.uniform(), rng.uniform());
            Ray ray = scene_.camera.generate_ray(film, lens);
            origin = ray.o;
            count = 0;
            first_r = 0;
            RGB beta(1.0f), Ld(0.0f);
            float path_length = 0;
            // Cycles' per-kind switches: the kind of `ray` (the camera, then the lobe of the last
            // bounce; a light object crossed keeps it) and the last scattering vertex's lobes.
            // Emission found by the ray counts when the light is visible to that kind, and from a
            // light hidden from some kinds as f_V / p_V of the vertex (lobe_split.h), whose
            // density in the weights is p_V (msppm_detail::light_lobes).
            uint8_t kind = kRayCamera;
            LobeSplit prev;
            bool prev_delta = false;
            // The media the path is in (Cycles' volume stack), and the shadow test that follows
            // it through them and through Transparent BSDFs (paths/medium_walk.h), as pt's.
            MediumStack stack = media_ ? camera_media_.at(scene_, ray) : scene_.initial_medium_stack();
            ShadowTest shadow(scene_, media_ ? &stack : nullptr);
            if (n_beams) *n_beams = 0;
            bool past_mergeable = false;  // a (not crossed) mergeable vertex is behind: no more beams
            auto found = [&](const RGB& Le, int light) -> RGB {
              const Light& l = lights.lights()[light];
              if (!l.visible_to(kind)) return RGB(0.0f);
              if (kind == kRayCamera || l.visible_lobes == kAllLobes) return beta * Le;
              return prev.throughput(l.visible_lobes, prev_delta, beta) * Le;
            };
            // The camera-side vertices so far, as PathVertex (y[0] = camera).
            y.clear();
            PathVertex cam;
            cam.p = ray.o;
            y.push_back(cam);
            for (int depth = 1; depth <= max_depth_; ++depth) {
              ++rays;
              const auto hit = scene_.intersect(ray);
              // ---- Participating media along the segment: emission integrated exactly (only the
              // camera path finds it: weight 1), a beam for the volume photons before the first
              // mergeable vertex, and the transmittance to the surface behind (no free flight:
              // photons carry the light scattered in media) ----
              if (media_ && !stack.empty()) {
                const MediumSegment segment(stack, ray, 3, [&](int m) -> const MediumChannels& { return media_rgb_[m]; });
                const float t_end = hit ? hit->t : kInfinity;
                const ChannelValues em = segment.emission_integral(t_end);
                Ld += beta * RGB(em[0], em[1], em[2]);
                if (beams && segment.scatters && !past_mergeable && *n_beams < kMaxBeams) {
                  beams[(*n_beams)++] = make_beam(ray, t_end, {beta.r, beta.g, beta.b}, stack);
                  if (*n_beams == 1)  // the middle of the first beam (of a World medium: within the scene)
                    *first_vr = 2.0f * scene_.camera.pixel_footprint(
                                           path_length + 0.5f * std::min(t_end, length(scene_.bounds().diagonal())));
                }
                const ChannelValues T = segment.transmittance(t_end);
                beta *= RGB(T[0], T[1], T[2]);
                if (split_lobes) prev.beta *= RGB(T[0], T[1], T[2]);
              }
              if (!hit) {
                // ---- Environment seen by the path (technique "hit") ----
                if (lights.environment() >= 0) {
                  PathVertex lv;
                  lv.light = lights.environment();
                  lv.distant = true;
                  lv.dir = -ray.d;
                  y.push_back(lv);
                  Ld += found(lights.environment_radiance(ray), lv.light) *
                        static_cast<float>(light_weight(y, 0, cy[y.size() - 2], ratio));
                  y.pop_back();
                }
                break;
              }
              path_length += hit->t;
              if (hit->light >= 0) {
                // ---- Emission hit by the path (technique "hit") ----
                const RGB Le = lights.area_radiance(hit->light, -ray.d, hit->p, &hit->ray);
                if (!Le.is_black()) {
                  PathVertex lv;
                  lv.p = hit->p;
                  lv.ng = lights.lights()[hit->light].n;
                  lv.light = hit->light;
                  y.push_back(lv);
                  Ld += found(Le, hit->light) * static_cast<float>(light_weight(y, 0, cy[y.size() - 2], ratio));
                  y.pop_back();
                }
              }
              // Light Paths > Transparent reached: the surface's emission is seen, the path ends
              // (as paths/camera_path.h and trace_eye).
              if (transparent_done(scene_.transparent_bounces, ray.state) || count >= eye_stride_) break;
              const Bsdf bsdf = scene_.bsdf(*hit);
              if (bsdf.is_black()) break;
              const Vec3 wo = hit->frame.to_local(-ray.d);
              if (wo.z == 0) break;
              EyeVertex& e = ev[count++];
              e.p = hit->p;
              e.ng = hit->ng;
              e.n_smooth = hit->n_smooth;
              e.wo = -ray.d;
              e.frame = hit->frame;
              e.beta = beta;
              e.material = hit->material;
              e.uv = hit->uv;
              e.delta = bsdf.is_delta();
              e.mergeable = !e.delta;  // no diffuse/glossy classification (thesis §9.6)
              e.crossed = false;
              if (e.mergeable && first_r == 0) first_r = 2.0f * scene_.camera.pixel_footprint(path_length);
              PathVertex sv = path_vertex(e);
              y.push_back(sv);
              {
                // c_j = B_{j-1} / E_j for the new vertex y_j (see camera_prefix).
                const int j = static_cast<int>(y.size()) - 1;
                if (j == 1) {
                  cy[1] = 0.0;
                } else {
                  auto acc = [&](int i) -> const PathVertex& { return y[i]; };
                  const auto d = msppm_detail::densities(scene_, acc, j + 3);
                  const double B = (y[j - 1].mergeable ? 1.0 : 0.0) + (j - 1 == 1 ? 0.0 : d.L_inner(j - 2) * cy[j - 1]);
                  cy[j] = B / d.E(j);
                }
              }
              // ---- Next-event estimation (technique "nee"): the lobes that see the light ----
              if (!e.delta && !lights.empty()) {
                const float u_light = rng.uniform();
                const Vec2 u2(rng.uniform(), rng.uniform());
                if (auto ls = lights.sample_li(hit->p, u_light, u2); ls && ls->pdf > 0 && !ls->L.is_black()) {
                  const Vec3 wi = hit->frame.to_local(ls->wi);
                  const uint8_t vis = msppm_detail::light_lobes(scene_, ls->light);
                  const RGB f = bsdf.eval(wo, wi, TransportMode::Radiance, vis) * std::abs(wi.z);
                  if (!f.is_black()) {
                    ++rays;
                    const Light& l = lights.lights()[ls->light];
                    // The shared shadow test (paths/medium_walk.h): media's transmittance and
                    // Transparent BSDFs up to transparent_bounces, as pt's. A surface it passes is
                    // no vertex of the paths (the camera path and the photons cross it too).
                    if (media_) shadow.at_surface(hit->mesh, scene_.material(hit->material).interior, hit->ng, ray.d);
                    const ShadowChannels ch{.count = 3, .media = media_ ? media_rgb_.data() : nullptr, .state = hit->ray};
                    const ChannelValues T = shadow.transmittance(hit->p, &hit->ng, *ls, ch);
                    if (!is_blocked(T, 3)) {
                      PathVertex lv;
                      lv.light = ls->light;
                      if (l.is_infinite()) {
                        lv.distant = true;
                        lv.dir = -ls->wi;
                      } else {
                        // Where the light is at the pass's time (a moving lamp or mesh moves).
                        lv.p = l.type == LightType::Area ? hit->p + ls->wi * ls->dist : lights.position(ls->light);
                        lv.ng = l.type == LightType::Area ? ls->n : Vec3(0, 0, 0);
                      }
                      y.push_back(lv);
                      Ld += beta * f * RGB(T[0], T[1], T[2]) * ls->L *
                            static_cast<float>(light_weight(y, 1, cy[y.size() - 2], ratio) / ls->pdf);
                      y.pop_back();
                    }
                  }
                }
              }
              if (depth == max_depth_) break;
              // ---- Continue by BSDF sampling, Russian roulette ----
              const float uc = rng.uniform();
              const Vec2 u(rng.uniform(), rng.uniform());
              const auto bs = bsdf.sample(wo, uc, u);
              if (!bs || bs->pdf <= 0 || bs->f.is_black()) break;
              const Material& material = scene_.material(hit->material);
              // A light object, a volume boundary (a clear Transparent BSDF, which shadow rays pass
              // filtered, is a transparent pass below, as trace_eye's).
              const bool crossed = material.is_pass_through() && !material.transparent_shadow();
              const Vec3 wi_world = hit->frame.to_world(bs->wi);
              // A sample through a surface with an interior medium (glass of murky water, a volume
              // boundary) crosses it.
              if (media_ && material.interior >= 0 && (dot(wi_world, hit->ng) < 0) == (dot(ray.d, hit->ng) < 0))
                stack.cross(hit->mesh, material.interior, dot(ray.d, hit->ng) < 0);
              ray = scattered_ray(hit->p, hit->ng, wi_world, ray, crossed, *bs);
              if (crossed) {
                // A light object or a volume boundary that casts no shadow: shadow rays pass it,
                // so it is no vertex of the paths through it either (nor of the photons',
                // photon_walk.h); the kind and lobe state of the vertex before stay.
                if (!material.casts_shadow) {
                  e.crossed = true;
                  y.pop_back();
                }
              } else if (is_transparent_pass(*bs) && material.transparent_shadow()) {
                // Through a Transparent BSDF that shadow rays pass: no vertex of the paths that go
                // on (as next-event estimation from the vertex before passed it), so it leaves y
                // and the kind and lobe state of the vertex before stay (as pt's).
                e.crossed = true;
                y.pop_back();
                if (split_lobes) prev.beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
                // A transparent bounce, counted against Light Paths > Transparent only (the ray's
                // state counts it, scattered_ray), not a bounce: Cycles' path_state_next, as the
                // other methods.
                --depth;
              } else {
                past_mergeable = past_mergeable || e.mergeable;
                kind = bs->lobe;
                prev_delta = bs->delta;
                if (split_lobes) {
                  prev.beta = beta;
                  prev.lobe = bs->lobe;
                  if (!bs->delta) prev.fill(bsdf, wo, bs->wi);
                }
              }
              beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
              if (depth >= rr_depth_) {
                const float q = std::max(0.05f, 1.0f - beta.max_component());
                if (rng.uniform() < q) break;
                beta = beta / (1.0f - q);
                if (split_lobes) prev.beta = prev.beta / (1.0f - q);
              }
            }
            if (!Ld.is_finite()) {
              ++invalid;
              Ld = RGB(0.0f);
            }
            return Ld;
        };
        for (int py = tile.y0; py < tile.y1; ++py)
          for (int px = tile.x0; px < tile.x1; ++px) {
            const size_t pixel = static_cast<size_t>(py) * width_ + px;
            // Pass 0 without a given radius has no radius yet: no density estimation weight
            // (PT takes weight 1), and the gathering of that pass uses the same 0.
            const double npm = n_pm(pixel);
            const int npt = pass_npt_[pixel];
            // Eq. 9.19 (bias ignored) depends on the counts only through n_pm / n_pt: every
            // weight of this pixel and pass, PT's here and the photons' in the gathering, takes
            // this one ratio.
            const double ratio = npm / npt;
            pass_npm_[pixel] = ratio;
            pass_npm_full_[pixel] = npm;
            Rng rng = Rng::for_key(seed_, scene_.camera.pixel_key(px, py), pass);
            int count = 0;
            float first_r = 0;
            RGB Ld = trace(rng, px, py, ratio, path.data(), count, first_r, eye_origin_[pixel],
                           media_ ? &beams_[pixel * kMaxBeams] : nullptr, media_ ? &n_beams_[pixel] : nullptr,
                           media_ ? &first_vr_[pixel] : nullptr);
            eye_at_[pixel] = static_cast<uint32_t>(list.size());
            list.insert(list.end(), path.begin(), path.begin() + count);
            eye_count_[pixel] = count;
            first_r_[pixel] = first_r;
            // The other n_pt - 1 path-tracing samples (§9.5 step 5), their own random stream.
            int traced = 1;
            if (npt > 1) {
              Rng extra = Rng::for_key(seed_ ^ 0x707473616d70ULL, pixel, pass);
              int c2;
              float r2;
              Vec3 o2;
              for (int s = 1; s < npt; ++s, ++traced) Ld += trace(extra, px, py, ratio, scratch.data(), c2, r2, o2, nullptr, nullptr, nullptr);
            }
            pass_traced_[pixel] = traced;
            pass_direct_[pixel] = Ld / static_cast<float>(npt);  // (1 / n_i) sum_j w_i f / p_i (eq. 9.5)
          }
        // The tile's list at its size (a longer one than the tile had before reallocates once).
        tile_eye_[tile_of(static_cast<size_t>(tile.y0) * width_ + tile.x0)].assign(list.begin(), list.end());
        rays_out += rays;
        invalid_out += invalid;
      });
}

// ---- Photon pass with whole paths recorded, chunked as PhotonTracer::trace ----
void Msppm::photon_pass(uint64_t pass, PhotonPassStats& stats) {
  const int64_t count = photons_per_pass_;
  const int64_t chunk = PhotonTracer::kChunk;
  const size_t n_chunks = static_cast<size_t>((count + chunk - 1) / chunk);
  if (chunk_photons_.size() < n_chunks) {
    chunk_photons_.resize(n_chunks);
    chunk_tails_.resize(n_chunks);
  }
  if (media_ && chunk_volume_.size() < n_chunks) chunk_volume_.resize(n_chunks);
  std::atomic<int64_t> rays{0}, invalid{0};
  parallel_for(n_chunks, threads_, [&](size_t lo, size_t hi) {
    int64_t r = 0, inv = 0;
    // A chunk's whole photon paths, needed only until its tails are made: one record per worker,
    // not one kept per chunk (docs/adaptive-and-msppm.md "Memory").
    PhotonPathRecord record;
    for (size_t c = lo; c < hi; ++c) {
      chunk_photons_[c].clear();
      record.clear();
      if (media_) chunk_volume_[c].clear();
      Rng rng = Rng::for_key(seed_ ^ 0x6d7370706dULL, c, pass);
      RngSamples u(rng);
      const int64_t begin = static_cast<int64_t>(c) * chunk, end = std::min(count, begin + chunk);
      for (int64_t k = begin; k < end; ++k)
        r += tracer_.trace_path(u, 0, chunk_photons_[c], inv, &record, nullptr, nullptr,
                                media_ ? &chunk_volume_[c] : nullptr);
      photon_tails(record, chunk_tails_[c]);  // light-side sums, once per path vertex
    }
    rays += r;
    invalid += inv;
  });
  // Photons in chunk order; a photon's `index` is its position, its tail found in its chunk's
  // list (tail(): not copied into one list beside them, 128 bytes a photon).
  photons_.clear();
  tail_base_.assign(1, 0);
  for (size_t c = 0; c < n_chunks; ++c) {
    photons_.insert(photons_.end(), chunk_photons_[c].begin(), chunk_photons_[c].end());
    tail_base_.push_back(photons_.size());
  }
  for (size_t i = 0; i < photons_.size(); ++i) photons_[i].index = static_cast<uint32_t>(i);
  tail_block_.assign((photons_.size() >> kTailBlockBits) + 1, 0);
  for (size_t b = 0, c = 0; b < tail_block_.size(); ++b) {
    while (c + 1 < n_chunks && tail_base_[c + 1] <= (b << kTailBlockBits)) ++c;
    tail_block_[b] = static_cast<uint32_t>(c);
  }
  if (media_) concatenate_chunks(chunk_volume_, n_chunks, threads_, volume_photons_);
  stats.emitted = count;
  stats.stored = static_cast<int64_t>(photons_.size());
  stats.rays = rays;
  stats.invalid = invalid;
}

void Msppm::iterate(ProgressSink* sink) {
  const auto start = clock_type::now();
  const uint64_t pass = static_cast<uint64_t>(stats_.passes);
  // Motion blur (thesis ch. 7): one shutter time per pass, shared by its eye paths and photons.
  const ShutterTime at_time(scene_.pass_shutter_time(seed_, pass));
  const size_t n_pixels = px_.size();
  // The first pass stops between eye tiles and between its stages when the sink asks (Msppm.h).
  const bool may_pause = sink && stats_.passes == 0;
  PassPause open_pass(open_, stats_.seconds, start, sink, may_pause);
  std::atomic<int64_t>& rays = open_pass.rays;
  std::atomic<int64_t>& invalid = open_pass.invalid;

  // ---- 1. Camera paths (measurement points + weighted path tracing) ----
  // Radii start from the footprint before the first MIS evaluation needs them.
  const float min_r = 1e-5f * std::max(1e-3f, length(scene_.bounds().diagonal()));
  const bool new_pass = stage_ == Stage::Start;
  if (pass == 0 && new_pass)
    for (size_t i = 0; i < n_pixels; ++i) px_[i].r2 = radius_ > 0 ? radius_ * radius_ : 0.0;
  // Pixels whose camera path meets no photon-diffuse vertex in the first pass (light or sky
  // seen directly, paths through glass that leave) still need a radius: every pass weights
  // their later paths against density estimation, and a zero radius would give path tracing
  // the full weight of caustic paths (fireflies). They take the mean footprint radius.
  auto set_new_radii = [&] {
    if (fallback_r_ == 0) {
      double sum = 0, cnt = 0;
      for (size_t i = 0; i < n_pixels; ++i)
        if (first_r_[i] > 0) { sum += first_r_[i]; cnt += 1; }
      if (cnt > 0) fallback_r_ = sum / cnt;
    }
    for (size_t i = 0; i < n_pixels; ++i)
      if (px_[i].r2 == 0) {
        const double r0 = first_r_[i] > 0 ? first_r_[i] : fallback_r_;
        if (r0 > 0) {
          const double r = std::max(r0, static_cast<double>(min_r));
          px_[i].r2 = r * r;
        }
      }
  };
  // Path-tracing samples of this pass per pixel (§9.4.5, §9.5 step 5): the number of photons
  // the pixel can expect to find this pass, M = N_e pi R^2 * (photon density seen so far), i.e.
  // (photons found in earlier passes / sum of their R^2) * R^2 -- the local photon count that
  // grows as O(N^alpha) over N photon passes, which makes the path-tracing samples N^alpha
  // (eq. 9.23). Rounded, at least 1 (paths that only path tracing can make, e.g. a light seen
  // directly, need a sample in every pass), at most path_samples_max. Fixed before the pass so
  // that these counts, used in every weight of the pass, are the samples actually taken.
  for (size_t i = 0; i < n_pixels && new_pass; ++i) {
    int npt = 1;
    if (path_samples_ > 0) {
      npt = path_samples_;
    } else if (px_[i].r2_sum > 0) {
      const double expected = px_[i].found_sum / px_[i].r2_sum * px_[i].r2;
      npt = static_cast<int>(std::clamp(std::lround(expected), 1L, static_cast<long>(path_samples_max_)));
    }
    pass_npt_[i] = npt;
  }
  if (new_pass) stage_ = pass == 0 && radius_ == 0 ? Stage::Radii : Stage::Eye;
  // A whole eye pass: its path tracing becomes the preview while the first pass stays open.
  const auto keep_preview = [&] {
    if (may_pause && preview_.empty()) preview_ = pass_direct_;
  };
  // One eye pass, then the radii from it; false when it paused (the pass stays open).
  const auto eye_stage = [&](Stage next) {
    const auto t_eye = clock_type::now();
    const bool done = eye_pass(pass, sink, may_pause, rays, invalid);
    if (sink && sink->cancelled()) return false;
    stats_.extra["eye seconds"] += seconds_since(t_eye);
    if (!done) {
      open_pass.leave_open();
      return false;
    }
    set_new_radii();
    keep_preview();
    stage_ = next;
    return !open_pass.pause_here();
  };
  // The footprint radius comes from the camera path itself: the first pass's paths are traced
  // once for it (same random streams, results discarded), so that even the first pass weights
  // path tracing against density estimation. Without this the first pass would be plain path
  // tracing, whose caustic fireflies then fade only as 1 / passes.
  if (stage_ == Stage::Radii && !eye_stage(Stage::Eye)) return;
  if (stage_ == Stage::Eye && !eye_stage(Stage::Photons)) return;

  // ---- 2. Photon pass ----
  if (stage_ == Stage::Photons) {
    const auto t_trace = clock_type::now();
    photon_pass(pass, open_ps_);
    stats_.extra["trace seconds"] += seconds_since(t_trace);
    stage_ = Stage::Gather;
    if (open_pass.pause_here()) return;
  }
  const PhotonPassStats ps = open_ps_;
  stage_ = Stage::Start;  // this call ends the pass
  open_pass.close();
  std::vector<RGB>().swap(preview_);

  // ---- 3. Gathering at every measurement point, weighted by the balance heuristic ----
  const auto t_lookup = clock_type::now();
  // The grid's cells are twice the largest radius of a pixel that queries this pass (one with a
  // measurement point and a density-estimation weight): pixels whose path met no
  // photon-diffuse vertex keep their initial radius (their count never grows), and letting
  // them set the cell size made every query scan many times the photons it finds.
  double max_r2 = 0, sum_rq = 0, n_q = 0;
  for (size_t i = 0; i < n_pixels; ++i) {
    if (!(pass_npm_[i] > 0)) continue;
    const EyeVertex* ev = eye_vertices(i);
    bool any = false;
    for (int j = 0; j < eye_count_[i] && !any; ++j) any = ev[j].mergeable;
    if (!any) continue;
    max_r2 = std::max(max_r2, px_[i].r2);
    sum_rq += std::sqrt(px_[i].r2);
    n_q += 1;
  }
  stats_.extra["max radius / mean radius"] = n_q > 0 && sum_rq > 0 ? std::sqrt(max_r2) / (sum_rq / n_q) : 0.0;
  const float max_r = static_cast<float>(std::sqrt(max_r2));
  const bool have_photons = !photons_.empty() && max_r > 0;
  if (have_photons) grid_.build(photons_, 2.0f * max_r, PhotonHashMode::Exact, seed_, pass, threads_);
  std::atomic<int64_t> points{0}, found{0};
  parallel_for(n_pixels, threads_, [&](size_t lo, size_t hi) {
    std::vector<PathVertex> ycam(static_cast<size_t>(eye_stride_) + 1), ytmp(ycam.size());
    std::vector<double> cpre(static_cast<size_t>(eye_stride_) + 1), ctmp(cpre.size());
    std::vector<int> at(static_cast<size_t>(eye_stride_));
    std::vector<const Photon*> hits;
    int64_t local_points = 0, local_found = 0;
    for (size_t i = lo; i < hi; ++i) {
      gather_m_[i] = 0;
      gather_phi_[i] = RGB(0.0f);
      if (!have_photons || px_[i].r2 <= 0) continue;
      const float R = static_cast<float>(std::sqrt(px_[i].r2));
      const double npm = pass_npm_[i];
      if (!(npm > 0)) continue;  // weight 0 for every photon (pass 0, see eye_pass)
      const EyeVertex* ev = eye_vertices(i);
      // The camera path as path vertices y_0 .. y_n, those it crossed (EyeVertex::crossed) left
      // out, and its prefix sums c_j; at[a]: the index of ev[a] in it (a crossed one: where it
      // would be, as the end of the paths that merge there).
      const int count = eye_count_[i];
      ycam[0] = PathVertex();
      ycam[0].p = eye_origin_[i];
      int n = 0;
      for (int a = 0; a < count; ++a) {
        at[a] = n + 1;
        if (!ev[a].crossed) ycam[++n] = path_vertex(ev[a]);
      }
      if (n > 0) camera_prefix(ycam.data(), n, cpre.data());
      // Paths with a medium vertex are the first mergeable vertex's (msppm.h, "Participating
      // media"): photons that scattered in a medium count there with weight 1, nowhere else. A
      // crossed vertex is the first of the paths that end there only: merges up to the first
      // mergeable vertex not crossed take them.
      int medium_merges = count - 1;  // the last vertex that takes them
      for (int a = 0; a < count; ++a)
        if (ev[a].mergeable && !ev[a].crossed) {
          medium_merges = a;
          break;
        }
      double m = 0;
      RGB phi(0.0f);
      for (int j = 0; j < count; ++j) {
        const EyeVertex& e = ev[j];
        if (!e.mergeable) continue;
        ++local_points;
        // A crossed vertex ends the paths merged there: the prefix up to it, then it.
        const PathVertex* yj = ycam.data();
        const double* cj = cpre.data();
        if (e.crossed) {
          std::copy(ycam.begin(), ycam.begin() + at[j], ytmp.begin());
          ytmp[at[j]] = path_vertex(e);
          camera_prefix(ytmp.data(), at[j], ctmp.data());
          yj = ytmp.data();
          cj = ctmp.data();
        }
        const Bsdf bsdf = scene_.bsdf(e.material, e.uv, e.frame, e.ng, e.n_smooth);  // as Scene::bsdf(hit)
        const Vec3 wo = e.frame.to_local(e.wo);
        // The grid's own copy of the photons (bucket order, read in sequence); `index` finds the
        // tail, a cache miss each: found photons are collected and their tails prefetched
        // while the query goes on, then weighted.
        hits.clear();
        const bool transmits = bsdf.transmits();
        grid_.query(e.p, R, [&](const Photon& ph, float, float) {
          const Vec3 wi = e.frame.to_local(ph.wi);
          if (!photon_gather_side(transmits, wo, wi)) return;
          m += 1;
          const char* tp = reinterpret_cast<const char*>(&tail(ph.index));
          __builtin_prefetch(tp);
          __builtin_prefetch(tp + 64);
          hits.push_back(&ph);
        });
        for (const Photon* ph : hits) {
          const PhotonTail& tail = this->tail(ph->index);
          if (tail.through_medium && j > medium_merges) continue;  // another vertex's path
          // The photon's lobes (the kinds that see where it came from, photon_tracer.cpp), and a
          // normal map's bent cosine (gather_shading_correction), as SPPM's gather.
          const RGB f = bsdf.eval(wo, e.frame.to_local(ph->wi), TransportMode::Radiance, ph->lobes) *
                        gather_shading_correction(ph->wi, e.n_smooth, e.frame.n);
          if (f.is_black()) continue;
          // Balance heuristic of density estimation at y_t for the full path the photon closes
          // (eq. 9.5), in O(1) from the camera prefix and the photon's tail; 1 for a path with a
          // medium vertex at its first mergeable vertex.
          const double w = tail.through_medium ? 1.0 : merge_weight(yj, at[j], cj, tail, npm);
          phi += e.beta * f * ph->power * static_cast<float>(w);  // eq. 7.4, weighted (§9.5 step 4)
        }
      }
      gather_m_[i] = static_cast<float>(m);
      gather_phi_[i] = phi;
      local_found += static_cast<int64_t>(m);
    }
    points += local_points;
    found += local_found;
  });
  if (media_) volume_gather(pass);
  stats_.extra["lookup seconds"] += seconds_since(t_lookup);

  // ---- 4. Update (SPPM, eq. 7.2-7.5), path-tracing samples accumulated ----
  emitted_total_ += ps.emitted;
  int64_t bad = 0;
  for (size_t i = 0; i < n_pixels; ++i) {
    PixelState& s = px_[i];
    RGB phi = gather_phi_[i];
    if (!phi.is_finite()) {
      ++bad;
      phi = RGB(0.0f);
    }
    if (have_photons && pass_npm_[i] > 0 && s.r2 > 0) {  // this pass gathered with radius sqrt(r2)
      s.found_sum += gather_m_[i];
      s.r2_sum += s.r2;
    }
    const PhotonStatsUpdate u = progressive_update(s.n, s.r2, gather_m_[i], alpha_);
    for (int c = 0; c < 3; ++c) {
      s.tau[c] = (s.tau[c] + phi[c]) * u.ratio;  // eq. 7.5
      s.direct[c] += pass_direct_[i][c];
    }
    s.n = u.n_new;
    s.r2 = u.r2_new;
    if (media_)  // the beam radiance estimate's radius and flux
      bad += progressive_beam_update(vpx_[i].vn, vpx_[i].vr2, vpx_[i].vtau, gather_vphi_[i], gather_vm_[i], alpha_);
  }
  stats_.passes += 1;

  // ---- Statistics ----
  int64_t traced = 0;
  for (size_t i = 0; i < n_pixels; ++i) traced += pass_traced_[i];
  double sum_r = 0, n_r = 0, pt = 0, pm = 0;
  for (size_t i = 0; i < n_pixels; ++i) {
    const PixelState& s = px_[i];
    if (s.r2 > 0) { sum_r += std::sqrt(s.r2); n_r += 1; }
    pt += RGB(float(s.direct[0]), float(s.direct[1]), float(s.direct[2])).luminance() / stats_.passes;
    if (s.r2 > 0 && emitted_total_ > 0)
      pm += RGB(float(s.tau[0]), float(s.tau[1]), float(s.tau[2])).luminance() / (emitted_total_ * M_PI * s.r2);
  }
  stats_.rays += rays + ps.rays;
  stats_.paths += ps.emitted + traced;
  stats_.invalid_samples += invalid + bad + ps.invalid;
  stats_.extra["photons traced"] += static_cast<double>(ps.emitted);
  stats_.extra["photons stored"] += static_cast<double>(ps.stored);
  stats_.extra["photon rays"] += static_cast<double>(ps.rays);
  stats_.extra["average radius"] = n_r > 0 ? sum_r / n_r : 0.0;
  stats_.extra["measurement points per pixel"] = static_cast<double>(points) / static_cast<double>(n_pixels);
  stats_.extra["photons found per point"] = points > 0 ? static_cast<double>(found) / static_cast<double>(points) : 0.0;
  stats_.extra["path tracing samples"] += static_cast<double>(traced);
  stats_.extra["path tracing samples per pixel and pass"] =
      stats_.extra["path tracing samples"] / (static_cast<double>(n_pixels) * stats_.passes);
  stats_.extra["path tracing share"] = pt + pm > 0 ? pt / (pt + pm) : 0.0;
  if (media_) {  // the beam radiance estimate's figures, as SPPM's
    double sum_vr = 0, n_vr = 0;
    for (const VolumeState& s : vpx_)
      if (s.vr2 > 0) { sum_vr += std::sqrt(s.vr2); n_vr += 1; }
    stats_.extra["volume photons stored"] += static_cast<double>(volume_photons_.size());
    stats_.extra["average cylinder radius"] = n_vr > 0 ? sum_vr / n_vr : 0.0;
  }
  stats_.seconds += seconds_since(start);
}

RGB Msppm::pixel_radiance(size_t i) const {
  // direct: per pass the mean of its n_pt weighted path-tracing samples, summed over passes.
  const PixelState& s = px_[i];
  RGB L = progressive_radiance(s.direct, s.tau, s.r2, stats_.passes, emitted_total_);
  if (media_ && vpx_[i].vr2 > 0 && emitted_total_ > 0) {
    // The beam radiance estimate: the cylinder's flux over pi R^2 and the photons emitted (§5.6).
    const VolumeState& v = vpx_[i];
    const double k = 1.0 / (static_cast<double>(emitted_total_) * M_PI * v.vr2);
    for (int c = 0; c < 3; ++c) L[c] += static_cast<float>(v.vtau[c] * k);
  }
  return L;
}

// ---- The beam radiance estimate of the pixels' beams (beam_estimate.h's gather_pixel_beams, SPPM's) ----
// No cancellation inside: the pass's update follows unconditionally (iterate).
void Msppm::volume_gather(uint64_t pass) {
  gather_pixel_beams(
      scene_, volume_photons_, volume_grid_, PixelBeams{beams_, kMaxBeams, n_beams_, first_vr_}, radius_,
      [&](size_t i) -> double& { return vpx_[i].vr2; }, seed_, pass, threads_, 3, {},
      [&](int med) -> const MediumChannels& { return media_rgb_[med]; },
      [](const EyeBeam& b, const Photon& ph, const ChannelValues& T, const ChannelValues& f) {
        return RGB(b.beta[0] * T[0] * f[0], b.beta[1] * T[1] * f[1], b.beta[2] * T[2] * f[2]) * ph.power;
      },
      gather_vm_, gather_vphi_);
}

void Msppm::develop(Film& film) const {
  if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
  Pass& combined = film.add_pass(pass::kCombined, 3);
  Pass& radius = film.add_pass(pass::kRadius, 1);
  Pass& count = film.add_pass(pass::kPhotonCount, 1);
  Pass& path_tracing = film.add_pass(pass::kPathTracing, 3);
  const double passes = static_cast<double>(std::max<int64_t>(stats_.passes, 1));
  if (first_pass_open()) {
    // The first pass paused before its end: a preview, its first eye pass's path tracing (where
    // its tiles have reached, until that pass is whole); nothing is left of it after the pass.
    for (size_t i = 0; i < px_.size(); ++i) {
      const RGB L = !preview_.empty() ? preview_[i] : eye_tiles_.done(i) ? pass_direct_[i] : RGB(0.0f);
      for (int c = 0; c < 3; ++c) combined.data[3 * i + c] = path_tracing.data[3 * i + c] = L[c];
      radius.data[i] = count.data[i] = 0.0f;
    }
    return;
  }
  for (size_t i = 0; i < px_.size(); ++i) {
    const RGB L = pixel_radiance(i);
    for (int c = 0; c < 3; ++c) {
      combined.data[3 * i + c] = L[c];
      path_tracing.data[3 * i + c] = static_cast<float>(px_[i].direct[c] / passes);
    }
    radius.data[i] = static_cast<float>(std::sqrt(px_[i].r2));
    count.data[i] = static_cast<float>(px_[i].n);
  }
}

}  // namespace gp
