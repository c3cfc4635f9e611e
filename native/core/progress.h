// Progress, cancellation and statistics: one small object shared by the CLI, the Python
// module and Blender (DESIGN.md, "The progressive interface").
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

namespace gp {

// Counters an integrator reports. `extra` holds method-specific counts by name
// (e.g. shift failures by reason) so new methods add statistics without new fields.
// Rays one worker traced; summed into Stats after each tile.
struct RayCounts {
  int64_t closest = 0, shadow = 0;
};

struct Stats {
  int64_t passes = 0;
  int64_t paths = 0;            // camera paths (or photon paths) traced
  int64_t rays = 0;             // closest-hit + occlusion rays
  int64_t shadow_rays = 0;      // the occlusion share of `rays`
  int64_t invalid_samples = 0;  // NaN/Inf contributions discarded before reaching a pass
  double seconds = 0;           // wall-clock time inside iterate()
  std::map<std::string, double> extra;
};

// Wall-clock seconds since t0: the per-phase timings ("eye seconds", "trace seconds", ...) that
// integrators add to Stats::extra.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Callbacks from a render loop. Methods may be called from the rendering thread only.
class ProgressSink {
 public:
  virtual ~ProgressSink() = default;
  // After every pass; `fraction` is the share of the stop rule done, in [0,1] (or <0 if unknown).
  virtual void on_pass(const Stats& stats, double fraction) {}
  // Polled between tiles; returning true stops the current pass early and ends the render.
  virtual bool cancelled() { return cancel_flag.load(std::memory_order_relaxed); }
  std::atomic<bool> cancel_flag{false};
  // Polled between tiles by the methods whose pass can stop at a tile and go on at the next
  // iterate() (the one-sample-per-pixel estimate: pt, spt, spt-hero); true ends this call with
  // the pass unfinished, its pixels' means valid, so a caller can show the image within a long
  // pass (Blender's F12 window at 1920x1080). Methods whose passes are one whole (photons,
  // gradients) never ask.
  virtual bool pause() { return false; }
};

}  // namespace gp
