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
#include "integrators/methods.h"
#include "integrators/photon/photon_tracer.h"
#include "reconstruction/poisson.h"
#include "scene/accel.h"
#include "scene/loader.h"
#include "session/render_session.h"

namespace gp::cli {

namespace {

// ---- bench ----
// Raw Embree throughput next to the path tracer's ray rate on the same scene, in one run.
// The raw figure replays the path tracer's own rays (recorded from a few passes) through bare
// Embree calls, so both numbers are for the same ray distribution and the same
// closest-hit/occlusion mix; the difference is the cost of everything else a path tracer does.
// Raw replays and rendering alternate in rounds, so that the load of a shared machine weighs
// on both alike; the per-round ratios give the spread.

// Seconds to replay `rays` once through bare Embree: one ray at a time (rtcIntersect1 /
// rtcOccluded1) or as streams of kBenchStream rays (rtcIntersect1M / rtcOccluded1M).
constexpr size_t kBenchStream = 256;
double replay_seconds(const Accelerator& accel, const std::vector<Ray>& rays, bool occlusion, bool stream,
                      int threads, bool coherent = false) {
  const auto t0 = std::chrono::steady_clock::now();
  std::atomic<size_t> hits{0};  // consumed, so no call is optimised away
  parallel_for(rays.size(), threads, [&](size_t lo, size_t hi) {
    size_t h = 0;
    if (stream) {
      RawHit raw[kBenchStream];
      bool found[kBenchStream];
      for (size_t b = lo; b < hi; b += kBenchStream) {
        const size_t n = std::min(kBenchStream, hi - b);
        if (occlusion) accel.occluded_stream(&rays[b], n, found, coherent);
        else accel.intersect_stream(&rays[b], n, raw, found, coherent);
        for (size_t i = 0; i < n; ++i) h += found[i];
      }
    } else {
      RawHit hit;
      for (size_t i = lo; i < hi; ++i) h += occlusion ? accel.occluded(rays[i]) : accel.intersect(rays[i], hit);
    }
    hits += h;
  });
  return seconds_since(t0);
}

// Rays among the first `limit` of `rays` whose stream query answers differently from the
// single-ray one (hit or not, t, u, v, triangle): zero means streams are a pure speed-up there.
size_t stream_mismatches(const Accelerator& accel, const std::vector<Ray>& rays, bool occlusion, size_t limit) {
  size_t bad = 0;
  RawHit raw[kBenchStream], one;
  bool found[kBenchStream];
  for (size_t b = 0; b < std::min(limit, rays.size()); b += kBenchStream) {
    const size_t n = std::min(kBenchStream, rays.size() - b);
    if (occlusion) accel.occluded_stream(&rays[b], n, found);
    else accel.intersect_stream(&rays[b], n, raw, found);
    for (size_t i = 0; i < n; ++i) {
      if (occlusion) {
        bad += found[i] != accel.occluded(rays[b + i]);
        continue;
      }
      const bool f = accel.intersect(rays[b + i], one);
      bad += f != found[i] || (f && (one.t != raw[i].t || one.u != raw[i].u || one.v != raw[i].v ||
                                      one.prim != raw[i].prim || one.geom != raw[i].geom));
    }
  }
  return bad;
}

// Raw Embree seconds per round for one ray list, one at a time and as streams.
struct ReplayTimes {
  double single = 0, stream = 0;
  void add(const Accelerator& accel, const std::vector<Ray>& rays, bool occlusion, int threads) {
    if (rays.empty()) return;
    single += replay_seconds(accel, rays, occlusion, false, threads);
    stream += replay_seconds(accel, rays, occlusion, true, threads);
  }
};

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The render session every front end runs (session/render_session.h), without its auxiliary
// passes: what is timed here is the method's own passes.
std::unique_ptr<RenderSession> bench_session(const std::shared_ptr<const Scene>& scene, const std::string& method,
                                             const Params& params) {
  auto s = std::make_unique<RenderSession>(scene, method, params);
  s->set_aux_passes(false);
  return s;
}

int run_bench(const std::string& scene_path, double seconds, int threads) {
  const auto shared = std::make_shared<Scene>(load_scene(scene_path));
  const Scene& scene = *shared;
  const Accelerator& accel = scene.accelerator();
  Params params;
  params.set("threads", threads);

  RayRecorder recorded;
  recorded.limit = 1 << 21;
  {
    auto recorder_run = bench_session(shared, "pt", params);
    Accelerator::record_rays(&recorded);
    while (recorded.closest.size() < recorded.limit && recorder_run->stats().passes < 64)
      recorder_run->iterate(nullptr);
    Accelerator::record_rays(nullptr);
  }
  const double n_closest = static_cast<double>(recorded.closest.size());
  const double n_shadow = static_cast<double>(recorded.shadow.size());

  auto pt = bench_session(shared, "pt", params);
  pt->iterate(nullptr);  // warm-up pass (first allocations, caches), not counted
  ReplayTimes closest, occl;
  double pt_seconds = 0, pt_rays = 0, pt_shadow = 0;
  std::vector<double> round_ratios;
  const auto t0 = std::chrono::steady_clock::now();
  for (int round = 0; round < 3 || seconds_since(t0) < seconds; ++round) {
    ReplayTimes c, o;
    c.add(accel, recorded.closest, false, threads);
    o.add(accel, recorded.shadow, true, threads);
    const Stats before = pt->stats();
    pt->iterate(nullptr);
    const Stats& s = pt->stats();
    const double secs = s.seconds - before.seconds, rays = double(s.rays - before.rays);
    const double shadow = double(s.shadow_rays - before.shadow_rays);
    // Raw rate of the path tracer's mix: its rays at the replays' time per closest / shadow ray.
    const double raw_secs = (rays - shadow) * c.single / n_closest + (n_shadow > 0 ? shadow * o.single / n_shadow : 0);
    round_ratios.push_back(raw_secs / secs);
    closest.single += c.single; closest.stream += c.stream;
    occl.single += o.single; occl.stream += o.stream;
    pt_seconds += secs; pt_rays += rays; pt_shadow += shadow;
  }
  const int rounds = static_cast<int>(round_ratios.size());
  const double shadow_share = pt_rays > 0 ? pt_shadow / pt_rays : 0.0;
  auto rate = [&](double n, double secs) { return secs > 0 ? n * rounds / secs * 1e-6 : 0.0; };  // Mrays/s
  // Raw rate of the same mix: time per ray is the share-weighted mean of the two kinds.
  auto mix = [&](double c_secs, double o_secs) {
    return 1.0 / ((1.0 - shadow_share) / rate(n_closest, c_secs) + (n_shadow > 0 ? shadow_share / rate(n_shadow, o_secs) : 0.0));
  };
  const double raw_mix = mix(closest.single, occl.single), stream_mix = mix(closest.stream, occl.stream);
  const double pt_rate = pt_rays / pt_seconds * 1e-6;
  const auto [lo, hi] = std::minmax_element(round_ratios.begin(), round_ratios.end());
  fmt::print("scene                   {} ({} triangles)\n", scene_path, scene.triangle_count());
  fmt::print("threads                 {}\n", resolve_thread_count(threads));
  fmt::print("recorded rays           {} closest-hit, {} occlusion (the path tracer's own)\n",
             recorded.closest.size(), recorded.shadow.size());
  fmt::print("embree closest-hit      {:.2f} Mrays/s (streams of {}: {:.2f})\n", rate(n_closest, closest.single),
             kBenchStream, rate(n_closest, closest.stream));
  fmt::print("embree occlusion        {:.2f} Mrays/s (streams: {:.2f})\n", rate(n_shadow, occl.single),
             rate(n_shadow, occl.stream));
  fmt::print("embree, same mix        {:.2f} Mrays/s ({:.0f}% occlusion rays; streams: {:.2f})\n", raw_mix,
             100 * shadow_share, stream_mix);
  // Camera rays alone (a tile's are coherent): do packets pay for them?
  std::vector<Ray> camera_rays;
  for (const Ray& r : recorded.closest)
    if (r.camera) camera_rays.push_back(r);
  if (!camera_rays.empty()) {
    double single = 0, stream = 0;
    for (int i = 0; i < 3; ++i) {
      single += replay_seconds(accel, camera_rays, false, false, threads);
      stream += replay_seconds(accel, camera_rays, false, true, threads, true);
    }
    const double n = 3e-6 * static_cast<double>(camera_rays.size());
    fmt::print("embree camera rays      {:.2f} Mrays/s (coherent streams: {:.2f}; {} rays)\n", n / single, n / stream,
               camera_rays.size());
  }
  constexpr size_t kChecked = 1 << 18;
  fmt::print("streams differ          {} of {} closest-hit, {} of {} occlusion rays from single-ray answers\n",
             stream_mismatches(accel, recorded.closest, false, kChecked), std::min(kChecked, recorded.closest.size()),
             stream_mismatches(accel, recorded.shadow, true, kChecked), std::min(kChecked, recorded.shadow.size()));
  fmt::print("path tracer             {:.2f} Mrays/s ({} passes, {:.2f} s)\n", pt_rate, rounds, pt_seconds);
  fmt::print("path tracer / embree    {:.2f}\n", pt_rate / raw_mix);
  fmt::print("path tracer / streams   {:.2f}\n", pt_rate / stream_mix);
  fmt::print("rounds                  {} (ratio per round: median {:.2f}, {:.2f} .. {:.2f})\n", rounds,
             median_of(round_ratios), *lo, *hi);
  return 0;
}

// ---- bench-photons ----
// Photon tracing rate beside raw Embree on the photon tracer's own rays, and the SPPM photon
// pass split into tracing, lookup (hash-grid build + gathering) and update, in one run; raw
// replays and SPPM passes alternate, as in bench. Then SPPM with its default photon count: the
// share of a pass its eye pass takes.
int run_bench_photons(const std::string& scene_path, int64_t photons, int passes, int threads,
                      const std::string& hash, int width) {
  const auto shared = std::make_shared<Scene>(load_scene(scene_path));
  Scene& scene = *shared;
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
  Params params;
  params.set("photons", photons);
  params.set("threads", threads);
  params.set("hash", hash);
  auto sppm = bench_session(shared, "sppm", params);
  sppm->iterate(nullptr);  // warm-up pass (first allocations), not counted
  const Stats before = sppm->stats();
  ReplayTimes raw;
  std::vector<double> round_ratios;
  for (int i = 0; i < passes; ++i) {
    ReplayTimes r;
    r.add(accel, recorded.closest, false, threads);
    const Stats pass_before = sppm->stats();
    sppm->iterate(nullptr);
    const Stats& s = sppm->stats();
    const double rays = s.extra.at("photon rays") - pass_before.extra.at("photon rays");
    const double trace = s.extra.at("trace seconds") - pass_before.extra.at("trace seconds");
    // This round's ratio: photon tracing's time per ray against the replay's.
    round_ratios.push_back((r.single / double(recorded.closest.size())) / (trace / rays));
    raw.single += r.single;
    raw.stream += r.stream;
  }
  const Stats& s = sppm->stats();
  auto delta = [&](const char* k) { return (s.extra.at(k) - before.extra.at(k)) / passes; };
  const double trace = delta("trace seconds"), lookup = delta("lookup seconds"), update = delta("update seconds"),
               eye = delta("eye seconds");
  const double photon_rays = delta("photon rays");
  const double rate = photon_rays / trace * 1e-6;
  const double n_rays = static_cast<double>(recorded.closest.size());
  const double raw_rate = n_rays * passes / raw.single * 1e-6, stream_rate = n_rays * passes / raw.stream * 1e-6;
  fmt::print("scene                   {} ({} triangles, {}x{} pixels)\n", scene_path, scene.triangle_count(),
             scene.camera.width, scene.camera.height);
  fmt::print("threads                 {}\n", resolve_thread_count(threads));
  fmt::print("photons per pass        {} (hash {}), {} passes timed\n", photons, hash, passes);
  fmt::print("embree closest-hit      {:.2f} Mrays/s (replaying {} photon rays; streams of {}: {:.2f})\n", raw_rate,
             recorded.closest.size(), kBenchStream, stream_rate);
  fmt::print("photon tracing          {:.2f} Mrays/s, {:.2f} Mphotons/s ({:.2f} rays per photon)\n", rate,
             photons / trace * 1e-6, photon_rays / photons);
  fmt::print("photon tracing / embree {:.2f}\n", rate / raw_rate);
  fmt::print("photon tracing / streams {:.2f}\n", rate / stream_rate);
  fmt::print("photon pass (ms)        trace {:.1f}  lookup {:.1f}  update {:.1f}  (eye pass {:.1f})\n", 1e3 * trace,
             1e3 * lookup, 1e3 * update, 1e3 * eye);
  fmt::print("(lookup + update) / trace {:.2f}\n", (lookup + update) / trace);
  const auto [lo, hi] = std::minmax_element(round_ratios.begin(), round_ratios.end());
  fmt::print("rounds                  {} (ratio per round: median {:.2f}, {:.2f} .. {:.2f})\n", passes,
             median_of(round_ratios), *lo, *hi);

  // ---- SPPM with its defaults (photon count included): the eye pass's share of a pass ----
  Params defaults;
  defaults.set("threads", threads);
  auto plain = bench_session(shared, "sppm", defaults);
  plain->iterate(nullptr);
  const Stats d0 = plain->stats();
  for (int i = 0; i < passes; ++i) plain->iterate(nullptr);
  const Stats& d = plain->stats();
  const double d_eye = (d.extra.at("eye seconds") - d0.extra.at("eye seconds")) / passes;
  const double d_pass = (d.seconds - d0.seconds) / passes;
  const double d_photons = (d.extra.at("photons traced") - d0.extra.at("photons traced")) / passes;
  fmt::print("sppm defaults           {:.0f} photons per pass: eye pass {:.1f} ms of a {:.1f} ms pass\n", d_photons,
             1e3 * d_eye, 1e3 * d_pass);
  fmt::print("sppm eye share          {:.2f}\n", d_eye / d_pass);
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
  bench_photons->add_option("--passes", p->bp_passes, "Passes timed (after one warm-up pass)")
      ->capture_default_str()->check(CLI::PositiveNumber);
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
