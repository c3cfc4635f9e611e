// `gradphoton diff`, `info`, `reconstruct` and `merge`: commands on rendered images and scene
// files.
#include <fmt/format.h>

#include <chrono>
#include <memory>
#include <sstream>

#include "cli/commands.h"
#include "distributed/merge.h"
#include "distributed/run_info.h"
#include "io/display.h"
#include "io/exr.h"
#include "io/metrics.h"
#include "reconstruction/poisson.h"
#include "scene/loader.h"

namespace gp::cli {

namespace {

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

// ---- reconstruct ----
// Screened Poisson reconstruction of EXR inputs: primal from `primal_path` (pass "primal", else
// "combined"), gradients from `grad_path` (passes gradient_x, gradient_y) or, without it, from
// the primal file itself.
int run_reconstruct(const std::string& primal_path, const std::string& grad_path, bool l1, double lambda,
                    const std::string& out, int threads, double tolerance, int max_rounds) {
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
  if (tolerance > 0) o.tolerance = tolerance;
  if (max_rounds > 0) o.max_irls_iterations = max_rounds;
  const auto t0 = std::chrono::steady_clock::now();
  ReconReport rep;
  const std::vector<float> r =
      screened_poisson(p.data, gx.data, gy.data, pf.width(), pf.height(), p.channels, o, &rep);
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
  fmt::print("reconstruction {} lambda {:g}, {}x{}, {:.3f} s\n", l1 ? "L1" : "L2", lambda, pf.width(), pf.height(),
             secs);
  if (l1)
    fmt::print("L1 solve   {} IRLS rounds, {} PCG iterations, objective {:.12e} (sum |r| {:.12e}), estimated "
               "{:.2e} above its minimum{}\n",
               rep.irls_iterations, rep.cg_iterations, rep.objective, rep.objective_l1, rep.estimated_excess,
               rep.converged ? "" : " (tolerance NOT met)");
  fmt::print("exr        {}\n", out);
  return 0;
}

}  // namespace

std::vector<Command> add_image_commands(CLI::App& app) {
  struct MergeArgs {
    std::vector<std::string> merge_inputs;
    std::string merge_out, merge_png;
    int merge_threads = 0;
  };
  auto a = std::make_shared<MergeArgs>();
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
  merge->add_option("runs", a->merge_inputs, "EXR files written by gradphoton render (or the Blender addon)")
      ->required()->check(CLI::ExistingFile);
  merge->add_option("-o,--output", a->merge_out, "Merged EXR (carries the merged run record)")->required();
  merge->add_option("--png", a->merge_png, "Also write a display PNG through OpenColorIO");
  merge->add_option("--threads", a->merge_threads, "Worker threads for the reconstruction (0 = all cores)")
      ->capture_default_str();

  struct DiffArgs {
    std::string diff_a, diff_ref, diff_pass = "combined", diff_png, diff_error_pass;
  };
  auto d = std::make_shared<DiffArgs>();
  auto* diff = app.add_subcommand("diff", "Compare an EXR with a reference: relMSE, RMSE, mean ratio");
  diff->add_option("image", d->diff_a, "Image EXR")->required()->check(CLI::ExistingFile);
  diff->add_option("reference", d->diff_ref, "Reference EXR")->required()->check(CLI::ExistingFile);
  diff->add_option("--pass", d->diff_pass, "Pass to compare")->capture_default_str();
  diff->add_option("--png", d->diff_png, "Write a false-colour per-pixel relative error PNG");
  diff->add_option("--error-pass", d->diff_error_pass,
                   "Also report how often this estimated-relative-error pass bounds the actual error (e.g. error)");

  auto info_scene = std::make_shared<std::string>();
  auto* info = app.add_subcommand("info", "Print a scene summary and its warnings");
  info->add_option("scene", *info_scene, "Scene file")->required()->check(CLI::ExistingFile);

  struct ReconArgs {
    std::string rec_primal, rec_grad, rec_out;
    bool rec_l1 = false, rec_l2 = false;
    double rec_lambda = 0.2, rec_tolerance = 0;
    int rec_threads = 0, rec_max_rounds = 0;
  };
  auto r = std::make_shared<ReconArgs>();
  auto* recon = app.add_subcommand(
      "reconstruct", "Screened Poisson reconstruction (L2 or L1) of a primal image and its gradients");
  recon->add_option("primal", r->rec_primal, "EXR with the primal image (pass 'primal', else 'combined'); "
                                          "may also hold gradient_x and gradient_y")
      ->required()->check(CLI::ExistingFile);
  recon->add_option("gradients", r->rec_grad, "EXR with passes gradient_x and gradient_y")->check(CLI::ExistingFile);
  auto* l1_flag = recon->add_flag("--l1", r->rec_l1, "L1 reconstruction (IRLS): robust to outlier gradients");
  recon->add_flag("--l2", r->rec_l2, "L2 reconstruction (default): unbiased")->excludes(l1_flag);
  recon->add_option("--lambda", r->rec_lambda, "Weight of the primal image")->capture_default_str();
  recon->add_option("--threads", r->rec_threads, "Worker threads (0 = all cores)")->capture_default_str();
  recon->add_option("--tolerance", r->rec_tolerance,
                    "L1: stop when the objective is estimated within this fraction of its minimum (default 1e-4)")
      ->check(CLI::PositiveNumber);
  recon->add_option("--max-rounds", r->rec_max_rounds, "L1: cap on IRLS rounds (default 100)")
      ->check(CLI::PositiveNumber);
  recon->add_option("-o,--output", r->rec_out, "Output EXR (combined = reconstruction, plus the inputs)")->required();

  auto show_info = [info_scene] {
    Scene scene = load_scene(*info_scene);
    fmt::print("{}", scene_summary(scene));
    print_warnings(scene);
    return 0;
  };
  return {{merge, [a] { return run_merge(a->merge_inputs, a->merge_out, a->merge_png, a->merge_threads); }},
          {diff, [d] { return run_diff(d->diff_a, d->diff_ref, d->diff_pass, d->diff_png, d->diff_error_pass); }},
          {info, show_info},
          {recon, [r] {
             return run_reconstruct(r->rec_primal, r->rec_grad, r->rec_l1, r->rec_lambda, r->rec_out, r->rec_threads,
                                    r->rec_tolerance, r->rec_max_rounds);
           }}};
}

}  // namespace gp::cli
