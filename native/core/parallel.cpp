#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

namespace gp {

namespace {

// One arena per thread count, kept for the life of the process: oneTBB 2021.8 (Debian 12)
// keeps about 7 kB of every task_arena created and destroyed, and an arena per call made that
// a leak of 7 MB per thousand passes of the path tracer, more for the photon methods
// (scripts/soak.py, docs/reliability.md). Deliberately never freed (no order-of-destruction
// trouble with TBB's own globals at exit). Concurrent callers with the same count share it.
tbb::task_arena& arena_for(int threads) {
  static std::mutex mutex;
  static auto* arenas = new std::map<int, std::unique_ptr<tbb::task_arena>>();
  const int n = resolve_thread_count(threads);
  std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<tbb::task_arena>& arena = (*arenas)[n];
  if (!arena) arena = std::make_unique<tbb::task_arena>(n);
  return *arena;
}

}  // namespace

int resolve_thread_count(int threads) {
  return threads > 0 ? threads : tbb::info::default_concurrency();
}

namespace {
std::optional<Tile> g_pixel_window;  // PixelWindow
}  // namespace

PixelWindow::PixelWindow(int x, int y) { g_pixel_window = Tile{x, y, x + 1, y + 1}; }
PixelWindow::~PixelWindow() { g_pixel_window.reset(); }

void parallel_for_tiles(int width, int height, int tile_size, int threads,
                        const std::function<void(const Tile&)>& fn,
                        const std::function<bool()>& cancelled) {
  if (g_pixel_window) {
    const Tile& w = *g_pixel_window;
    if (w.x0 >= 0 && w.y0 >= 0 && w.x0 < width && w.y0 < height && !(cancelled && cancelled())) fn(w);
    return;
  }
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += tile_size)
    for (int x = 0; x < width; x += tile_size)
      tiles.push_back({x, y, std::min(x + tile_size, width), std::min(y + tile_size, height)});
  std::atomic<bool> stop{false};
  arena_for(threads).execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles.size(), 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t i = r.begin(); i != r.end(); ++i) {
                          if (stop.load(std::memory_order_relaxed)) return;
                          if (cancelled && cancelled()) {
                            stop = true;
                            return;
                          }
                          fn(tiles[i]);
                        }
                      });
  });
}

void parallel_for(size_t count, int threads, const std::function<void(size_t, size_t)>& fn) {
  arena_for(threads).execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count),
                      [&](const tbb::blocked_range<size_t>& r) { fn(r.begin(), r.end()); });
  });
}

}  // namespace gp
