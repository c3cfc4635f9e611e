#include "integrators/integrator.h"

namespace gp {

namespace {
thread_local bool t_display_develop = false;
}
DisplayDevelop::DisplayDevelop() : saved_(t_display_develop) { t_display_develop = true; }
DisplayDevelop::~DisplayDevelop() { t_display_develop = saved_; }
bool DisplayDevelop::active() { return t_display_develop; }

void run_progressive(Integrator& integrator, const StopRule& stop, ProgressSink* sink) {
  if (stop.seconds <= 0 && stop.passes <= 0 && stop.target_error <= 0)
    throw ParamError("no stop rule: give a time budget, a pass count or a target error");
  for (;;) {
    if (sink && sink->cancelled()) return;
    integrator.iterate(sink);
    const Stats& s = integrator.stats();
    const double elapsed = s.seconds;
    double fraction = -1;
    if (stop.passes > 0) fraction = static_cast<double>(s.passes) / stop.passes;
    if (stop.seconds > 0) fraction = std::max(fraction, elapsed / stop.seconds);
    const double err = integrator.estimated_error();
    if (stop.target_error > 0 && err < 0 && stop.seconds <= 0 && stop.passes <= 0)
      throw ParamError("method '" + integrator.name() +
                       "' has no error estimate: give a time budget or a pass count");
    const bool error_reached = stop.target_error > 0 && err >= 0 && err <= stop.target_error;
    if (sink) sink->on_pass(s, std::min(1.0, fraction));
    if ((stop.passes > 0 && s.passes >= stop.passes) || (stop.seconds > 0 && elapsed >= stop.seconds) ||
        error_reached)
      return;
  }
}

void check_image_size(int width, int height) {
  if (width < 1 || height < 1) throw ParamError("image size must be at least 1x1");
}

}  // namespace gp
