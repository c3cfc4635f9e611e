// Cancellation (docs/reliability.md, "Cancellation"): Esc in Blender and Ctrl-C in the CLI set
// ProgressSink::cancel_flag; every method must then return from the pass in progress without
// finishing it. No timing here (scripts/cancel_latency.py measures seconds at 1080p): these
// tests count work instead.
#include <gtest/gtest.h>

#include <atomic>

#include "integrators/methods.h"
#include "core/progress.h"
#include "integrators/photon/photon_tracer.h"
#include "render_for_tests.h"

namespace gp {
namespace {

// A sink that says "cancelled" from its `after`-th poll on and counts the polls.
class CancelAfter : public ProgressSink {
 public:
  explicit CancelAfter(int64_t after) : after_(after) {}
  bool cancelled() override { return polls.fetch_add(1) >= after_; }
  std::atomic<int64_t> polls{0};

 private:
  int64_t after_;
};

TEST(Cancel, PhotonTracerStopsTracingOnceCancelled) {
  const Scene scene = test_scene("cornell-glass", 8, 8);
  PhotonTracer tracer(scene, 16, kDefaultSpecularThreshold, 1, 2);
  std::vector<Photon> full, part;
  const int64_t count = 100 * PhotonTracer::kChunk;
  const PhotonPassStats all = tracer.trace(count, 0, 0, full);
  std::atomic<int> polls{0};
  const PhotonPassStats some =
      tracer.trace(count, 0, 0, part, nullptr, nullptr, [&] { return polls.fetch_add(1) >= 2; });
  // Two chunks of a hundred traced: the rest were skipped, not traced and thrown away.
  EXPECT_LT(some.rays * 20, all.rays) << some.rays << " of " << all.rays << " rays";
  EXPECT_LT(part.size() * 20, full.size());
  EXPECT_EQ(polls.load(), 100);  // polled once per chunk
}

TEST(Cancel, EveryMethodStopsAPassCancelledAtItsFirstPoll) {
  // Pixel methods keep what a cancelled pass reached (Integrator::iterate); photon methods
  // abandon it. Either way no path of the pass is traced after the first poll said stop.
  const Scene scene = test_scene("cornell-glass", 24, 16);
  for (const std::string& method : integrator_names()) {
    auto full = make_integrator(method, scene, photon_params(20000, 1, 2));
    full->iterate(nullptr);
    auto integ = make_integrator(method, scene, photon_params(20000, 1, 2));
    CancelAfter now(0);
    integ->iterate(&now);
    EXPECT_GE(now.polls.load(), 1) << method << " never asked whether it was cancelled";
    EXPECT_EQ(integ->stats().paths, 0) << method << ": traced paths after the cancel (a full pass traces "
                                       << full->stats().paths << ")";
    EXPECT_GT(full->stats().paths, 0) << method;
    // The render goes on afterwards (Blender keeps the session for the image so far).
    integ->iterate(nullptr);
    EXPECT_GT(integ->stats().paths, 0) << method;
  }
}

TEST(Cancel, PhotonMethodsAbandonAPassCancelledMidway) {
  // A sink that cancels a quarter of the way through a pass's polls (counted on a full pass:
  // eye tiles, photon chunks, gather blocks): the pass is abandoned, the count stays.
  // Also in a medium (volume photons, beams, their gather and the adaptive sampler's beam
  // visibility between the polls).
  for (const char* name : {"cornell-glass", "volumetric-caustic"})
  for (const char* method : {"ppm", "sppm", "sppm-adaptive"}) {
    const Scene scene = test_scene(name, 24, 16);
    auto probe = make_integrator(method, scene, photon_params(200000, 1, 2));
    CancelAfter count_only(int64_t(1) << 60);
    probe->iterate(&count_only);
    const int64_t full_polls = count_only.polls.load();
    auto integ = make_integrator(method, scene, photon_params(200000, 1, 2));
    integ->iterate(nullptr);  // PPM traces its eye pass once: start from the second pass
    CancelAfter mid(full_polls / 4);
    integ->iterate(&mid);
    EXPECT_EQ(integ->stats().passes, 1) << method << " on " << name << ": the pass cancelled in the middle was counted";
  }
}

}  // namespace
}  // namespace gp
