#include "session/render_session.h"

#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "distributed/run_info.h"
#include "integrators/methods.h"
#include "io/exr.h"

namespace gp {

RenderSession::RenderSession(std::shared_ptr<const Scene> scene, const std::string& method, Params params)
    : scene_(std::move(scene)), params_(std::move(params)) {
  if (!scene_) throw std::invalid_argument("RenderSession: no scene");
  Scene::RenderGuard guard(*scene_);
  generation_ = scene_->generation();
  integrator_ = make_integrator(method, *scene_, params_);
  unused_ = params_.unused();
  unused_report_ = unused_parameter_report(method, params_);
  // Bound as `method` reads them; declared by what runs (pt may run as spt-hero).
  passes_ = find_method(integrator_->name()).passes_with(find_method(method).bind(params_), scene_.get());
  // Scene features the method does not render: said once, naming it; the rest still renders.
  if (scene_->has_media() && !find_method(method).supports.media) {
    std::vector<std::string> with_media;  // as the methods declare (Method::supports)
    for (const Method& m : methods())
      if (m.supports.media) with_media.push_back(m.name);
    feature_report_.push_back(fmt::format("method '{}' does not render participating media yet: the scene's media "
                                          "are left out and only its surfaces render ({} render them)",
                                          method, fmt::join(with_media, ", ")));
  } else if (scene_->has_grid_media() && !find_method(method).supports.grid_media) {
    std::vector<std::string> with_grids;
    for (const Method& m : methods())
      if (m.supports.grid_media) with_grids.push_back(m.name);
    feature_report_.push_back(fmt::format("method '{}' does not render grid (OpenVDB) media yet: the scene's media "
                                          "are left out and only its surfaces render ({} render them)",
                                          method, fmt::join(with_grids, ", ")));
  }
  if (scene_->has_motion() && !find_method(method).supports.motion_blur) {
    std::vector<std::string> with_blur;
    for (const Method& m : methods())
      if (m.supports.motion_blur) with_blur.push_back(m.name);
    feature_report_.push_back(fmt::format("method '{}' does not render motion blur: the scene renders at one instant "
                                          "of the shutter ({} blur it)",
                                          method, fmt::join(with_blur, ", ")));
  }
  // Light Paths > Caustics: Filter Glossy is path tracing's noise-reduction knob (Blender's
  // default 1.0 is on in nearly every scene), which the photon and gradient methods have no use
  // for: they say nothing of it (docs/blender.md). A caustics switch turned off is a request
  // they do not honour: said once.
  if ((!scene_->caustics_reflective || !scene_->caustics_refractive) && !find_method(method).supports.caustics) {
    std::vector<std::string> with;
    for (const Method& m : methods())
      if (m.supports.caustics) with.push_back(m.name);
    feature_report_.push_back(fmt::format("method '{}' renders reflective and refractive caustics whatever Light "
                                          "Paths > Caustics says (only {} leave them out)",
                                          method, fmt::join(with, ", ")));
  }
  aov_ = std::make_unique<AovEstimator>(*scene_, params_.get<uint64_t>("seed", 0), params_.get<int>("threads", 0));
}

std::vector<std::string> RenderSession::stop_report(const StopRule& stop) const {
  std::vector<std::string> lines;
  // The error model of thesis ch. 6 is the surface disc's; the beam estimate has none yet. Said
  // only to a render whose stop asks for it (a Target Error): run_progressive refuses one with no
  // other limit, so this one stops on its time or pass limit.
  if (stop.target_error > 0 && scene_->has_media() && method().error_estimate)
    lines.push_back(fmt::format("method '{}' estimates no error with participating media: the Target Error "
                                "is never reached and the render stops on its time or pass limit; the error pass "
                                "is 0 (docs/photon-mapping.md)",
                                integrator_->name()));
  return lines;
}

void RenderSession::check_fresh() const {
  if (stale()) throw std::logic_error("the scene changed since this session was made; make a new Session");
}

void RenderSession::aux_pass(ProgressSink* sink) {
  if (!aux_ || aov_->passes() >= AovEstimator::kMaxPasses || aov_->passes() >= integrator_->stats().passes) return;
  if (sink && sink->cancelled()) return;
  aov_->add_pass([sink] { return sink && sink->cancelled(); });
}

void RenderSession::iterate(ProgressSink* sink) {
  check_fresh();
  Scene::RenderGuard guard(*scene_);
  integrator_->iterate(sink);
  aux_pass(sink);
}

namespace {
// Puts the auxiliary pass between a pass and the caller's sink (which may develop checkpoints).
class AuxThenSink : public ProgressSink {
 public:
  AuxThenSink(ProgressSink* outer, std::function<void()> aux) : outer_(outer), aux_(std::move(aux)) {}
  void on_pass(const Stats& stats, double fraction) override {
    aux_();
    if (outer_) outer_->on_pass(stats, fraction);
  }
  bool cancelled() override { return (outer_ && outer_->cancelled()) || cancel_flag.load(); }

 private:
  ProgressSink* outer_;
  std::function<void()> aux_;
};
}  // namespace

void RenderSession::run(const StopRule& stop, ProgressSink* sink) {
  check_fresh();
  Scene::RenderGuard guard(*scene_);
  AuxThenSink both(sink, [&] { aux_pass(sink); });
  run_progressive(*integrator_, stop, &both);
}

Film RenderSession::develop(bool for_display) const {
  Scene::RenderGuard guard(*scene_);
  Film film;
  std::optional<DisplayDevelop> display;
  if (for_display) display.emplace();
  integrator_->develop(film);
  // Before a whole auxiliary pass there is nothing to show (Blender keeps them zero): this keeps
  // the image sent after an early Esc as cheap as before.
  if (aux_ && aov_->passes() > 0) aov_->develop(film);
  return film;
}

std::map<std::string, std::string> RenderSession::run_record() const {
  return to_attributes(make_run_info(integrator_->name(), params_, integrator_->stats(), *scene_));
}

void RenderSession::write_exr(const std::string& path) const { gp::write_exr(path, develop(), run_record()); }

}  // namespace gp
