// Screened Poisson reconstruction of an image from a primal estimate and its forward-difference
// gradients (gradient-domain photon density estimation, eq. 3; KMA15 §3.3; GD-MLT slides):
//
//   I = argmin ||D_x I - G_x||_p + ||D_y I - G_y||_p + lambda ||I - I_0||_p ,  p = 1 or 2.
//
// Conventions:
//   - Images are width x height, row-major, row 0 at the top, `channels` values interleaved per
//     pixel (the Film pass layout). Each channel is reconstructed on its own.
//   - G_x(x, y) = I(x+1, y) - I(x, y) and G_y(x, y) = I(x, y+1) - I(x, y) (y grows downwards).
//     Gradients that would cross the image border (last column of G_x, last row of G_y) do not
//     exist: their values are ignored, which gives the Neumann boundary of the discrete problem.
//   - L2, as KMA15 writes it, weights the primal residual inside the norm:
//       min |D_x I - G_x|^2 + |D_y I - G_y|^2 + lambda^2 |I - I_0|^2,
//     i.e. (lambda^2 + D_x^T D_x + D_y^T D_y) I = lambda^2 I_0 + D_x^T G_x + D_y^T G_y.
//     With forward differences and Neumann borders the operator is diagonalised by the 2D
//     DCT-II (Bhat et al. 2008, the [BCCZ08] of the paper), so the L2 solve is exact: two
//     FFTW REDFT transforms and a division per channel.
//   - L1 (sum |r| of the same residuals, the primal one scaled by lambda) by iteratively
//     re-weighted least squares (LKL*13): each iteration solves the weighted L2 system with
//     weights 1 / max(|r|, eps) by conjugate gradients preconditioned with one multigrid V-cycle
//     (2 x 2 aggregation, Galerkin coarse levels, red-black Gauss-Seidel; poisson.cpp),
//     warm-started from the previous iterate (the first from the exact L2 solution).
//     eps = epsilon * mean |I_0| of the channel, so the weights do not depend on the image's
//     brightness. The function these weights minimise (IRLS majorises it) is Huber's of every
//     residual: |r| beyond eps, r^2 / (2 eps) + eps / 2 within ("the objective" below).
//     Convergence: each round's PCG stops once its residual falls to 0.3 of the round's start
//     (early rounds need not be solved exactly: their weights are about to change; a partial
//     round still lowers the objective). IRLS stops when the objective's distance to its
//     minimum, estimated from the rate at which the rounds lower it (poisson.cpp), falls under
//     `tolerance` of the objective. The caps only guard against a stall; ReconReport says
//     whether the tolerance was met.
#pragma once

#include <string>
#include <vector>

namespace gp {

enum class ReconNorm { L2, L1 };

// "l2" / "l1" (anything else throws std::invalid_argument naming the value).
ReconNorm parse_recon_norm(const std::string& name);

struct ReconOptions {
  ReconNorm norm = ReconNorm::L2;
  double lambda = 0.2;        // weight of the primal term (KMA15's alpha)
  double tolerance = 1e-4;    // L1 only: estimated relative distance of the objective to its minimum at which it stops
  int max_irls_iterations = 100;  // L1 only: cap on re-weighting rounds
  int max_cg_iterations = 1000;   // L1 only: cap on PCG iterations per round
  double epsilon = 1e-2;      // L1 only: weight floor, relative to the channel's mean |I_0|
  int threads = 0;            // 0 = all cores
};

// What an L1 solve did, summed (iterations, objectives) or worst (estimate) over channels.
struct ReconReport {
  int irls_iterations = 0;    // re-weighting rounds
  int cg_iterations = 0;      // PCG iterations over all rounds
  double estimated_excess = 0;  // the stop's estimate of (objective - its minimum) / objective
  double objective = 0;       // L1: the minimised objective at the result, summed over channels
  double objective_l1 = 0;    // L1: the plain sum of |r| (the same weights) at the result
  bool converged = true;      // every channel met `tolerance` within the caps
};

// Reconstructs every channel. All three inputs hold width * height * channels values.
// Throws std::invalid_argument on bad sizes or lambda <= 0 (the problem needs the primal term
// to fix the constant; with lambda -> 0 the L2 solution tends to the mean-preserving one).
std::vector<double> screened_poisson(const std::vector<double>& primal, const std::vector<double>& gx,
                                     const std::vector<double>& gy, int width, int height, int channels,
                                     const ReconOptions& options = {}, ReconReport* report = nullptr);
std::vector<float> screened_poisson(const std::vector<float>& primal, const std::vector<float>& gx,
                                    const std::vector<float>& gy, int width, int height, int channels,
                                    const ReconOptions& options = {}, ReconReport* report = nullptr);

// Forward differences of an image in the convention above (border entries are 0); for tests,
// the benchmark and the CLI.
void forward_differences(const std::vector<double>& image, int width, int height, int channels,
                         std::vector<double>* gx, std::vector<double>* gy);

}  // namespace gp
