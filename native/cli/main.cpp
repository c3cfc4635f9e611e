// The `gradphoton` command: render, merge, diff, info, bench, reconstruct, bench-reconstruct. Argument parsing by
// CLI11.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <functional>
#include <map>
#include <iostream>
#include <optional>
#include <sstream>

#include "core/parallel.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "distributed/merge.h"
#include "distributed/run_info.h"
#include "integrators/integrator.h"
#include "integrators/photon/photon_tracer.h"
#include "integrators/spectral/spectral_pt.h"
#include "io/display.h"
#include "io/exr.h"
#include "io/metrics.h"
#include "reconstruction/poisson.h"
#include "scene/accel.h"
#include "scene/loader.h"

namespace fs = std::filesystem;
using namespace gp;

namespace {

std::atomic<ProgressSink*> g_sink{nullptr};

void on_sigint(int) {
  if (ProgressSink* s = g_sink.load()) s->cancel_flag = true;  // finish with the image so far
}

using Attributes = std::map<std::string, std::string>;

// Progress bar on stderr (only when it is a terminal) and checkpoint snapshots, each with the
// run's record so far (`attributes`).
class CliProgress : public ProgressSink {
 public:
  CliProgress(const Integrator& integ, std::vector<double> checkpoints, std::string out,
              std::function<Attributes()> attributes)
      : integ_(integ), checkpoints_(std::move(checkpoints)), out_(std::move(out)),
        attributes_(std::move(attributes)), tty_(isatty(2)) {
    std::sort(checkpoints_.begin(), checkpoints_.end());
  }
  void on_pass(const Stats& s, double fraction) override {
    while (next_ < checkpoints_.size() && s.seconds >= checkpoints_[next_]) {
      Film film;
      integ_.develop(film);
      const std::string path = checkpoint_path(checkpoints_[next_]);
      write_exr(path, film, attributes_());
      written.push_back(path);
      ++next_;
    }
    if (!tty_) return;
    const auto now = std::chrono::steady_clock::now();
    if (fraction < 1 && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    const int width = 30, filled = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * width);
    fmt::print(stderr, "\r[{}{}] {:3.0f}%  pass {}  {:.1f}s  {:.1f} Mrays/s ", std::string(filled, '#'),
               std::string(width - filled, ' '), 100 * std::max(0.0, fraction), s.passes, s.seconds,
               s.seconds > 0 ? s.rays / s.seconds * 1e-6 : 0.0);
  }
  void finish() {
    if (tty_) fmt::print(stderr, "\n");
  }
  std::string checkpoint_path(double t) const {
    fs::path p(out_);
    return (p.parent_path() / fmt::format("{}.{:g}s{}", p.stem().string(), t, p.extension().string())).string();
  }
  std::vector<std::string> written;

