// One-sample-per-pixel progressive estimate, shared by the path tracers (RGB and spectral):
// each pass visits every pixel in parallel tiles, draws the pixel's own random stream
// Rng::for_key(seed, pixel, pass) (so the image does not depend on the thread count), a
// box-filtered film position and a lens sample, and averages what the estimator returns.
// NaN/Inf estimates are discarded and counted: they never reach a pass.
// An estimator that returns a PixelSample also reports the sample's alpha (coverage), averaged
// into develop_alpha(); one that returns RGB counts as covering its pixel.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <chrono>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/film.h"
#include "core/parallel.h"
#include "core/progress.h"
#include "core/rng.h"
#include "core/sampler.h"
#include "scene/camera.h"
#include "scene/scene.h"

namespace gp {

// start_pixel (scene/camera.h) from the Sobol pattern (core/sampler.h; pt, spt, spt-hero with
// sampling_pattern sobol): `sampler` becomes pixel (x, y)'s SobolSampler for sample `pass`, and
// the film position (through the pixel filter, in the whole image's pixels), the lens sample and
// the shutter time are its camera dimensions; the start's stream is the pixel's PCG32 stream
// (as camera.h's), which the sampler continues past its dimensions.
inline PixelStart start_pixel(const Camera& camera, uint64_t seed, uint64_t pass, int x, int y, SobolSampler& sampler) {
  const size_t key = camera.pixel_key(x, y);
  PixelStart s{Rng::for_key(seed, key, pass), {}, {}, 0.0f};
  sampler = SobolSampler(seed, key, pass, s.rng);
  const Vec2 u = sampler.get2d(kDimFilter);
  const float px = static_cast<float>(x + camera.crop_x), py = static_cast<float>(y + camera.crop_y);
  s.film = camera.filter.is_default_box() ? Vec2(px + u.x, py + u.y)
                                          : Vec2(camera.filter.sample(px, u.x), camera.filter.sample(py, u.y));
  s.lens = sampler.get2d(kDimLens);
  if (camera.motion_blur) s.time = sampler.get1d(kDimTime);
  return s;
}

// One camera sample: its radiance and its alpha (0 where the camera ray escaped to a transparent
// background, else 1).
struct PixelSample {
  RGB L;
  float alpha = 1.0f;
};

class PixelEstimate {
 public:
  // `camera` (optional) gives each pixel's random stream and film position (camera.h
  // start_pixel: a crop window's pixels take what they take in the whole image); without it
  // the key is the pixel's index.
  PixelEstimate(int width, int height, const Camera* camera = nullptr)
      : width_(width), height_(height), camera_(camera), sum_(static_cast<size_t>(width) * height * 3, 0.0),
        samples_(static_cast<size_t>(width) * height, 0), alpha_(static_cast<size_t>(width) * height, 0.0) {}

  // One pass: estimate(rng, film, lens, rays) -> RGB per pixel. Updates `stats` (passes,
  // paths, rays, shadow rays, invalid samples, seconds). A cancelled pass leaves the pixels it
  // did not reach with one sample fewer.
  template <typename Estimator>
  void run_pass(uint64_t seed, int tile_size, int threads, ProgressSink* sink, Stats& stats,
                const Estimator& estimate) {
    run_pass_tiles(seed, tile_size, threads, sink, stats,
                   [&](PixelStart* starts, SobolSampler*, size_t n, RayCounts& rays, PixelSample* out) {
                     for (size_t i = 0; i < n; ++i) {
                       const auto sample = estimate(starts[i].rng, starts[i].film, starts[i].lens, rays);
                       if constexpr (std::is_same_v<std::decay_t<decltype(sample)>, PixelSample>) out[i] = sample;
                       else out[i] = PixelSample{sample, 1.0f};
                     }
                   });
  }

