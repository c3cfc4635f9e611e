#include "reconstruction/spectral_poisson.h"

#include <Eigen/Dense>

#include <stdexcept>

namespace gp {

SpectralPoisson::SpectralPoisson(int bins, int stride, double alpha)
    : bins_(bins), stride_(stride), alpha_(alpha) {
  if (bins < 2) throw std::invalid_argument("spectral Poisson needs at least 2 bins");
  if (stride < 1 || stride >= bins) throw std::invalid_argument("spectral Poisson stride must be in 1..bins-1");
  if (!(alpha > 0)) throw std::invalid_argument("spectral Poisson alpha must be > 0");
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(bins, bins);
  for (int j = 0; j < bins; ++j) {
    D(j, j) -= 1.0;
    D(j, (j + stride) % bins) += 1.0;
  }
  const Eigen::MatrixXd A = alpha * Eigen::MatrixXd::Identity(bins, bins) + D.transpose() * D;  // eq. 14
  const Eigen::MatrixXd inv = A.ldlt().solve(Eigen::MatrixXd::Identity(bins, bins));
  // Fold D^T into the operator: I' = inv (alpha I + D^T G).
  inverse_.resize(static_cast<size_t>(bins) * bins * 2);
  const Eigen::MatrixXd invDt = inv * D.transpose();
  for (int r = 0; r < bins; ++r)
    for (int c = 0; c < bins; ++c) {
      inverse_[r * bins + c] = alpha * inv(r, c);
      inverse_[bins * bins + r * bins + c] = invDt(r, c);
    }
}

std::vector<double> SpectralPoisson::solve(const std::vector<double>& primal,
                                           const std::vector<double>& gradient) const {
  std::vector<double> out(bins_, 0.0);
  const size_t off = static_cast<size_t>(bins_) * bins_;
  for (int r = 0; r < bins_; ++r) {
    double s = 0;
    for (int c = 0; c < bins_; ++c) s += inverse_[r * bins_ + c] * primal[c] + inverse_[off + r * bins_ + c] * gradient[c];
    out[r] = s;
  }
  return out;
}

}  // namespace gp