 private:
  const Integrator& integ_;
  std::vector<double> checkpoints_;
  size_t next_ = 0;
  std::string out_;
  std::function<Attributes()> attributes_;
  bool tty_;
  std::chrono::steady_clock::time_point last_{};
};

void print_warnings(const Scene& scene) {
  for (const auto& line : scene.warnings.summary()) fmt::print(stderr, "warning: {}\n", line);
}

std::string scene_summary(const Scene& scene) {
  std::ostringstream s;
  const Bounds3& b = scene.bounds();
  s << fmt::format("scene      {}\n", scene.source);
  s << fmt::format("meshes     {}\ntriangles  {}\n", scene.meshes.size(), scene.triangle_count());
  s << fmt::format("materials  {}\n", scene.materials.size());
  for (const Material& m : scene.materials)
    s << fmt::format("  {:<16} {}{}{}\n", m.name, to_string(m.type),
                     m.type == MaterialType::Conductor || m.type == MaterialType::Dielectric
                         ? fmt::format(" roughness {:g}", m.roughness) : "",
                     m.is_emissive() ? fmt::format(" emits {:g}", m.radiance().average()) : "");
  size_t area = 0;
  for (const Light& l : scene.light_set().lights()) area += l.type == LightType::Area;
  s << fmt::format("lights     {} ({} emissive triangles)\n", scene.light_set().lights().size(), area);
  for (const Light& l : scene.lights) {
    const char* kind = l.type == LightType::Point ? "point" : l.type == LightType::Spot ? "spot"
                     : l.type == LightType::Directional ? "sun" : "environment";
    s << fmt::format("  {:<16} {}\n", l.name, kind);
  }
  s << fmt::format("bounds     [{:g} {:g} {:g}] .. [{:g} {:g} {:g}]\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
  s << fmt::format("camera     {}x{}, fov {:g} deg{}\n", scene.camera.width, scene.camera.height,
                   scene.camera.fov_degrees,
                   scene.camera.aperture_radius > 0 ? fmt::format(", aperture {:g} m", scene.camera.aperture_radius) : "");
  s << fmt::format("warnings   {}\n", scene.warnings.total());
  return s.str();
}

// ---- render ----
struct RenderArgs {
  std::string scene, method = "pt", out, png, recon;
  double lambda = 0;
  double seconds = 0;
  int64_t passes = 0;
  int width = 0, height = 0, threads = 0, max_depth = 0;
  uint64_t seed = 0;
  // Photon methods (ppm, sppm): set only when given, so each method keeps its defaults.
  std::optional<double> alpha, radius, confidence;
  std::optional<int64_t> photons;
  std::optional<std::string> hash;
  std::optional<std::string> photon_sampler;
  double target_error = 0;
  std::vector<double> checkpoints;
  std::vector<std::string> params;
  // Spectral mode and spectral gradient sampling (docs/spectral.md); unset = method defaults.
  std::string spectral;
  std::optional<double> delta, tau;
  std::optional<int> bins;
};

void make_parent_dirs(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
}

int run_render(const RenderArgs& a) {
  make_parent_dirs(a.out);
  if (!a.png.empty()) make_parent_dirs(a.png);
  Scene scene = load_scene(a.scene);
  print_warnings(scene);
  if (a.width > 0) scene.camera.width = a.width;
  if (a.height > 0) scene.camera.height = a.height;
  Params params;
  params.set("seed", a.seed);
  params.set("threads", a.threads);
  if (a.max_depth > 0) params.set("max_depth", a.max_depth);
  if (a.alpha) params.set("alpha", *a.alpha);
  if (a.radius) params.set("radius", *a.radius);
  if (a.confidence) params.set("confidence", *a.confidence);
  if (a.photons) params.set("photons", *a.photons);
  if (a.hash) params.set("hash", *a.hash);
  if (!a.recon.empty()) params.set("recon", a.recon);
  if (a.lambda > 0) params.set("lambda", a.lambda);
  if (!a.spectral.empty()) params.set("spectral", a.spectral);
  if (a.delta) params.set("delta", *a.delta);
  if (a.tau) params.set("tau", *a.tau);
  if (a.bins) params.set("bins", *a.bins);
  if (a.photon_sampler) params.set("photon_sampler", *a.photon_sampler);
  for (const std::string& kv : a.params) {  // --param name=value, value parsed as JSON if it can be
    const auto eq = kv.find('=');
    if (eq == std::string::npos) throw ParamError("--param expects name=value, got '" + kv + "'");
    const std::string value = kv.substr(eq + 1);
    auto parsed = nlohmann::json::parse(value, nullptr, false);
    params.set(kv.substr(0, eq), parsed.is_discarded() ? nlohmann::json(value) : parsed);
  }
  auto integrator = make_integrator(a.method, scene, params);
  for (const auto& name : params.unused())
    fmt::print(stderr, "warning: parameter '{}' is not used by method '{}'\n", name, a.method);

  StopRule stop;
  stop.seconds = a.seconds;
  stop.passes = a.passes;
  stop.target_error = a.target_error;
  if (stop.seconds <= 0 && stop.passes <= 0 && stop.target_error <= 0) stop.passes = 16;
  auto record = [&] { return to_attributes(make_run_info(integrator->name(), params, integrator->stats(), scene)); };
  CliProgress progress(*integrator, a.checkpoints, a.out, record);
  g_sink = &progress;
  std::signal(SIGINT, on_sigint);
  run_progressive(*integrator, stop, &progress);
  progress.finish();
  g_sink = nullptr;

  Film film;
  integrator->develop(film);
  write_exr(a.out, film, record());
  const Stats& s = integrator->stats();
  fmt::print("method     {}\n", integrator->name());
  if (a.method == "pt" && integrator->name() != "pt") {
    const std::string why = first_dispersive_material(scene);
    fmt::print("spectral   on: {} (method pt ran as {})\n",
               why.empty() ? std::string("forced by --spectral spectral") : "dispersive material '" + why + "'",
               integrator->name());
  }
  fmt::print("passes     {}\npaths      {}\nrays       {}\n", s.passes, s.paths, s.rays);
  fmt::print("seconds    {:.3f}\nMrays/s    {:.2f}\n", s.seconds, s.seconds > 0 ? s.rays / s.seconds * 1e-6 : 0.0);
  if (const double err = integrator->estimated_error(); err >= 0) fmt::print("est. error {:.4g}\n", err);
  if (s.invalid_samples) fmt::print("discarded  {} NaN/Inf samples\n", s.invalid_samples);
  // Image mean of the combined pass (and of the other passes), for quick comparisons between
  // methods and modes.
  for (const auto& [name, p] : film.passes()) {
    double m[3] = {0, 0, 0};
    for (size_t i = 0; i < film.pixel_count(); ++i)
      for (int k = 0; k < p.channels; ++k) m[k] += p.data[p.channels * i + k];
    const double n = std::max<double>(1.0, static_cast<double>(film.pixel_count()));
    const std::string label = name == pass::kCombined ? "mean rgb" : "mean " + name;
    if (p.channels == 3)
      fmt::print("{:<10} {:.6g} {:.6g} {:.6g}\n", label, m[0] / n, m[1] / n, m[2] / n);
    else
      fmt::print("{:<10} {:.6g}\n", label, m[0] / n);
  }
  for (const auto& [k, v] : s.extra) fmt::print("{:<16} {:g}\n", k, v);
  if (progress.cancel_flag) fmt::print("cancelled  yes (image so far written)\n");
  fmt::print("exr        {}\n", a.out);
  for (const auto& p : progress.written) fmt::print("checkpoint {}\n", p);
  if (!a.png.empty()) {
    write_png(a.png, film);
    fmt::print("png        {} ({})\n", a.png, describe_display({}));
  }
  return 0;
}

// ---- diff ----
int run_diff(const std::string& a_path, const std::string& ref_path, const std::string& pass_name,
             const std::string& png, const std::string& error_pass) {
  const Film a = read_exr(a_path), ref = read_exr(ref_path);
  if (!a.has_pass(pass_name)) throw std::runtime_error(fmt::format("{}: no pass '{}'", a_path, pass_name));
  if (!ref.has_pass(pass_name)) throw std::runtime_error(fmt::format("{}: no pass '{}'", ref_path, pass_name));
  if (a.width() != ref.width() || a.height() != ref.height())
    throw std::runtime_error(fmt::format("{} is {}x{} but {} is {}x{}", a_path, a.width(), a.height(), ref_path,
                                         ref.width(), ref.height()));
  const DiffResult d = diff_images(a.pass(pass_name), ref.pass(pass_name), a.width(), a.height());
  fmt::print("relMSE     {:.6g}\nRMSE       {:.6g}\nmean ratio {:.6g}\n", d.rel_mse, d.rmse, d.mean_ratio);
  if (d.nonfinite) fmt::print("non-finite {}\n", d.nonfinite);
  if (!error_pass.empty()) {
    // Calibration of an error estimate (thesis Figure 6.6): the share of pixels whose
    // estimated relative error bound is at least the actual relative error against the
    // reference, |L - L_ref| / L on luminance, over pixels with L > 0.
    if (!a.has_pass(error_pass)) throw std::runtime_error(fmt::format("{}: no pass '{}'", a_path, error_pass));
    const Pass& e = a.pass(error_pass);
    size_t covered = 0, n = 0;
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x) {
        const float L = a.rgb(pass_name, x, y).luminance(), R = ref.rgb(pass_name, x, y).luminance();
        if (!(L > 0)) continue;
        ++n;
        covered += e.data[static_cast<size_t>(y) * a.width() + x] >= std::abs(L - R) / L;
      }
    fmt::print("coverage   {:.4f} ({} of {} pixels: estimated bound >= actual error)\n",
               n ? double(covered) / n : 0.0, covered, n);
  }
  if (!png.empty()) {
    float vmax = 0;
    for (float v : d.per_pixel_rel_se) vmax = std::max(vmax, v);
    write_false_color_png(png, d.per_pixel_rel_se, a.width(), a.height(), vmax > 0 ? vmax : 1.0f);
    fmt::print("error png  {} (scale 0..{:.3g})\n", png, vmax);
  }
  return 0;
}

// ---- merge ----
int run_merge(const std::vector<std::string>& inputs, const std::string& out, const std::string& png, int threads) {
  const MergeResult m = merge_files(inputs, threads);
  for (const auto& w : m.warnings) fmt::print(stderr, "warning: {}\n", w);
  make_parent_dirs(out);
  Attributes record = to_attributes(m.run);
  record["gradphoton.merged_from"] = nlohmann::json(inputs).dump();
  write_exr(out, m.film, record);
  fmt::print("method     {}\nruns       {}\npasses     {}\npaths      {}\nseconds    {:.3f}\n", m.run.method, m.run.runs,
             m.run.passes, m.run.paths, m.run.seconds);
  for (const std::string& path : inputs) {
    const RunInfo r = from_attributes(read_exr_attributes(path), path);
    fmt::print("weight     {:.4f}  {} (seed {}, {} passes)\n", double(r.paths) / double(m.run.paths), path,
               r.seeds.front(), r.passes);
  }
  if (merge_keeps_bias(m.run.method))
    fmt::print("note       {} is a photon method: the merged image has the variance of all runs together but the "
               "bias of one run's passes (docs/distributed.md)\n", m.run.method);
  fmt::print("exr        {}\n", out);
  if (!png.empty()) {
    make_parent_dirs(png);
    write_png(png, m.film);
    fmt::print("png        {} ({})\n", png, describe_display({}));
  }
  return 0;
}

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
  const double n_closest = static_cast<double>(recorded.closest.size());
  const double n_shadow = static_cast<double>(recorded.shadow.size());

