#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <vector>

namespace gp {

int resolve_thread_count(int threads) {
  return threads > 0 ? threads : tbb::info::default_concurrency();
}

void parallel_for_tiles(int width, int height, int tile_size, int threads,
                        const std::function<void(const Tile&)>& fn,
                        const std::function<bool()>& cancelled) {
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += tile_size)
    for (int x = 0; x < width; x += tile_size)
      tiles.push_back({x, y, std::min(x + tile_size, width), std::min(y + tile_size, height)});
  std::atomic<bool> stop{false};
  tbb::task_arena arena(resolve_thread_count(threads));
  arena.execute([&] {
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
  tbb::task_arena arena(resolve_thread_count(threads));
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count),
                      [&](const tbb::blocked_range<size_t>& r) { fn(r.begin(), r.end()); });
  });
}

}  // namespace gp
