// `gradphoton bench`, `bench-photons` and `bench-reconstruct`: throughput measurements (their
// figures go to docs/benchmarks.md).
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>

#include "cli/commands.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "integrators/integrator.h"
#include "integrators/photon/photon_tracer.h"
#include "reconstruction/poisson.h"
#include "scene/accel.h"
#include "scene/loader.h"

namespace gp::cli {

namespace {

// ---- bench ----
// Raw Embree throughput next to the path tracer's ray rate on the same scene, in one run.
// The raw figure replays the path tracer's own rays (recorded from a few passes) through bare
// Embree calls, so both numbers are for the same ray distribution and the same
// closest-hit/occlusion mix; the difference is the cost of everything else a path tracer does.
int run_bench(const std::string& scene_path, double seconds, int threads) {
  Scene scene = load_scene(scene_path);
  const Accelerator& accel = scene.accelerator();
  Params params;
  params.set("threads", threads);

  RayRecorder recorded;
  recorded.limit = 1 << 21;
  {
    auto recorder_run = make_integrator("pt", scene, params);
    Accelerator::record_rays(&recorded);
    while (recorded.closest.size() < recorded.limit && recorder_run->stats().passes < 64)
      recorder_run->iterate(nullptr);
    Accelerator::record_rays(nullptr);
  }
  auto measure = [&](const std::vector<Ray>& rays, bool occlusion) {  // Mrays/s
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    size_t traced = 0;
    std::atomic<size_t> hits{0};
    while (std::chrono::duration<double>(clock::now() - t0).count() < seconds / 2) {
      parallel_for(rays.size(), threads, [&](size_t lo, size_t hi) {
        size_t h = 0;
        RawHit hit;
        for (size_t i = lo; i < hi; ++i) h += occlusion ? accel.occluded(rays[i]) : accel.intersect(rays[i], hit);
        hits += h;
      });
      traced += rays.size();
    }
    return traced / std::chrono::duration<double>(clock::now() - t0).count() * 1e-6;
  };
  const double closest = measure(recorded.closest, false);
  const double occl = recorded.shadow.empty() ? 0.0 : measure(recorded.shadow, true);

  auto pt = make_integrator("pt", scene, params);
  StopRule stop;
  stop.seconds = seconds;
  run_progressive(*pt, stop, nullptr);
  const Stats& s = pt->stats();
  const double pt_rate = s.rays / s.seconds * 1e-6;
  const double shadow_share = s.rays ? static_cast<double>(s.shadow_rays) / s.rays : 0.0;
  // Raw rate of the same mix: time per ray is the share-weighted mean of the two kinds.
  const double raw_mix = 1.0 / ((1.0 - shadow_share) / closest + (occl > 0 ? shadow_share / occl : 0.0));
  fmt::print("scene                   {} ({} triangles)\n", scene_path, scene.triangle_count());
  fmt::print("threads                 {}\n", resolve_thread_count(threads));
  fmt::print("recorded rays           {} closest-hit, {} occlusion (the path tracer's own)\n",
             recorded.closest.size(), recorded.shadow.size());
  fmt::print("embree closest-hit      {:.2f} Mrays/s\n", closest);
  fmt::print("embree occlusion        {:.2f} Mrays/s\n", occl);
  fmt::print("embree, same mix        {:.2f} Mrays/s ({:.0f}% occlusion rays)\n", raw_mix, 100 * shadow_share);
  fmt::print("path tracer             {:.2f} Mrays/s ({} passes, {:.2f} s)\n", pt_rate, s.passes, s.seconds);
  fmt::print("path tracer / embree    {:.2f}\n", pt_rate / raw_mix);
  return 0;
}

// ---- bench-photons ----
// Photon tracing rate beside raw Embree on the photon tracer's own rays, and the SPPM photon
// pass split into tracing, lookup (hash-grid build + gathering) and update, in one run.
int run_bench_photons(const std::string& scene_path, int64_t photons, int passes, int threads,
                      const std::string& hash, int width) {
  Scene scene = load_scene(scene_path);
  if (width > 0) {
    scene.camera.height = std::max(1, static_cast<int>(std::lround(double(scene.camera.height) * width / scene.camera.width)));
    scene.camera.width = width;
  }
  const Accelerator& accel = scene.accelerator();
  // Raw rate: replay one photon pass's rays (all closest-hit) through bare Embree.
  RayRecorder recorded;
  recorded.limit = 1 << 22;
  {
    PhotonTracer tracer(scene, 32, kDefaultSpecularThreshold, 0, threads);
    std::vector<Photon> out;
    Accelerator::record_rays(&recorded);
    tracer.trace(std::min<int64_t>(photons, 1 << 21), 0, 0, out);
    Accelerator::record_rays(nullptr);
  }
  double raw = 0;
  {
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    size_t traced = 0;
    std::atomic<size_t> hits{0};
    while (std::chrono::duration<double>(clock::now() - t0).count() < 2.0) {
      parallel_for(recorded.closest.size(), threads, [&](size_t lo, size_t hi) {
        size_t h = 0;
        RawHit hit;
        for (size_t i = lo; i < hi; ++i) h += accel.intersect(recorded.closest[i], hit);
        hits += h;
      });
      traced += recorded.closest.size();
    }
    raw = traced / std::chrono::duration<double>(clock::now() - t0).count() * 1e-6;
  }
  Params params;
  params.set("photons", photons);
  params.set("threads", threads);
  params.set("hash", hash);
  auto sppm = make_integrator("sppm", scene, params);
  sppm->iterate(nullptr);  // warm-up pass (first allocations), not counted
  const Stats before = sppm->stats();
  for (int i = 0; i < passes; ++i) sppm->iterate(nullptr);
  const Stats& s = sppm->stats();
  auto delta = [&](const char* k) { return (s.extra.at(k) - before.extra.at(k)) / passes; };
  const double trace = delta("trace seconds"), lookup = delta("lookup seconds"), update = delta("update seconds"),
               eye = delta("eye seconds");
  const double photon_rays = delta("photon rays");
  const double rate = photon_rays / trace * 1e-6;
  fmt::print("scene                   {} ({} triangles, {}x{} pixels)\n", scene_path, scene.triangle_count(),
             scene.camera.width, scene.camera.height);
  fmt::print("threads                 {}\n", resolve_thread_count(threads));
  fmt::print("photons per pass        {} (hash {}), {} passes timed\n", photons, hash, passes);
  fmt::print("embree closest-hit      {:.2f} Mrays/s (replaying {} photon rays)\n", raw, recorded.closest.size());
  fmt::print("photon tracing          {:.2f} Mrays/s, {:.2f} Mphotons/s ({:.2f} rays per photon)\n", rate,
             photons / trace * 1e-6, photon_rays / photons);
  fmt::print("photon tracing / embree {:.2f}\n", rate / raw);
  fmt::print("photon pass (ms)        trace {:.1f}  lookup {:.1f}  update {:.1f}  (eye pass {:.1f})\n", 1e3 * trace,
             1e3 * lookup, 1e3 * update, 1e3 * eye);
  fmt::print("(lookup + update) / trace {:.2f}\n", (lookup + update) / trace);
  return 0;
}

// ---- bench-reconstruct ----
// Median wall time of L2 and L1 reconstruction of a synthetic width x height RGB image whose
// primal and gradients carry independent noise (like a rendering's), `repeats` runs each.
int run_bench_reconstruct(int width, int height, int repeats, int threads) {
  const size_t n = static_cast<size_t>(width) * height * 3;
  std::vector<double> img(n);
  Rng rng(12345, 0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        img[(static_cast<size_t>(y) * width + x) * 3 + c] =
            1.0 + 0.5 * std::sin(0.02 * x + c) * std::cos(0.03 * y) + (x > width / 2 ? 1.0 : 0.0);
  std::vector<double> gx, gy;
  forward_differences(img, width, height, 3, &gx, &gy);
  std::vector<float> p(n), fx(n), fy(n);
  for (size_t i = 0; i < n; ++i) {
    p[i] = static_cast<float>(img[i] * (0.5 + rng.uniform()));
    fx[i] = static_cast<float>(gx[i] + 0.1 * (rng.uniform() - 0.5));
    fy[i] = static_cast<float>(gy[i] + 0.1 * (rng.uniform() - 0.5));
  }
  fmt::print("image      {}x{} RGB ({:.2f} MP), threads {}, {} runs each\n", width, height,
             width * double(height) * 1e-6, resolve_thread_count(threads), repeats);
  for (ReconNorm norm : {ReconNorm::L2, ReconNorm::L1}) {
    ReconOptions o;
    o.norm = norm;
    o.threads = threads;
    std::vector<double> times;
    ReconReport rep;
    for (int r = 0; r < repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      const auto out = screened_poisson(p, fx, fy, width, height, 3, o, &rep);
      times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(times.begin(), times.end());
    fmt::print("{}         median {:.3f} s  (min {:.3f}, max {:.3f}){}\n", norm == ReconNorm::L2 ? "L2" : "L1",
               times[times.size() / 2], times.front(), times.back(),
               norm == ReconNorm::L1 ? fmt::format("  [{} IRLS rounds, {} PCG iterations, tolerance {:g}{}]",
                                                   rep.irls_iterations, rep.cg_iterations, o.tolerance,
                                                   rep.converged ? "" : ", NOT met")
                                     : std::string());
  }
  return 0;
}

}  // namespace

std::vector<Command> add_bench_commands(CLI::App& app) {
  struct BenchArgs {
    std::string bench_scene;
    double bench_seconds = 3;
    int bench_threads = 0;
  };
  auto b = std::make_shared<BenchArgs>();
  auto* bench = app.add_subcommand("bench", "Raw Embree ray throughput next to the path tracer's, same scene");
  bench->add_option("scene", b->bench_scene, "Scene file")->required()->check(CLI::ExistingFile);
  bench->add_option("--seconds", b->bench_seconds, "Seconds per measurement")->capture_default_str();
  bench->add_option("--threads", b->bench_threads, "Worker threads (0 = all cores)")->capture_default_str();

  struct BenchPhotonsArgs {
    std::string bp_scene, bp_hash = "exact";
    int64_t bp_photons = 1000000;
    int bp_passes = 3, bp_threads = 0, bp_width = 0;
  };
  auto p = std::make_shared<BenchPhotonsArgs>();
  auto* bench_photons = app.add_subcommand(
      "bench-photons", "Photon tracing rate beside raw Embree; SPPM pass time split into trace, lookup, update");
  bench_photons->add_option("scene", p->bp_scene, "Scene file")->required()->check(CLI::ExistingFile);
  bench_photons->add_option("--photons", p->bp_photons, "Photons per pass")->capture_default_str();
  bench_photons->add_option("--passes", p->bp_passes, "Passes timed (after one warm-up pass)")->capture_default_str();
  bench_photons->add_option("--threads", p->bp_threads, "Worker threads (0 = all cores)")->capture_default_str();
  bench_photons->add_option("--hash", p->bp_hash, "exact|stochastic")->capture_default_str();
  bench_photons->add_option("--width", p->bp_width, "Image width (height keeps the aspect ratio; default: the scene's)");

  struct BenchReconArgs {
    int brec_width = 1000, brec_height = 1000, brec_repeats = 5, brec_threads = 0;
  };
  auto q = std::make_shared<BenchReconArgs>();
  auto* bench_rec = app.add_subcommand("bench-reconstruct", "Median L2 and L1 reconstruction times");
  bench_rec->add_option("--width", q->brec_width)->capture_default_str();
  bench_rec->add_option("--height", q->brec_height)->capture_default_str();
  bench_rec->add_option("--repeats", q->brec_repeats)->capture_default_str()->check(CLI::PositiveNumber);
  bench_rec->add_option("--threads", q->brec_threads, "Worker threads (0 = all cores)")->capture_default_str();

  return {{bench, [b] { return run_bench(b->bench_scene, b->bench_seconds, b->bench_threads); }},
          {bench_photons,
           [p] { return run_bench_photons(p->bp_scene, p->bp_photons, p->bp_passes, p->bp_threads, p->bp_hash, p->bp_width); }},
          {bench_rec, [q] { return run_bench_reconstruct(q->brec_width, q->brec_height, q->brec_repeats, q->brec_threads); }}};
}

}  // namespace gp::cli
