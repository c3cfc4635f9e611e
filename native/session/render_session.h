// One progressive render, as every front end runs it (the CLI's `render` and `bench`, the Python
// module, hence Blender): a scene, a method and its parameters -> passes -> develop() -> an EXR
// with the run's record. The method's passes come with the auxiliary ones (Albedo, Normal,
// Depth: integrators/aov.h), made beside the first AovEstimator::kMaxPasses passes.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/film.h"
#include "core/params.h"
#include "core/progress.h"
#include "integrators/aov.h"
#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "scene/scene.h"

namespace gp {

class RenderSession {
 public:
  // Builds `method` on `scene` (make_integrator: ParamError for a bad method or value). The
  // parameters given but left unread are in unused_report().
  RenderSession(std::shared_ptr<const Scene> scene, const std::string& method, Params params);

  // One pass of the method, then one auxiliary pass while they are fewer than the method's.
  void iterate(ProgressSink* sink);
  // Passes until `stop` fires or `sink` cancels (run_progressive), each followed by an auxiliary
  // pass while they are fewer; `sink` sees every pass, after its auxiliary one (checkpoints
  // develop them all). A second call continues to larger totals.
  void run(const StopRule& stop, ProgressSink* sink);
  // Whether to make the auxiliary passes (on by default; Blender: when none is enabled, off).
  void set_aux_passes(bool on) { aux_ = on; }
  bool aux_passes() const { return aux_; }

  // Every pass of the current estimate: the method's, and the auxiliary ones once there is one.
  // for_display: an image to show while the render runs (integrators/integrator.h DisplayDevelop).
  Film develop(bool for_display = false) const;
  // develop() written as a multi-layer EXR with run_record() in its header.
  void write_exr(const std::string& path) const;
  // The run's record (distributed/run_info.h) as EXR header attributes.
  std::map<std::string, std::string> run_record() const;

  const Integrator& integrator() const { return *integrator_; }
  // The method as registered: `method` given, or what it ran as (pt as spt-hero in spectral mode).
  const Method& method() const { return find_method(integrator_->name()); }
  const Stats& stats() const { return integrator_->stats(); }
  const Params& params() const { return params_; }
  const std::vector<std::string>& unused() const { return unused_; }
  const std::vector<std::string>& unused_report() const { return unused_report_; }
  // Warnings on scene features the method leaves out ("method 'sppm' does not render
  // participating media yet: ..."), for every front end to show.
  const std::vector<std::string>& feature_report() const { return feature_report_; }
  // Warnings on what a stop rule asks of this method and scene that it cannot give (a Target
  // Error where media leave it without an error estimate), for every front end to show.
  std::vector<std::string> stop_report(const StopRule& stop) const;
  // The passes the method's develop() writes with these parameters on this scene, as it declares
  // them (Method::passes_with: alpha with a transparent film or a holdout), the auxiliary ones aside.
  const std::vector<std::string>& passes() const { return passes_; }
  const Scene& scene() const { return *scene_; }
  // A scene update (Scene::commit, set_camera) since the session was made leaves the integrator
  // with what it derived from the old scene: it must not render (make a new session).
  bool stale() const { return scene_->generation() != generation_; }

 private:
  std::shared_ptr<const Scene> scene_;
  Params params_;
  std::unique_ptr<Integrator> integrator_;
  std::unique_ptr<AovEstimator> aov_;
  bool aux_ = true;
  uint64_t generation_ = 0;
  std::vector<std::string> unused_, unused_report_, feature_report_, passes_;

  void check_fresh() const;
  void aux_pass(ProgressSink* sink);  // one auxiliary pass if they are fewer than the method's
};

}  // namespace gp
