// Progressive error estimation for photon density estimation (thesis ch. 6): per
// measurement point (here: per pixel), a bias estimate from the progressive estimate of the
// radiance Laplacian with a smooth kernel (§6.4), a variance from bias-corrected per-pass
// samples (eq. 6.22), the confidence interval of eq. 6.10 and the relative bound of
// eq. 6.13; their average over the image (eq. 6.33) drives render-until-error.
//
// Kernel (eq. 6.34) K(t) = 1 - 6t^5 + 15t^4 - 10t^3 on t = |x - x_p| / R in [0, 1]; on a
// surface (2D) its Laplacian is (K''(t) + K'(t) / t) / R^2 (eq. 6.38 summed over the two
// tangent axes). Normalisation k1 = 2 pi / 7 (appendix 6.8.1).
//
// Bias. Silverman's expansion (eq. 6.17) for a radially symmetric kernel of per-axis second
// moment mu2 is B = 1/2 mu2 R^2 Lap L. The radiance the image shows uses the disc kernel of
// eq. 5.13, whose mu2 is 1/4, so B' = R^2 Lap L / 8 (eq. 6.20 with this constant; the
// thesis' k2 = 10 pi / 168 is the unnormalised radial moment of the smooth kernel). The
// Laplacian itself comes from the smooth kernel, as §6.4 requires.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace gp {

namespace error_kernel {
inline constexpr double kK1 = 2.0 * 3.14159265358979323846 / 7.0;  // integral of K over the unit disk
// Disc-kernel bias constant: B' = kBiasDisc * R^2 * Lap L.
inline constexpr double kBiasDisc = 1.0 / 8.0;
// error_bound = calibrated: B' counts where it is significant, a two-sided test at this false-alarm
// rate (see ProgressivePhotonMapping::error_terms and bias_significance_cut).
inline constexpr double kBiasFalseAlarm = 0.05;
inline double K(double t) { return t >= 1 ? 0.0 : 1 - t * t * t * (10 - 15 * t + 6 * t * t); }  // eq. 6.34
inline double dK(double t) { return t >= 1 ? 0.0 : -30 * t * t * (t - 1) * (t - 1); }
inline double d2K(double t) { return t >= 1 ? 0.0 : -60 * t * (2 * t * t - 3 * t + 1); }
// 2D Laplacian of K(|x - x_p| / R) with respect to x, from the squared distance.
inline double laplacian(double d2, double R) {
  const double t = std::sqrt(d2) / R;
  if (t >= 1) return 0.0;
  const double dk_over_t = -30 * t * (t - 1) * (t - 1);  // K'(t) / t, finite at t = 0
  return (d2K(t) + dk_over_t) / (R * R);
}
}  // namespace error_kernel

// Quantile of Student's t distribution with `dof` degrees of freedom at probability p
// (Cornish-Fisher expansion about the normal quantile; exact for 1 and 2 dof).
double student_t_quantile(double dof, double p);
double normal_quantile(double p);

// Cut-off of the test "B' is not 0": |B'| / sd(B') above it in a share kBiasFalseAlarm of the
// pixels of a bias-free scene. sd(B') comes from the n per-pass Laplacians, a sample sd with
// n - 1 degrees of freedom, so the ratio is Student's t with n - 1 dof and the cut-off its
// two-sided quantile (12.7 at 2 passes, 2.57 at 6, 1.96 in the limit). A fixed normal cut of 2
// passed 10 % of a bias-free scene's pixels at 6 passes (12 % measured on cornell-box), and a
// false B' enters the estimated error as a bias that is not there (docs/error-calibration.md).
// INFINITY below 2 passes: B' is never significant from one Laplacian.
inline double bias_significance_cut(uint32_t n_laplacians) {
  return n_laplacians < 2 ? INFINITY : student_t_quantile(n_laplacians - 1.0, 1 - error_kernel::kBiasFalseAlarm / 2);
}

// ---- Boundary bias (first order) ----
// Where the query disc reaches past its surface's edge, into a wall or under a box, photons land
// on part of it only, and the disc estimate (flux / pi R^2) is low by the missing share; where
// the radiance changes across the disc, the part that is left is off-centre and its mean is not
// L at the centre. Both are first order in R, which the Laplacian term (eq. 6.17: second order,
// for a whole disc) does not describe. The local linear fit over the part that receives photons
// (the boundary correction of kernel estimation) removes both: with L(x) = L + g . (x - p) there,
// own = a L + c . g and m = c L + S g, where a, c, S are that part's area, first and second
// moments about p over pi R^2, own the radiance the disc estimate gives from this surface's
// photons and m its first moment (photon flux times offset, over pi R^2 N_e). Solved for L.
struct DiscShape {
  double a = 1;                  // share of the disc that receives photons
  double cu = 0, cv = 0;         // its first moment about the centre / pi R^2 (tangent axes)
  double suu = 0, suv = 0, svv = 0;  // its second moments / pi R^2; a whole disc: R^2 / 4, 0, R^2 / 4
  static DiscShape whole(double R) { return {1, 0, 0, R * R / 4, 0, R * R / 4}; }
};
// L at the centre from this surface's photons (radiance `own`, first moment mu, mv) over the
// part `d` of the disc: `own` itself for a whole disc. Falls back to own / a where the part is
// too thin to fit a gradient on (the system's determinant, relative to a whole disc's, below 1 %),
// and returns own where nothing of the disc receives photons.
double local_linear_radiance(const DiscShape& d, double own, double mu, double mv);

