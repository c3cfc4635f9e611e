// Develop step shared by the gradient-domain methods (gpt, gpm, gdmlt): reconstruct the
// gradient-domain part by screened Poisson (eq. 3), add the part kept out of the gradients
// (emission seen directly or through delta vertices, photons of specular chains: exact in the
// primal, huge and sparse in the gradients), and write combined, primal, gradient_x and
// gradient_y. The gradient passes include the kept-out part's own forward differences, so the
// written primal and gradients reconstruct to `combined` (exactly for L2, which is linear), unless
// `combined` takes a better estimate of the kept-out part (`kept_out_combined`: GPM's further
// camera paths for emission), which `primal` and the gradient passes leave out.
#pragma once

#include <array>
#include <string_view>
#include <vector>

#include "core/film.h"
#include "core/params.h"
#include "reconstruction/poisson.h"

namespace gp {

// The method's reconstruction from its parameters "recon" and "lambda", `params` bound to its
// declarations (the defaults: l2 for gpt, l1 for gpm and gdmlt; lambda 0.2; methods.cpp). The
// integrators and `gradphoton merge` (which reconstructs merged runs as they would) read it here.
ReconOptions gradient_recon_options(const Params& params, int threads);

// Writes combined, primal, gradient_x and gradient_y from `value(k)`, the four passes' values
// (in that order) of float k of width * height * 3.
template <class Value>
void write_gradient_passes(Film& film, size_t floats, const Value& value) {
  Pass& comb = film.add_pass(pass::kCombined, 3);
  Pass& prim = film.add_pass(pass::kPrimal, 3);
  Pass& px = film.add_pass(pass::kGradientX, 3);
  Pass& py = film.add_pass(pass::kGradientY, 3);
  for (size_t k = 0; k < floats; ++k) {
    const auto [c, p, x, y] = value(k);
    comb.data[k] = static_cast<float>(c);
    prim.data[k] = static_cast<float>(p);
    px.data[k] = static_cast<float>(x);
    py.data[k] = static_cast<float>(y);
  }
}

// All arrays are width * height * 3, row-major, row 0 at the top.
void develop_gradient_passes(Film& film, const std::vector<double>& primal, const std::vector<double>& gx,
                             const std::vector<double>& gy, const std::vector<double>& kept_out, int width,
                             int height, const ReconOptions& recon,
                             const std::vector<double>* kept_out_combined = nullptr);

}  // namespace gp