  // The same pass with the estimator called once per tile, so that it can trace the tile's
  // camera rays together (Scene::intersect_coherent): estimate_tile(starts, sobol, n, rays, out)
  // fills out[i] from starts[i], the PixelStart of the tile's i-th pixel in row order, and with
  // the Sobol pattern (a camera given) from sobol[i], its sampler; sobol is null otherwise.
  // When the sink asks to pause (ProgressSink::pause), the pass stops at a tile and the next
  // call goes on with the tiles it has not done, with the same pass index: the image is the same
  // as without the pause, and in between every pixel's mean is of the samples it has.
  template <typename TileEstimator>
  void run_pass_tiles(uint64_t seed, int tile_size, int threads, ProgressSink* sink, Stats& stats,
                      const TileEstimator& estimate_tile, SamplingPattern pattern = SamplingPattern::Independent) {
    const bool sobol = pattern == SamplingPattern::Sobol && camera_;
    const auto start = std::chrono::steady_clock::now();
    const uint64_t pass = static_cast<uint64_t>(stats.passes);
    std::atomic<int64_t> closest{0}, shadow{0}, paths{0}, invalid{0};
    const int tiles_x = (width_ + tile_size - 1) / tile_size;
    if (tile_done_.empty()) {  // a new pass
      tile_done_.assign(static_cast<size_t>(tiles_x) * ((height_ + tile_size - 1) / tile_size), 0);
      tiles_left_ = tile_done_.size();
    }
    std::atomic<bool> paused{false};
    std::atomic<size_t> tiles_now{0};  // tiles this call did
    parallel_for_tiles(
        width_, height_, tile_size, threads,
        [&](const Tile& tile) {
          const size_t index = static_cast<size_t>(tile.y0 / tile_size) * tiles_x + tile.x0 / tile_size;
          if (index < tile_done_.size() && tile_done_[index]) return;  // done before a pause
          RayCounts tile_rays;
          int64_t tile_invalid = 0;
          std::vector<PixelStart> starts;
          std::vector<SobolSampler> samplers(sobol ? static_cast<size_t>(tile.x1 - tile.x0) * (tile.y1 - tile.y0) : 0);
          for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x)
              starts.push_back(sobol     ? start_pixel(*camera_, seed, pass, x, y, samplers[starts.size()])
                               : camera_ ? start_pixel(*camera_, seed, pass, x, y)
                                         : start_pixel(seed, static_cast<size_t>(y) * width_ + x, pass, x, y));
          std::vector<PixelSample> samples(starts.size());
          estimate_tile(starts.data(), sobol ? samplers.data() : nullptr, starts.size(), tile_rays, samples.data());
          size_t k = 0;
          for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x, ++k) {
              const size_t pixel = static_cast<size_t>(y) * width_ + x;
              const RGB& L = samples[k].L;
              alpha_[pixel] += samples[k].alpha;
              ++samples_[pixel];
              if (!L.is_finite()) {
                ++tile_invalid;
                continue;
              }
              sum_[3 * pixel] += L.r;
              sum_[3 * pixel + 1] += L.g;
              sum_[3 * pixel + 2] += L.b;
            }
          closest += tile_rays.closest;
          shadow += tile_rays.shadow;
          paths += static_cast<int64_t>(starts.size());
          invalid += tile_invalid;
          if (index < tile_done_.size()) {
            tile_done_[index] = 1;
            tiles_now.fetch_add(1, std::memory_order_relaxed);
          }
        },
        [sink, &paused, &tiles_now] {
          if (!sink) return false;
          if (sink->cancelled() || paused.load(std::memory_order_relaxed)) return true;
          // At least one tile a call, so that a caller pausing early still moves on.
          if (tiles_now.load(std::memory_order_relaxed) == 0 || !sink->pause()) return false;
          paused = true;
          return true;
        });
    tiles_left_ -= std::min(tiles_left_, tiles_now.load());
    // A pause leaves the pass open; a cancel ends it (its unreached pixels one sample short).
    const bool finished = tiles_left_ == 0 || !paused.load() || (sink && sink->cancelled());
    if (finished) {
      tile_done_.clear();
      stats.passes += 1;
    }
    stats.rays += closest + shadow;
    stats.shadow_rays += shadow;
    stats.paths += paths;
    stats.invalid_samples += invalid;
    stats.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  // One pass of a camera-path tracer (pt, spt, spt-hero): a tile's camera rays traced together
  // (Embree packets: the same hits, several times faster than one by one; holdouts applied),
  // then each path alone from its first hit: sample(ray, sampler, rays, first_hit) -> PixelSample,
  // generic over the sampler (core/sampler.h): the pixel's SobolSampler with the Sobol pattern,
  // else an IndependentSampler over its stream.
  template <typename Sample>
  void run_camera_pass(const Scene& scene, uint64_t seed, int tile_size, int threads, ProgressSink* sink,
                       Stats& stats, SamplingPattern pattern, const Sample& sample) {
    run_pass_tiles(
        seed, tile_size, threads, sink, stats,
        [&](PixelStart* starts, SobolSampler* sobol, size_t n, RayCounts& rays, PixelSample* out) {
          CameraRays first(scene, starts, n);
          for (size_t i = 0; i < n; ++i) {
            if (sobol) {
              out[i] = sample(first.rays[i], sobol[i], rays, &first.hits[i]);
            } else {
              IndependentSampler independent{starts[i].rng};
              out[i] = sample(first.rays[i], independent, rays, &first.hits[i]);
            }
            out[i].alpha *= first.coverage[i];  // a Holdout weighted in a mix
          }
        },
        pattern);
  }

  // The mean of every pixel's samples into pass `name` (RGB) of `film`, sized to the image.
  void develop(Film& film, std::string_view name) const {
    if (film.width() != width_ || film.height() != height_) film = Film(width_, height_);
    Pass& p = film.add_pass(name, 3);
    for (size_t i = 0; i < samples_.size(); ++i) {
      const double inv = samples_[i] ? 1.0 / samples_[i] : 0.0;
      for (int c = 0; c < 3; ++c) p.data[3 * i + c] = static_cast<float>(sum_[3 * i + c] * inv);
    }
  }

  // The mean alpha of every pixel's samples into pass::kAlpha of `film` (after develop()).
  void develop_alpha(Film& film) const {
    Pass& p = film.add_pass(pass::kAlpha, 1);
    for (size_t i = 0; i < samples_.size(); ++i)
      p.data[i] = samples_[i] ? static_cast<float>(alpha_[i] / samples_[i]) : 0.0f;
  }

 private:
  int width_, height_;
  const Camera* camera_;
  std::vector<double> sum_;        // RGB sums per pixel
  std::vector<uint32_t> samples_;  // samples per pixel
  std::vector<double> alpha_;      // alpha sums per pixel
  // The open pass's tiles (run_pass_tiles): done or not; empty between passes.
  std::vector<uint8_t> tile_done_;
  size_t tiles_left_ = 0;
};

}  // namespace gp
