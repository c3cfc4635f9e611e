// 1D screened Poisson reconstruction of a pixel's discretised spectrum (spectral gradient
// sampling §3.2, eq. 14): argmin_I' |D I' - G|^2 + alpha |I' - I|^2, where (D I)_j =
// I_{(j+k) mod B} - I_j is the cyclic finite difference over k bins (the shift delta). The
// system (alpha Id + D^T D) I' = alpha I + D^T G is the same for every pixel: it is factorised
// once (B is ~15, so a dense inverse is cheaper and simpler than the paper's 1D FFT solve) and
// each pixel costs one B x B matrix-vector product. The L2 solution is linear in (I, G), so an
// unbiased (I, G) gives an unbiased reconstruction.
#pragma once

#include <vector>

namespace gp {

class SpectralPoisson {
 public:
  SpectralPoisson(int bins, int stride, double alpha);
  int bins() const { return bins_; }
  int stride() const { return stride_; }
  // primal[j]: estimate of bin j; gradient[j]: estimate of bin (j + stride) - bin j.
  std::vector<double> solve(const std::vector<double>& primal, const std::vector<double>& gradient) const;

 private:
  int bins_, stride_;
  double alpha_;
  std::vector<double> inverse_;  // (alpha Id + D^T D)^-1, row-major
};

}  // namespace gp