// A measurement point's boundary data summed over the passes, offsets in units of each pass's
// radius (whole disc: S = I / 4), and the bias of its progressive estimate from one local linear
// fit of the sums. A fit per pass was biased: with 8 probes a pass sees the missing part as a
// point or two, and the fit, not linear in the shape, extrapolated from that (-0.34 L against
// -0.09 L on a plane cut by its edge, scratch measurement); the sums' shape is the mean shape.
struct BoundarySums {
  DiscShape shape{0, 0, 0, 0, 0, 0};
  double x[4] = {0, 0, 0, 0};  // sums of own, foreign, mu / R, mv / R (radiance units)
  double xx[10] = {};          // sums of their products (upper triangle), for the bias' standard error
  uint32_t n = 0;
  void add(const DiscShape& unit_shape, double own, double foreign, double mu, double mv);
  // Bias of the mean of the n passes' estimates (own + foreign) against the fit's L and its
  // standard error; and what the bias-corrected mean's variance differs by from the uncorrected
  // one's (both variances of the mean): the bias comes from the same photons as the estimate, so
  // the corrected estimate is the fit itself, not the estimate plus an independent noise. All 0
  // where every disc was whole and no other surface's photon came.
  struct Bias {
    double bias = 0, sd = 0, variance_change = 0;
  };
  Bias bias() const;
};

// Running per-measurement-point statistics for eq. 6.22 (bias-corrected samples x_j).
struct ErrorStats {
  double sum = 0, sum2 = 0;
  uint32_t n = 0;
  void add(double x) { sum += x; sum2 += x * x; ++n; }
  // Sample variance V_i (eq. 6.22); 0 with fewer than two samples.
  double variance() const {
    if (n < 2) return 0.0;
    return std::max(0.0, (sum2 - sum * sum / n) / (n - 1));
  }
};

// One measurement point's per-pass estimates y_j = L_p,j and query radii r_j = R_j^2, kept as
// sums so that the bias-corrected samples x_j = y_j - B'_j of eq. 6.22, with B'_j = slope r_j
// (slope = kBiasDisc Lap L), can be taken with the latest Laplacian for every pass. The thesis
// takes B'_j from the Laplacian of pass j, which for the first passes is mostly noise (about
// twice the image's own): that noise entered V_i and widened the interval (error_bound =
// calibrated; docs/error-calibration.md).
struct PassSamples {
  double y = 0, yy = 0, r = 0, rr = 0, yr = 0;
  uint32_t n = 0;
  void add(double yj, double rj) {
    y += yj; yy += yj * yj; r += rj; rr += rj * rj; yr += yj * rj; ++n;
  }
  // Mean of x_j = y_j - slope r_j.
  double mean(double slope) const { return n > 0 ? (y - slope * r) / n : 0.0; }
  // Sample variance of the x_j (eq. 6.22); 0 with fewer than two samples.
  double variance(double slope) const {
    if (n < 2) return 0.0;
    const double sum = y - slope * r, sum2 = yy - 2 * slope * yr + slope * slope * rr;
    return std::max(0.0, (sum2 - sum * sum / n) / (n - 1));
  }
};

// Half-width E_i of the interval of eq. 6.10: t(i, 1 - beta/2) sqrt(V_i / i), with the
// t-quantile computed once per pass by the caller.
inline double interval_half_width(double t_quantile, const ErrorStats& s) {
  return s.n < 2 ? INFINITY : t_quantile * std::sqrt(s.variance() / s.n);
}

// Quantile q(m) of |m + Z|, Z standard normal: P(|m + Z| <= q) = c. The bound of an error
// that is a known shift m plus unit normal noise at exactly the confidence c, where eq. 6.12's
// E + |B| (q = m + z_{(1+c)/2}) over-covers: for m = 0 it is z_{(1+c)/2}, for large m it tends
// to m + z_c (one tail). Tabulated at construction (bisection on a grid of m), interpolated.
class FoldedNormalQuantile {
 public:
  explicit FoldedNormalQuantile(double confidence = 0.5);
  double operator()(double m) const;

 private:
  static constexpr double kStep = 1.0 / 16, kMax = 12;
  double one_tail_;            // z_c, for m beyond the table
  std::vector<double> table_;  // q at m = k * kStep
};

// Estimated E|m + sigma Z|, Z standard normal, from a sample sd s with `dof` degrees of freedom:
// the folded normal's mean with s / c4 for sigma (unbiased for sigma). What --target-error
// compares with E: a mean of |e| like the error it is measured by (a 50 % bound is the median
// of |e|, 1 / 1.19 of the mean for a normal error). Not the t quantile's correction: that one
// makes a bound cover at its confidence over the sd's noise; the mean of |e| needs sigma
// itself (E|T_5| / E|Z| = 1.19 against 1 / c4 = 1.05 at 6 passes; with it the stop came 20-30 %
// late at 5-8 passes, achieved 0.7-0.8 E). INFINITY below one degree of freedom or for an infinite s.
double folded_normal_mean(double m, double s, double dof);

// Relative stochastic bound of eq. 6.13: (E_i + |B'_i|) / L_i (infinite when L_i <= 0).
inline double relative_bound(double half_width, double bias, double radiance) {
  return radiance > 0 ? (half_width + std::abs(bias)) / radiance : INFINITY;
}

}  // namespace gp
