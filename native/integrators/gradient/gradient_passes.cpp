#include "integrators/gradient/gradient_passes.h"

#include "integrators/integrator.h"

namespace gp {

// The defaults (methods.cpp): L1 for gpm and gdmlt, lower relMSE than L2 at equal time on every
// scene measured (docs/gradient.md); gpt keeps L2, KMA15's unbiased choice.
ReconOptions gradient_recon_options(const Params& params, int threads) {
  ReconOptions o;
  o.norm = parse_recon_norm(params.get<std::string>("recon"));  // "l1" or "l2": checked by the declaration
  o.lambda = params.get<double>("lambda");
  o.threads = threads;
  return o;
}

void develop_gradient_passes(Film& film, const std::vector<double>& primal, const std::vector<double>& gx,
                             const std::vector<double>& gy, const std::vector<double>& kept_out, int width,
                             int height, const ReconOptions& recon, const std::vector<double>* kept_out_combined) {
  const std::vector<double>& kept_comb = kept_out_combined ? *kept_out_combined : kept_out;
  ReconOptions r = recon;
  if (DisplayDevelop::active()) r.norm = ReconNorm::L2;  // an image for display only (integrator.h)
  const std::vector<double> rec = screened_poisson(primal, gx, gy, width, height, 3, r);  // eq. 3
  std::vector<double> dx, dy;
  forward_differences(kept_out, width, height, 3, &dx, &dy);
  write_gradient_passes(film, primal.size(), [&](size_t k) {
    return std::array<double, 4>{rec[k] + kept_comb[k], primal[k] + kept_out[k], gx[k] + dx[k], gy[k] + dy[k]};
  });
}

}  // namespace gp
