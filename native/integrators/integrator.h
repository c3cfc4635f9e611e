// The progressive interface every method implements (DESIGN.md, "The progressive interface"):
// iterate() performs one pass, develop() writes the current estimate into a Film, and
// run_progressive() calls iterate() until a stop rule fires.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/film.h"
#include "core/params.h"
#include "core/progress.h"
#include "scene/scene.h"

namespace gp {

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual std::string name() const = 0;
  // One pass over the image. Polls `sink->cancelled()` and may return early, leaving the
  // estimate consistent (pixels not reached keep their earlier samples).
  virtual void iterate(ProgressSink* sink) = 0;
  // Writes every pass of the current estimate into `film` (sized to the camera).
  virtual void develop(Film& film) const = 0;
  // Current estimated mean relative error of the image (what --target-error stops on), or < 0
  // when the method has no estimate.
  virtual double estimated_error() const { return -1.0; }
  const Stats& stats() const { return stats_; }

 protected:
  Stats stats_;
};

// A develop for display while a render runs (Blender's F12 refresh, the viewport's image): a
// method may develop a cheaper approximation of its estimate there (the gradient methods solve
// their screened Poisson by L2 instead of L1: one linear solve, 0.3 s at 1920 x 1080 where the
// first passes' L1 took 20 s and held the render back). The final develop, checkpoints and EXRs
// are the method's own. A scope on the developing thread.
class DisplayDevelop {
 public:
  DisplayDevelop();
  ~DisplayDevelop();
  DisplayDevelop(const DisplayDevelop&) = delete;
  DisplayDevelop& operator=(const DisplayDevelop&) = delete;
  static bool active();

 private:
  bool saved_;
};

// Stop rules; zero means "not set". At least one of seconds / passes / target_error is needed.
struct StopRule {
  double seconds = 0;
  int64_t passes = 0;
  double target_error = 0;
};

// Calls iterate() until a rule fires or the sink cancels; reports after every pass. Rules
// compare the integrator's totals (Stats::passes, and Stats::seconds: render time inside
// iterate(), excluding the sink's work such as writing checkpoints), so a second call continues
// to a larger total.
void run_progressive(Integrator& integrator, const StopRule& stop, ProgressSink* sink);

// Whether a method that honours Holdout (Method::holdout) writes pass alpha, Combined's Alpha:
// with a transparent film, and on a scene that holds out whatever the film, as Cycles 3.4 gives
// held-out pixels alpha 0 with Film > Transparent off too (the world seen stays alpha 1; measured
// in Blender: tests/blender/test_cycles_panels.py). Method::passes_with declares the same.
inline bool writes_alpha(bool film_transparent, const Scene& scene) { return film_transparent || scene.has_holdout(); }

// Throws ParamError unless the image is at least 1x1 (parameters are checked by their
// declarations, methods.h, before an integrator is built).
void check_image_size(int width, int height);


}  // namespace gp
