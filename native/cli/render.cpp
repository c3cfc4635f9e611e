// `gradphoton render` (a scene, progressively, to a multi-layer EXR) and `gradphoton methods`
// (the methods and their parameters as declared: integrators/methods.h).
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>

#include "cli/commands.h"
#include "core/parallel.h"
#include "distributed/run_info.h"
#include "integrators/integrator.h"
#include "integrators/spectral/spectral_pt.h"
#include "io/display.h"
#include "io/exr.h"
#include "scene/loader.h"
#include "session/render_session.h"

namespace fs = std::filesystem;

namespace gp::cli {

namespace {

std::atomic<ProgressSink*> g_sink{nullptr};

void on_sigint(int) {
  if (ProgressSink* s = g_sink.load()) s->cancel_flag = true;  // finish with the image so far
}

// Progress bar on stderr (only when it is a terminal) and checkpoint snapshots, each with the
// run's record so far (`attributes`).
class CliProgress : public ProgressSink {
 public:
  CliProgress(const RenderSession& session, std::vector<double> checkpoints, std::string out)
      : session_(session), checkpoints_(std::move(checkpoints)), out_(std::move(out)), tty_(isatty(2)) {
    std::sort(checkpoints_.begin(), checkpoints_.end());
  }
  void on_pass(const Stats& s, double fraction) override {
    while (next_ < checkpoints_.size() && s.seconds >= checkpoints_[next_]) {
      const std::string path = checkpoint_path(checkpoints_[next_]);
      session_.write_exr(path);
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
  const RenderSession& session_;
  std::vector<double> checkpoints_;
  size_t next_ = 0;
  std::string out_;
  bool tty_;
  std::chrono::steady_clock::time_point last_{};
};

// ---- render ----
struct RenderArgs {
  std::string scene, method = "pt", out, png;
  double seconds = 0;
  int64_t passes = 0;
  int width = 0, height = 0;
  std::string pixel_filter;  // --pixel-filter TYPE[:WIDTH] (empty: the scene's)
  double target_error = 0;
  std::vector<double> checkpoints;
  std::vector<std::string> params;
  std::vector<int> pixel;  // --pixel X,Y (empty: the whole image)
  // Method parameters given as --<name> (one option per declared name, methods.h): set only
  // when given, so each method keeps its own defaults.
  std::map<std::string, std::string> method_params;
};

// A command-line value as the JSON of the parameter's declared type: strings as given, numbers
// and booleans parsed (a value that does not parse stays a string, and its declaration's check
// names it).
nlohmann::json param_value(const std::string& name, const std::string& text) {
  for (const Method& m : methods())
    if (const ParamDecl* d = m.find(name); d && d->type == ParamType::String) return text;
  auto parsed = nlohmann::json::parse(text, nullptr, false);
  return parsed.is_discarded() ? nlohmann::json(text) : parsed;
}

// Help of --<name>: the declaration's description, symbol and equation, range, and each
// method's default ("0.7: ppm, sppm, sppm-adaptive, gpm; 0.6: msppm").
std::string param_help(const std::string& name) {
  const ParamDecl* first = nullptr;
  using Groups = std::vector<std::pair<std::string, std::string>>;  // (value, its methods)
  Groups defaults, ranges;
  const auto add = [](Groups& g, const std::string& v, const std::string& method) {
    auto it = std::find_if(g.begin(), g.end(), [&](const auto& e) { return e.first == v; });
    if (it == g.end()) g.emplace_back(v, method);
    else it->second += ", " + method;
  };
  std::string all_methods;
  for (const Method& m : methods()) {
    all_methods += (all_methods.empty() ? "" : ", ") + m.name;
    const ParamDecl* d = m.find(name);
    if (!d) continue;
    if (!first) first = d;
    add(defaults, d->default_text(), m.name);
    add(ranges, d->range_text(), m.name);
  }
  std::string h = first->description;
  if (!first->symbol.empty() || !first->reference.empty())
    h += " (" + first->symbol + (first->symbol.empty() || first->reference.empty() ? "" : ", ") + first->reference + ")";
  // One range, or each with its methods where they differ (photons: 0 is automatic in some).
  for (size_t i = 0; i < ranges.size(); ++i)
    if (!ranges[i].first.empty())
      h += (i ? ", " : "; ") + ranges[i].first + (ranges.size() > 1 ? " (" + ranges[i].second + ")" : "");
  h += ". Default";
  for (size_t i = 0; i < defaults.size(); ++i)
    h += (i ? "; " : " ") + defaults[i].first + " (" +
         (defaults[i].second.size() == all_methods.size() ? std::string("every method") : defaults[i].second) + ")";
  return h;
}

int run_render(const RenderArgs& a) {
  make_parent_dirs(a.out);
  if (!a.png.empty()) make_parent_dirs(a.png);
  auto loaded = std::make_shared<Scene>(load_scene(a.scene));
  Scene& scene = *loaded;
  print_warnings(scene);
  if (a.width > 0) scene.camera.width = a.width;
  if (a.height > 0) scene.camera.height = a.height;
  if (!a.pixel_filter.empty()) {
    try {
      scene.camera.filter = PixelFilter::parse(a.pixel_filter);
    } catch (const std::invalid_argument& e) {
      throw ParamError(fmt::format("--pixel-filter {}: {}", a.pixel_filter, e.what()));
    }
  }
  Params params;
  for (const auto& [name, value] : a.method_params) params.set(name, param_value(name, value));
  for (const std::string& kv : a.params) {  // --param name=value
    const auto eq = kv.find('=');
    if (eq == std::string::npos) throw ParamError("--param expects name=value, got '" + kv + "'");
    params.set(kv.substr(0, eq), param_value(kv.substr(0, eq), kv.substr(eq + 1)));
  }
  // --pixel X,Y: that pixel only, single-threaded (PixelWindow, core/parallel.h), as pbrt's.
  std::optional<PixelWindow> window;
  if (!a.pixel.empty()) {
    const int x = a.pixel[0], y = a.pixel[1];
    if (x < 0 || y < 0 || x >= scene.camera.width || y >= scene.camera.height)
      throw ParamError(fmt::format("--pixel {},{} is outside the {}x{} image", x, y, scene.camera.width,
                                   scene.camera.height));
    if (!find_method(a.method).per_pixel)
      throw ParamError("--pixel: method '" + a.method + "' does not trace its pixels independently (Markov chains "
                       "over the whole image)");
    params.set("threads", 1);
    window.emplace(x, y);
  }
  RenderSession session(loaded, a.method, params);
  for (const auto& line : session.unused_report()) fmt::print(stderr, "warning: {}\n", line);
  for (const auto& line : session.feature_report()) fmt::print(stderr, "warning: {}\n", line);
  const Integrator* integrator = &session.integrator();

  StopRule stop;
  stop.seconds = a.seconds;
  stop.passes = a.passes;
  stop.target_error = a.target_error;
  if (stop.seconds <= 0 && stop.passes <= 0 && stop.target_error <= 0) stop.passes = 16;
  for (const auto& line : session.stop_report(stop)) fmt::print(stderr, "warning: {}\n", line);
  CliProgress progress(session, a.checkpoints, a.out);
  g_sink = &progress;
  std::signal(SIGINT, on_sigint);
  session.run(stop, &progress);
  progress.finish();
  g_sink = nullptr;

  const Film film = session.develop();
  write_exr(a.out, film, session.run_record());
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
  if (window) {  // the pixel's value in every pass, to the last digit (for comparisons)
    const size_t i = static_cast<size_t>(a.pixel[1]) * film.width() + a.pixel[0];
    for (const auto& [name, p] : film.passes()) {
      std::string v;
      for (int k = 0; k < p.channels; ++k) v += fmt::format(" {:.9g}", p.data[p.channels * i + k]);
      fmt::print("pixel {},{} {}{}\n", a.pixel[0], a.pixel[1], name, v);
    }
  }
  if (progress.cancel_flag) fmt::print("cancelled  yes (image so far written)\n");
  fmt::print("exr        {}\n", a.out);
  for (const auto& p : progress.written) fmt::print("checkpoint {}\n", p);
  if (!a.png.empty()) {
    write_png(a.png, film);
    fmt::print("png        {} ({})\n", a.png, describe_display({}));
  }
  return 0;
}

// ---- methods ----
// The methods, or one method's parameters, as declared (methods.cpp).
int run_methods(const std::string& name) {
  if (name.empty()) {
    for (const Method& m : methods()) fmt::print("{:<14} {:<18} {}\n", m.name, m.label, m.summary);
    fmt::print("\n`gradphoton methods NAME` lists a method's parameters; give them to render as --<name> VALUE.\n");
    return 0;
  }
  const Method& m = find_method(name);
  fmt::print("{} ({}): {}\n\n", m.name, m.label, m.summary);
  for (const ParamDecl& d : m.params) {
    fmt::print("  {:<22} {:<6} default {:<8} {}\n", d.flag(), to_string(d.type),
               d.zero_means.empty() ? d.default_text() : std::string("0"), d.range_text());
    std::string more = d.description;
    if (!d.zero_means.empty()) more += "; 0 = " + d.zero_means;
    if (!d.read_when.empty()) more += "; read only with " + d.read_when;
    if (!d.symbol.empty() || !d.reference.empty())
      more += " (" + d.symbol + (d.symbol.empty() || d.reference.empty() ? "" : ", ") + d.reference + ")";
    fmt::print("      {}\n", more);
  }
  return 0;
}

}  // namespace

std::vector<Command> add_render_commands(CLI::App& app) {
  auto ra = std::make_shared<RenderArgs>();
  std::string method_list;
  for (const auto& n : integrator_names()) method_list += (method_list.empty() ? "" : "|") + n;
  auto* render = app.add_subcommand("render", "Render a scene progressively to a multi-layer EXR");
  render->add_option("scene", ra->scene, "Scene file (JSON, see docs/scene-format.md)")->required()->check(CLI::ExistingFile);
  render->add_option("--method", ra->method, "Rendering method: " + method_list)->capture_default_str();
  render->add_option("--time", ra->seconds, "Stop after this many seconds of rendering");
  render->add_option("--passes", ra->passes, "Stop after this many passes (default 16 if no --time)");
  render->add_option("--width", ra->width, "Image width (overrides the scene)");
  render->add_option("--height", ra->height, "Image height (overrides the scene)");
  render->add_option("--pixel-filter", ra->pixel_filter,
                     "Pixel filter TYPE[:WIDTH] (box, gaussian, blackman-harris; width in pixels, default 1.5, "
                     "box 1), overriding the scene's camera pixel_filter");
  render->add_option("-o,--output", ra->out, "Output EXR (one layer per pass)")->required();
  render->add_option("--png", ra->png, "Also write a display PNG through OpenColorIO");
  render->add_option("--checkpoints", ra->checkpoints, "Write OUT.<T>s.exr snapshots at these render times (seconds)")
      ->delimiter(',');
  render->add_option("--pixel", ra->pixel,
                     "Render only pixel X,Y (0,0 = top left), single-threaded, and print its value in every pass: "
                     "for debugging a method. Its samples are the full render's for the same seed (every pixel "
                     "draws its own random stream; photon methods to float rounding); a gradient method's primal "
                     "pass, not its reconstruction (docs/methods.md)")
      ->delimiter(',')->expected(2);
  render->add_option("--param", ra->params, "Method parameter name=value (repeatable; the same as --<name> value)");
  render->add_option("--target-error", ra->target_error,
                     "Stop when the estimated mean relative error, mean |L - L_true| / L over the pixels, falls to "
                     "this (ppm/sppm/gpm; docs/error-calibration.md)");
  // One option per parameter any method declares (methods.cpp): --alpha, --photons, --lambda ...
  std::vector<const ParamDecl*> declared;
  for (const Method& m : methods())
    for (const ParamDecl& d : m.params)
      if (std::none_of(declared.begin(), declared.end(), [&](const ParamDecl* e) { return e->name == d.name; }))
        declared.push_back(&d);
  for (const ParamDecl* d : declared) {
    const std::string name = d->name;
    render->add_option_function<std::string>(d->flag(), [ra, name](const std::string& v) { ra->method_params[name] = v; },
                                             param_help(name))
        ->type_name(d->type == ParamType::String ? "TEXT" : d->type == ParamType::Bool ? "BOOL"
                    : d->type == ParamType::Int  ? "INT" : "FLOAT")
        ->group("Method parameters (each method reads its own; `gradphoton methods` lists them)");
  }

  auto methods_name = std::make_shared<std::string>();
  auto* methods_cmd = app.add_subcommand("methods", "List the methods, or one method's parameters and defaults");
  methods_cmd->add_option("method", *methods_name, "A method's name: list its parameters");

  return {{render, [ra] { return run_render(*ra); }}, {methods_cmd, [methods_name] { return run_methods(*methods_name); }}};
}

}  // namespace gp::cli