  auto pt = make_integrator("pt", scene, params);
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
  Params params;
  params.set("photons", photons);
  params.set("threads", threads);
  params.set("hash", hash);
  auto sppm = make_integrator("sppm", scene, params);
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
  auto plain = make_integrator("sppm", scene, defaults);
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

// ---- reconstruct ----
// Screened Poisson reconstruction of EXR inputs: primal from `primal_path` (pass "primal", else
// "combined"), gradients from `grad_path` (passes gradient_x, gradient_y) or, without it, from
// the primal file itself.
int run_reconstruct(const std::string& primal_path, const std::string& grad_path, bool l1, double lambda,
                    const std::string& out, int threads) {
  const Film pf = read_exr(primal_path);
  const Film gf = grad_path.empty() ? pf : read_exr(grad_path);
  const std::string gpath = grad_path.empty() ? primal_path : grad_path;
  const std::string_view primal_name = pf.has_pass(pass::kPrimal) ? pass::kPrimal : pass::kCombined;
  if (!pf.has_pass(primal_name))
    throw std::runtime_error(fmt::format("{}: no pass 'primal' or 'combined'", primal_path));
  for (auto name : {pass::kGradientX, pass::kGradientY})
    if (!gf.has_pass(name)) throw std::runtime_error(fmt::format("{}: no pass '{}'", gpath, name));
  if (gf.width() != pf.width() || gf.height() != pf.height())
    throw std::runtime_error(fmt::format("{} is {}x{} but {} is {}x{}", primal_path, pf.width(), pf.height(), gpath,
                                         gf.width(), gf.height()));
  const Pass& p = pf.pass(primal_name);
  const Pass& gx = gf.pass(pass::kGradientX);
  const Pass& gy = gf.pass(pass::kGradientY);
  if (gx.channels != p.channels || gy.channels != p.channels)
    throw std::runtime_error("primal and gradient passes have different channel counts");
  ReconOptions o;
  o.norm = l1 ? ReconNorm::L1 : ReconNorm::L2;
  o.lambda = lambda;
  o.threads = threads;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<float> r = screened_poisson(p.data, gx.data, gy.data, pf.width(), pf.height(), p.channels, o);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Film film(pf.width(), pf.height());
  film.add_pass(pass::kCombined, p.channels).data = r;
  film.add_pass(pass::kPrimal, p.channels).data = p.data;
  film.add_pass(pass::kGradientX, p.channels).data = gx.data;
  film.add_pass(pass::kGradientY, p.channels).data = gy.data;
  make_parent_dirs(out);
  Attributes record = read_exr_attributes(primal_path);  // the run's record, for audits
  std::erase_if(record, [](const auto& kv) { return kv.first.rfind("gradphoton.", 0) != 0; });
  write_exr(out, film, record);
  fmt::print("reconstruction {} lambda {:g}, {}x{}, {:.3f} s\nexr        {}\n", l1 ? "L1" : "L2", lambda,
             pf.width(), pf.height(), secs, out);
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

int main(int argc, char** argv) {
  CLI::App app{"gradphoton: a physically based renderer for caustics, glass and dispersion"};
  app.set_version_flag("--version", GRADPHOTON_VERSION);
  app.require_subcommand(1);

  RenderArgs ra;
  std::string methods;
  for (const auto& n : integrator_names()) methods += (methods.empty() ? "" : "|") + n;
  auto* render = app.add_subcommand("render", "Render a scene progressively to a multi-layer EXR");
  render->add_option("scene", ra.scene, "Scene file (JSON, see docs/scene-format.md)")->required()->check(CLI::ExistingFile);
  render->add_option("--method", ra.method, "Rendering method: " + methods)->capture_default_str();
  render->add_option("--time", ra.seconds, "Stop after this many seconds of rendering");
  render->add_option("--passes", ra.passes, "Stop after this many passes (default 16 if no --time)");
  render->add_option("--width", ra.width, "Image width (overrides the scene)");
  render->add_option("--height", ra.height, "Image height (overrides the scene)");
  render->add_option("--threads", ra.threads, "Worker threads (0 = all cores)")->capture_default_str();
  render->add_option("--seed", ra.seed, "Random seed")->capture_default_str();
  render->add_option("--max-depth", ra.max_depth, "Longest path in segments");
  render->add_option("-o,--output", ra.out, "Output EXR (one layer per pass)")->required();
  render->add_option("--png", ra.png, "Also write a display PNG through OpenColorIO");
  render->add_option("--checkpoints", ra.checkpoints, "Write OUT.<T>s.exr snapshots at these render times (seconds)")
      ->delimiter(',');
  render->add_option("--recon", ra.recon, "Gradient methods: screened Poisson reconstruction l2 or l1 (default l2 for gpt; l1 for gpm and gdmlt)")
      ->check(CLI::IsMember({"l1", "l2"}));
  render->add_option("--lambda", ra.lambda, "Gradient methods: weight of the primal image (default 0.2)")
      ->check(CLI::PositiveNumber);
  render->add_option("--param", ra.params, "Method parameter name=value (repeatable)");
  render->add_option("--alpha", ra.alpha, "photon methods: fraction of new photons kept per pass, in (0,1) (default 0.7; msppm 0.6)");
  render->add_option("--photons", ra.photons, "photon methods: photons emitted per pass (default 100000; msppm: one per pixel)");
  render->add_option("--radius", ra.radius, "photon methods: initial gathering radius in metres (default: from the pixel footprint)");
  render->add_option("--confidence", ra.confidence, "ppm/sppm: confidence of the error estimate, in (0,1) (default 0.5)");
  render->add_option("--hash", ra.hash, "ppm/sppm: photon lookup, exact|stochastic (default exact)");
  render->add_option("--photon-sampler", ra.photon_sampler,
                     "ppm/sppm: photon paths by uniform sampling or by adaptive MCMC on their visibility "
                     "(thesis ch. 8), uniform|adaptive (default uniform)");
  render->add_option("--target-error", ra.target_error,
                     "Stop when the average estimated relative error falls below this (ppm/sppm)");
  render->add_option("--spectral", ra.spectral,
                     "Spectral mode: auto (spectral only with a dispersive material), rgb or spectral")
      ->check(CLI::IsMember({"auto", "rgb", "spectral"}));
  render->add_option("--delta", ra.delta, "sgpt: wavelength shift as a fraction of 360-830 nm (default 0.15)");
  render->add_option("--tau", ra.tau, "sgpt: shift threshold tau of the paper's eq. 16 (default 0)");
  render->add_option("--bins", ra.bins, "sgpt: spectral bins per pixel (default 15)");

  std::vector<std::string> merge_inputs;
  std::string merge_out, merge_png;
  int merge_threads = 0;
  auto* merge = app.add_subcommand(
      "merge",
      "Merge independent-seed runs of one render (e.g. Slurm array tasks), each weighted by the work it did");
  merge->footer(
      "Runs must share scene, image size, method and method parameters, and differ in --seed; anything else is "
      "refused, naming the file.\n"
      "Unbiased methods (pt, spt, spt-hero, sgpt): the work-weighted mean, as one run with all the samples.\n"
      "Gradient methods (gpt, gpm, gdmlt): primal and gradients are merged, then reconstructed once with the runs' "
      "--recon and --lambda.\n"
      "Photon methods (ppm, sppm, sppm-adaptive, msppm, gpm): N runs of K passes have 1/N of one run's variance but "
      "the BIAS OF K PASSES (each run shrinks its own radius); one run of N*K passes has less. Prefer fewer, longer "
      "runs (measured in docs/distributed.md).");
  merge->add_option("runs", merge_inputs, "EXR files written by gradphoton render (or the Blender addon)")
      ->required()->check(CLI::ExistingFile);
  merge->add_option("-o,--output", merge_out, "Merged EXR (carries the merged run record)")->required();
  merge->add_option("--png", merge_png, "Also write a display PNG through OpenColorIO");
  merge->add_option("--threads", merge_threads, "Worker threads for the reconstruction (0 = all cores)")
      ->capture_default_str();

  std::string diff_a, diff_ref, diff_pass = "combined", diff_png, diff_error_pass;
  auto* diff = app.add_subcommand("diff", "Compare an EXR with a reference: relMSE, RMSE, mean ratio");
  diff->add_option("image", diff_a, "Image EXR")->required()->check(CLI::ExistingFile);
  diff->add_option("reference", diff_ref, "Reference EXR")->required()->check(CLI::ExistingFile);
  diff->add_option("--pass", diff_pass, "Pass to compare")->capture_default_str();
  diff->add_option("--png", diff_png, "Write a false-colour per-pixel relative error PNG");
  diff->add_option("--error-pass", diff_error_pass,
                   "Also report how often this estimated-relative-error pass bounds the actual error (e.g. error)");

  std::string info_scene;
  auto* info = app.add_subcommand("info", "Print a scene summary and its warnings");
  info->add_option("scene", info_scene, "Scene file")->required()->check(CLI::ExistingFile);

  std::string bench_scene;
  double bench_seconds = 3;
  int bench_threads = 0;
  auto* bench = app.add_subcommand("bench", "Raw Embree ray throughput next to the path tracer's, same scene");
  bench->add_option("scene", bench_scene, "Scene file")->required()->check(CLI::ExistingFile);
  bench->add_option("--seconds", bench_seconds, "Seconds per measurement")->capture_default_str();
  bench->add_option("--threads", bench_threads, "Worker threads (0 = all cores)")->capture_default_str();

  std::string bp_scene, bp_hash = "exact";
  int64_t bp_photons = 1000000;
  int bp_passes = 3, bp_threads = 0, bp_width = 0;
  auto* bench_photons = app.add_subcommand(
      "bench-photons", "Photon tracing rate beside raw Embree; SPPM pass time split into trace, lookup, update");
  bench_photons->add_option("scene", bp_scene, "Scene file")->required()->check(CLI::ExistingFile);
  bench_photons->add_option("--photons", bp_photons, "Photons per pass")->capture_default_str();
  bench_photons->add_option("--passes", bp_passes, "Passes timed (after one warm-up pass)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  bench_photons->add_option("--threads", bp_threads, "Worker threads (0 = all cores)")->capture_default_str();
  bench_photons->add_option("--hash", bp_hash, "exact|stochastic")->capture_default_str();
  bench_photons->add_option("--width", bp_width, "Image width (height keeps the aspect ratio; default: the scene's)");
  std::string rec_primal, rec_grad, rec_out;
  bool rec_l1 = false, rec_l2 = false;
  double rec_lambda = 0.2;
  int rec_threads = 0;
  auto* recon = app.add_subcommand(
      "reconstruct", "Screened Poisson reconstruction (L2 or L1) of a primal image and its gradients");
  recon->add_option("primal", rec_primal, "EXR with the primal image (pass 'primal', else 'combined'); "
                                          "may also hold gradient_x and gradient_y")
      ->required()->check(CLI::ExistingFile);
  recon->add_option("gradients", rec_grad, "EXR with passes gradient_x and gradient_y")->check(CLI::ExistingFile);
  auto* l1_flag = recon->add_flag("--l1", rec_l1, "L1 reconstruction (IRLS): robust to outlier gradients");
  recon->add_flag("--l2", rec_l2, "L2 reconstruction (default): unbiased")->excludes(l1_flag);
  recon->add_option("--lambda", rec_lambda, "Weight of the primal image")->capture_default_str();
  recon->add_option("--threads", rec_threads, "Worker threads (0 = all cores)")->capture_default_str();
  recon->add_option("-o,--output", rec_out, "Output EXR (combined = reconstruction, plus the inputs)")->required();

  int brec_width = 1000, brec_height = 1000, brec_repeats = 5, brec_threads = 0;
  auto* bench_rec = app.add_subcommand("bench-reconstruct", "Median L2 and L1 reconstruction times");
  bench_rec->add_option("--width", brec_width)->capture_default_str();
  bench_rec->add_option("--height", brec_height)->capture_default_str();
  bench_rec->add_option("--repeats", brec_repeats)->capture_default_str()->check(CLI::PositiveNumber);
  bench_rec->add_option("--threads", brec_threads, "Worker threads (0 = all cores)")->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*render) return run_render(ra);
    if (*merge) return run_merge(merge_inputs, merge_out, merge_png, merge_threads);
    if (*diff) return run_diff(diff_a, diff_ref, diff_pass, diff_png, diff_error_pass);
    if (*info) {
      Scene scene = load_scene(info_scene);
      fmt::print("{}", scene_summary(scene));
      print_warnings(scene);
      return 0;
    }
    if (*bench) return run_bench(bench_scene, bench_seconds, bench_threads);
    if (*bench_photons) return run_bench_photons(bp_scene, bp_photons, bp_passes, bp_threads, bp_hash, bp_width);
    if (*recon) return run_reconstruct(rec_primal, rec_grad, rec_l1, rec_lambda, rec_out, rec_threads);
    if (*bench_rec) return run_bench_reconstruct(brec_width, brec_height, brec_repeats, brec_threads);
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
  return 0;
}
