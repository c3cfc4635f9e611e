#include "integrators/integrator.h"

#include "integrators/gradient/gdmlt.h"
#include "integrators/gradient/gpm.h"
#include "integrators/gradient/gpt.h"
#include "integrators/photon/msppm.h"
#include "integrators/path_tracer.h"
#include "integrators/photon/ppm.h"
#include "integrators/photon/sppm.h"
#include "integrators/spectral/sgpt.h"
#include "integrators/spectral/spectral_pt.h"

namespace gp {

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

std::vector<std::string> integrator_names() {
  return {"pt", "ppm", "sppm", "sppm-adaptive", "msppm", "gpt", "gpm", "gdmlt", "spt", "spt-hero", "sgpt"};
}

std::unique_ptr<Integrator> make_integrator(const std::string& method, const Scene& scene,
                                            const Params& params) {
  // Spectral mode (parameter `spectral`, CLI --spectral): `pt` turns into the hero-wavelength
  // spectral path tracer when the mode asks for it; in "auto" only dispersive scenes do, so a
  // scene without dispersion runs the RGB path tracer exactly as before.
  const SpectralMode mode = parse_spectral_mode(params.get<std::string>("spectral", "auto"));
  if (method == "pt") {
    if (use_spectral(mode, scene)) return std::make_unique<SpectralPathTracer>(scene, params, true);
    return std::make_unique<PathTracer>(scene, params);
  }
  if (method == "ppm") return std::make_unique<Ppm>(scene, params);
  if (method == "sppm") return std::make_unique<Sppm>(scene, params);
  // SPPM with photon_sampler defaulting to "adaptive" (thesis ch. 8), for scripts/convergence.py.
  if (method == "sppm-adaptive") return std::make_unique<Sppm>(scene, params, "adaptive");
  if (method == "msppm") return std::make_unique<Msppm>(scene, params);
  if (method == "gpt") return std::make_unique<GradientPathTracer>(scene, params);
  if (method == "gpm") return std::make_unique<Gpm>(scene, params);
  if (method == "gdmlt") return std::make_unique<GradientDomainMlt>(scene, params);
  if (method == "spt" || method == "spt-hero") {
    if (mode == SpectralMode::Rgb)
      throw ParamError("method '" + method + "' is spectral; spectral mode 'rgb' needs method 'pt'");
    return std::make_unique<SpectralPathTracer>(scene, params, method == "spt-hero");
  }
  if (method == "sgpt") {
    if (mode == SpectralMode::Rgb)
      throw ParamError("method 'sgpt' is spectral; spectral mode 'rgb' needs method 'pt'");
    return std::make_unique<SpectralGradientPathTracer>(scene, params);
  }
  std::string known;
  for (const auto& n : integrator_names()) known += (known.empty() ? "" : ", ") + n;
  throw ParamError("unknown method '" + method + "' (known: " + known + ")");
}

void check_common_params(int max_depth, int rr_depth, int threads, int tile_size, int width, int height) {
  if (max_depth < 1) throw ParamError("parameter 'max_depth' must be at least 1");
  if (rr_depth < 0) throw ParamError("parameter 'rr_depth' must be >= 0");
  if (threads < 0) throw ParamError("parameter 'threads' must be >= 0");
  if (tile_size < 1) throw ParamError("parameter 'tile_size' must be >= 1");
  if (width < 1 || height < 1) throw ParamError("image size must be at least 1x1");
}

}  // namespace gp
