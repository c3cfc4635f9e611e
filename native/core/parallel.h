// Parallel helpers over oneTBB. Work is split into image tiles; results never depend on the
// split because every pixel owns its random stream and its accumulator.
#pragma once

#include <functional>

namespace gp {

struct Tile {
  int x0, y0, x1, y1;  // half-open pixel rectangle
};

// Runs fn(tile) over all tiles of a width x height image in parallel, using `threads`
// workers (0 = all cores). Stops handing out tiles once `cancelled()` returns true.
void parallel_for_tiles(int width, int height, int tile_size, int threads,
                        const std::function<void(const Tile&)>& fn,
                        const std::function<bool()>& cancelled = {});

// Debugging one pixel (the CLI's --pixel, as pbrt-v4's): while a PixelWindow lives,
// parallel_for_tiles hands out only the 1x1 tile of pixel (x, y), on the calling thread; every
// other pixel is left untouched. Each pixel draws its own random stream, so a method whose
// pixels are traced independently computes that pixel's samples exactly as in the full render.
// Process-wide (the CLI renders one image); not for concurrent renders.
class PixelWindow {
 public:
  PixelWindow(int x, int y);
  ~PixelWindow();
  PixelWindow(const PixelWindow&) = delete;
  PixelWindow& operator=(const PixelWindow&) = delete;
};

// Runs fn(begin, end) over [0, count) in parallel chunks.
void parallel_for(size_t count, int threads, const std::function<void(size_t, size_t)>& fn);

// Number of worker threads a `threads` setting resolves to.
int resolve_thread_count(int threads);

}  // namespace gp
