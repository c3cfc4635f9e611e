// The tiles of an eye pass that may pause (ProgressSink::pause: Blender's F12 window asks for an
// image) and go on at the next call with the tiles it has not done: the first pass of the photon
// methods (ProgressivePhotonMapping: ppm, sppm, sppm-adaptive, gpm; Msppm), whose images in
// between show what the tiles done so far saw. Each pixel draws its own random stream, so the
// pass is the same as a whole one.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/parallel.h"
#include "core/progress.h"

namespace gp {

class PausableTiles {
 public:
  // fn over the open pass's tiles not done yet (parallel_for_tiles). With `may_pause`, it stops
  // handing out tiles once the sink asks (after at least one tile this call, so a caller pausing
  // at once still moves on) and returns false; true when the pass is done, or cancelled
  // (abandoned: the next call starts it anew).
  bool run(int width, int height, int tile_size, int threads, ProgressSink* sink, bool may_pause,
           const std::function<void(const Tile&)>& fn) {
    width_ = width;
    tile_size_ = tile_size;
    const int tiles_x = (width + tile_size - 1) / tile_size;
    const size_t n_tiles = static_cast<size_t>(tiles_x) * ((height + tile_size - 1) / tile_size);
    if (done_.empty()) done_.assign(n_tiles, 0);  // a new pass
    std::atomic<bool> paused{false};
    std::atomic<size_t> tiles_now{0};  // tiles this call did
    parallel_for_tiles(
        width, height, tile_size, threads,
        [&](const Tile& tile) {
          const size_t index = static_cast<size_t>(tile.y0 / tile_size) * tiles_x + tile.x0 / tile_size;
          if (index < n_tiles && done_[index]) return;  // done before a pause
          fn(tile);
          if (index < n_tiles) done_[index] = 1;
          tiles_now.fetch_add(1, std::memory_order_relaxed);
        },
        [&] {
          if (!sink) return false;
          if (sink->cancelled() || paused.load(std::memory_order_relaxed)) return true;
          if (!may_pause || tiles_now.load(std::memory_order_relaxed) == 0 || !sink->pause()) return false;
          paused = true;
          return true;
        });
    // A call that did not pause did every tile left (or was cancelled: the pass is abandoned).
    const bool done = !paused.load() || (sink && sink->cancelled());
    if (done) done_.clear();
    return done;
  }
  // Whether a pass is open (paused with some tiles done).
  bool open() const { return !done_.empty(); }
  // Whether the open pass has done the tile of pixel (x, y).
  bool done(size_t pixel) const {
    if (done_.empty()) return false;
    const int tiles_x = (width_ + tile_size_ - 1) / tile_size_;
    const int x = static_cast<int>(pixel % width_), y = static_cast<int>(pixel / width_);
    return done_[static_cast<size_t>(y / tile_size_) * tiles_x + x / tile_size_] != 0;
  }

 private:
  int width_ = 1, tile_size_ = 1;
  std::vector<uint8_t> done_;  // the open pass's tiles (row-major); empty: none open
};

// One call's part of a pass that may pause between its stages (the first pass, when the sink
// asks) and go on at the next call: the ray counters start from what the pass counted before the
// pause, and a pause keeps them (in `Kept`, the integrator's) with this call's seconds.
class PassPause {
 public:
  struct Kept {
    int64_t rays = 0, invalid = 0;
  };
  // on_leave: what else the integrator keeps when the pass stays open (GPM's shift failures).
  PassPause(Kept& kept, double& seconds, std::chrono::steady_clock::time_point start, ProgressSink* sink,
            bool may_pause, std::function<void()> on_leave = {})
      : rays(kept.rays), invalid(kept.invalid), kept_(kept), seconds_(seconds), start_(start), sink_(sink),
        may_pause_(may_pause), on_leave_(std::move(on_leave)) {}

  std::atomic<int64_t> rays, invalid;

  // The pass stays open for the next call.
  void leave_open() {
    kept_.rays = rays;
    kept_.invalid = invalid;
    if (on_leave_) on_leave_();
    seconds_ += seconds_since(start_);
  }
  // At the end of a stage: true, the pass left open, when the sink asks for a pause.
  bool pause_here() {
    if (!may_pause_ || !sink_->pause()) return false;
    leave_open();
    return true;
  }
  // This call ends the pass: the next one counts from zero.
  void close() { kept_ = Kept{}; }

 private:
  Kept& kept_;
  double& seconds_;
  std::chrono::steady_clock::time_point start_;
  ProgressSink* sink_;
  bool may_pause_;
  std::function<void()> on_leave_;
};

}  // namespace gp
