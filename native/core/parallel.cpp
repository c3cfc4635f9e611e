// Two back-ends behind one interface: oneTBB (the default), and plain std::threads for the
// ThreadSanitizer build (GRADPHOTON_PARALLEL_THREADS, scripts/sanitize.sh tsan): Debian's oneTBB
// is not instrumented, so TSan cannot see its hand-over of a task and reports every one of them;
// with std::thread and std::atomic every synchronisation is visible and a report is a race in
// gradphoton's own code. Both hand out the same tiles and chunks in any order; results never
// depend on the order (each pixel owns its random stream and accumulator).
#include "core/parallel.h"

#include "core/math.h"

#include <algorithm>
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <optional>
#include <vector>

#if GRADPHOTON_PARALLEL_THREADS
namespace gp {

int resolve_thread_count(int threads) {
  return threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

namespace {
// Runs body(i) for i in [0, n) on `threads` threads (the caller is one of them), each taking
// the next index from a shared counter.
void run_indices(size_t n, int threads, const std::function<void(size_t)>& body) {
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t i; (i = next.fetch_add(1)) < n;) body(i);
  };
  std::vector<std::thread> pool;
  const int extra = static_cast<int>(std::min<size_t>(n, resolve_thread_count(threads))) - 1;
  for (int t = 0; t < extra; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}
}  // namespace

void parallel_for_tiles(int width, int height, int tile_size, int threads,
                        const std::function<void(const Tile&)>& fn,
                        const std::function<bool()>& cancelled) {
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += tile_size)
    for (int x = 0; x < width; x += tile_size)
      tiles.push_back({x, y, std::min(x + tile_size, width), std::min(y + tile_size, height)});
  std::atomic<bool> stop{false};
  const float time = shutter_time();  // the caller's pass time reaches every worker (core/math.h)
  run_indices(tiles.size(), threads, [&](size_t i) {
    if (stop.load()) return;
    if (cancelled && cancelled()) {
      stop = true;
      return;
    }
    ShutterTime at(time);
    fn(tiles[i]);
  });
}

void parallel_for(size_t count, int threads, const std::function<void(size_t, size_t)>& fn) {
  const size_t chunks = std::min<size_t>(count, 8 * static_cast<size_t>(resolve_thread_count(threads)));
  if (chunks == 0) return;
  const float time = shutter_time();
  run_indices(chunks, threads, [&](size_t c) {
    ShutterTime at(time);
    fn(count * c / chunks, count * (c + 1) / chunks);
  });
}

}  // namespace gp
#else
#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

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
  const float time = shutter_time();  // the caller's pass time reaches every worker (core/math.h)
  arena_for(threads).execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles.size(), 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        ShutterTime at(time);
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
  const float time = shutter_time();
  arena_for(threads).execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count), [&](const tbb::blocked_range<size_t>& r) {
      ShutterTime at(time);
      fn(r.begin(), r.end());
    });
  });
}

}  // namespace gp
#endif
