// Screened Poisson reconstruction, L2 by DCT and L1 by IRLS + PCG (see poisson.h).
#include "reconstruction/poisson.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>
#include <stdexcept>

#include "core/parallel.h"

namespace gp {

namespace {

// Row loops go to the thread pool only for images large enough to pay for it (an arena per
// call costs tens of microseconds, and PCG makes several calls per iteration).
void for_rows(int w, int h, int threads, const std::function<void(size_t, size_t)>& fn) {
  if (static_cast<size_t>(w) * h < (1u << 15)) fn(0, h);
  else parallel_for(h, threads, fn);
}

// FFTW's planner is not thread-safe (executing distinct plans concurrently is).
std::mutex g_fftw_planner;

struct FftwBuffer {
  double* data;
  explicit FftwBuffer(size_t n) : data(static_cast<double*>(fftw_malloc(sizeof(double) * n))) {
    if (!data) throw std::bad_alloc();
  }
  ~FftwBuffer() { fftw_free(data); }
  FftwBuffer(const FftwBuffer&) = delete;
  FftwBuffer& operator=(const FftwBuffer&) = delete;
};

// One channel, planar. The screened Poisson operator's right-hand side
//   b = lambda^2 I_0 + D_x^T G_x + D_y^T G_y
// with (D^T g)[i] = g[i-1] - g[i] restricted to the differences that exist.
void l2_rhs(const double* primal, const double* gx, const double* gy, int w, int h, double lambda2, double* b) {
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      double v = lambda2 * primal[i];
      if (x > 0) v += gx[i - 1];
      if (x < w - 1) v -= gx[i];
      if (y > 0) v += gy[i - w];
      if (y < h - 1) v -= gy[i];
      b[i] = v;
    }
}

// Exact L2 solve of one planar channel: the DCT-II diagonalises D^T D of a path graph with
// eigenvalues 2 - 2 cos(pi k / N) (BCCZ08), so (lambda^2 + L_x + L_y) is a division per
// coefficient. FFTW's REDFT10 / REDFT01 pair scales by 2N per dimension.
void solve_l2_channel(const double* primal, const double* gx, const double* gy, int w, int h, double lambda,
                      double* out) {
  const size_t n = static_cast<size_t>(w) * h;
  FftwBuffer buf(n);
  fftw_plan fwd, inv;
  {
    std::lock_guard<std::mutex> lock(g_fftw_planner);
    fwd = fftw_plan_r2r_2d(h, w, buf.data, buf.data, FFTW_REDFT10, FFTW_REDFT10, FFTW_ESTIMATE);
    inv = fftw_plan_r2r_2d(h, w, buf.data, buf.data, FFTW_REDFT01, FFTW_REDFT01, FFTW_ESTIMATE);
  }
  l2_rhs(primal, gx, gy, w, h, lambda * lambda, buf.data);
  fftw_execute(fwd);
  std::vector<double> ex(w), ey(h);
  for (int k = 0; k < w; ++k) ex[k] = 2.0 - 2.0 * std::cos(M_PI * k / w);
  for (int k = 0; k < h; ++k) ey[k] = 2.0 - 2.0 * std::cos(M_PI * k / h);
  const double norm = 1.0 / (4.0 * w * h);
  const double lambda2 = lambda * lambda;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) buf.data[static_cast<size_t>(y) * w + x] *= norm / (lambda2 + ex[x] + ey[y]);
  fftw_execute(inv);
  std::copy(buf.data, buf.data + n, out);
  std::lock_guard<std::mutex> lock(g_fftw_planner);
  fftw_destroy_plan(fwd);
  fftw_destroy_plan(inv);
}

// ---- L1 by IRLS ----

// Weighted normal equations of one channel:
//   A = diag(lambda wp) + D_x^T W_x D_x + D_y^T W_y D_y,  b = lambda wp I_0 + D_x^T W_x G_x + D_y^T W_y G_y.
struct WeightedSystem {
  int w, h, threads;
  double lambda;
  std::vector<double> wp, wx, wy;  // per pixel; wx / wy of border differences are 0

  // y = A v; with `dots`, also the per-row sums of v.y.
  void apply(const std::vector<double>& v, std::vector<double>& y, std::vector<double>* dots = nullptr) const {
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r) {
        const bool top = r == 0, bottom = static_cast<int>(r) == h - 1;
        double dot = 0;
        for (int x = 0; x < w; ++x) {
          const size_t i = r * w + x;
          const double vi = v[i];
          double s = lambda * wp[i] * vi;
          if (x > 0) s += wx[i - 1] * (vi - v[i - 1]);
          if (x < w - 1) s -= wx[i] * (v[i + 1] - vi);
          if (!top) s += wy[i - w] * (vi - v[i - w]);
          if (!bottom) s -= wy[i] * (v[i + w] - vi);
          y[i] = s;
          dot += vi * s;
        }
        if (dots) (*dots)[r] = dot;
      }
    });
  }
  double diagonal(size_t i) const {
    const int x = static_cast<int>(i % w), r = static_cast<int>(i / w);
    double d = lambda * wp[i];
    if (x > 0) d += wx[i - 1];
    if (x < w - 1) d += wx[i];
    if (r > 0) d += wy[i - w];
    if (r < h - 1) d += wy[i];
    return d;
  }
};

// Sums of per-row partial results taken serially, so that the result (and the image) does
// not depend on the thread count.
double sum_rows(const std::vector<double>& row_sums) {
  double s = 0;
  for (double v : row_sums) s += v;
  return s;
}

// Jacobi-preconditioned conjugate gradients, warm-started from `x`, until |r| <= rel_tol |b|
// or `iterations`; returns the iterations taken. Loops are fused so that each iteration reads
// the vectors three times (q = A p with p.q; the x, r, z update with r.z and r.r; the p update).
int pcg(const WeightedSystem& A, const std::vector<double>& b, std::vector<double>& x, int iterations,
        double rel_tol) {
  const size_t n = x.size();
  const int w = A.w, h = A.h, threads = A.threads;
  std::vector<double> r(n), z(n), p(n), q(n), inv_diag(n), rows_a(h), rows_b(h);
  A.apply(x, q);
  for_rows(w, h, threads, [&](size_t r0, size_t r1) {
    for (size_t row = r0; row < r1; ++row) {
      double rz = 0, bb = 0;
      for (size_t i = row * w; i < (row + 1) * w; ++i) {
        r[i] = b[i] - q[i];
        const double d = A.diagonal(i);
        inv_diag[i] = d > 0 ? 1.0 / d : 0.0;
        z[i] = inv_diag[i] * r[i];
        p[i] = z[i];
        rz += r[i] * z[i];
        bb += b[i] * b[i];
      }
      rows_a[row] = rz;
      rows_b[row] = bb;
    }
  });
  double rz = sum_rows(rows_a);
  const double b_norm2 = sum_rows(rows_b);
  const double stop2 = std::max(rel_tol * rel_tol, 1e-28) * b_norm2;
  int it = 0;
  while (it < iterations && rz > 0) {
    ++it;
    A.apply(p, q, &rows_a);  // q = A p, rows_a = per-row p.q
    const double pq = sum_rows(rows_a);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t row = r0; row < r1; ++row) {
        double rz_row = 0, rr_row = 0;
        for (size_t i = row * w; i < (row + 1) * w; ++i) {
          x[i] += alpha * p[i];
          r[i] -= alpha * q[i];
          z[i] = inv_diag[i] * r[i];
          rz_row += r[i] * z[i];
          rr_row += r[i] * r[i];
        }
        rows_a[row] = rz_row;
        rows_b[row] = rr_row;
      }
    });
    const double rz_new = sum_rows(rows_a);
    if (sum_rows(rows_b) <= stop2) break;  // converged
    const double beta = rz_new / rz;
    rz = rz_new;
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t i = r0 * w; i < r1 * w; ++i) p[i] = z[i] + beta * p[i];
    });
  }
  return it;
}

void solve_l1_channel(const double* primal, const double* gx, const double* gy, int w, int h,
                      const ReconOptions& o, double* out, ReconReport& report) {
  const size_t n = static_cast<size_t>(w) * h;
  std::vector<double> x(n);
  solve_l2_channel(primal, gx, gy, w, h, o.lambda, x.data());  // warm start
  double mean_abs = 0;
  for (size_t i = 0; i < n; ++i) mean_abs += std::abs(primal[i]);
  mean_abs /= static_cast<double>(n);
  const double eps = std::max(o.epsilon * mean_abs, 1e-12);
  WeightedSystem A{w, h, o.threads, o.lambda, std::vector<double>(n), std::vector<double>(n, 0.0),
                   std::vector<double>(n, 0.0)};
  std::vector<double> b(n), x_prev(n), rows_d(h), rows_x(h);
  bool converged = false;
  double change = 0;
  for (int round = 0; round < o.max_irls_iterations && !converged; ++round) {
    // IRLS weights 1 / max(|r|, eps) of the current residuals (LKL*13).
    for_rows(w, h, o.threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r)
        for (int c = 0; c < w; ++c) {
          const size_t i = r * w + c;
          A.wp[i] = 1.0 / std::max(std::abs(x[i] - primal[i]), eps);
          if (c < w - 1) A.wx[i] = 1.0 / std::max(std::abs(x[i + 1] - x[i] - gx[i]), eps);
          if (static_cast<int>(r) < h - 1) A.wy[i] = 1.0 / std::max(std::abs(x[i + w] - x[i] - gy[i]), eps);
        }
    });
    for (int y = 0; y < h; ++y)
      for (int c = 0; c < w; ++c) {
        const size_t i = static_cast<size_t>(y) * w + c;
        double v = o.lambda * A.wp[i] * primal[i];
        if (c > 0) v += A.wx[i - 1] * gx[i - 1];
        if (c < w - 1) v -= A.wx[i] * gx[i];
        if (y > 0) v += A.wy[i - w] * gy[i - w];
        if (y < h - 1) v -= A.wy[i] * gy[i];
        b[i] = v;
      }
    x_prev = x;
    report.cg_iterations += pcg(A, b, x, o.max_cg_iterations, 0.1 * o.tolerance);
    ++report.irls_iterations;
    for_rows(w, h, o.threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r) {
        double dd = 0, xx = 0;
        for (size_t i = r * w; i < (r + 1) * w; ++i) {
          dd += (x[i] - x_prev[i]) * (x[i] - x_prev[i]);
          xx += x[i] * x[i];
        }
        rows_d[r] = dd;
        rows_x[r] = xx;
      }
    });
    const double xx = sum_rows(rows_x);
    change = xx > 0 ? std::sqrt(sum_rows(rows_d) / xx) : 0.0;
    converged = change <= o.tolerance;
  }
  report.last_change = std::max(report.last_change, change);
  report.converged = report.converged && (converged || o.max_irls_iterations == 0);
  std::copy(x.begin(), x.end(), out);
}

}  // namespace

ReconNorm parse_recon_norm(const std::string& name) {
  if (name == "l2" || name == "L2") return ReconNorm::L2;
  if (name == "l1" || name == "L1") return ReconNorm::L1;
  throw std::invalid_argument("reconstruction must be 'l1' or 'l2', got '" + name + "'");
}

void forward_differences(const std::vector<double>& img, int w, int h, int c, std::vector<double>* gx,
                         std::vector<double>* gy) {
  gx->assign(img.size(), 0.0);
  gy->assign(img.size(), 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) {
        const size_t i = (static_cast<size_t>(y) * w + x) * c + k;
        if (x < w - 1) (*gx)[i] = img[i + c] - img[i];
        if (y < h - 1) (*gy)[i] = img[i + static_cast<size_t>(w) * c] - img[i];
      }
}

std::vector<double> screened_poisson(const std::vector<double>& primal, const std::vector<double>& gx,
                                     const std::vector<double>& gy, int w, int h, int c, const ReconOptions& o,
                                     ReconReport* report) {
  if (w < 1 || h < 1 || c < 1) throw std::invalid_argument("screened_poisson: empty image");
  const size_t n = static_cast<size_t>(w) * h;
  if (primal.size() != n * c || gx.size() != n * c || gy.size() != n * c)
    throw std::invalid_argument("screened_poisson: primal and gradients must all hold width*height*channels values");
  if (!(o.lambda > 0) || !std::isfinite(o.lambda)) throw std::invalid_argument("screened_poisson: lambda must be > 0");
  if (o.norm == ReconNorm::L1 &&
      (o.max_irls_iterations < 0 || o.max_cg_iterations < 0 || !(o.epsilon > 0) || !(o.tolerance > 0)))
    throw std::invalid_argument("screened_poisson: bad IRLS settings");
  // De-interleave into planar channels.
  std::vector<std::vector<double>> P(c, std::vector<double>(n)), X(c, std::vector<double>(n)),
      Y(c, std::vector<double>(n)), out(c, std::vector<double>(n));
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < c; ++k) {
      P[k][i] = primal[i * c + k];
      X[k][i] = gx[i * c + k];
      Y[k][i] = gy[i * c + k];
    }
  if (o.norm == ReconNorm::L2) {
    parallel_for(c, o.threads, [&](size_t k0, size_t k1) {
      for (size_t k = k0; k < k1; ++k)
        solve_l2_channel(P[k].data(), X[k].data(), Y[k].data(), w, h, o.lambda, out[k].data());
    });
  } else {
    ReconReport rep;
    for (int k = 0; k < c; ++k)  // each channel parallel over rows inside
      solve_l1_channel(P[k].data(), X[k].data(), Y[k].data(), w, h, o, out[k].data(), rep);
    if (report) *report = rep;
  }
  std::vector<double> result(n * c);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < c; ++k) result[i * c + k] = out[k][i];
  return result;
}

std::vector<float> screened_poisson(const std::vector<float>& primal, const std::vector<float>& gx,
                                    const std::vector<float>& gy, int w, int h, int c, const ReconOptions& o,
                                    ReconReport* report) {
  const std::vector<double> r = screened_poisson(std::vector<double>(primal.begin(), primal.end()),
                                                 std::vector<double>(gx.begin(), gx.end()),
                                                 std::vector<double>(gy.begin(), gy.end()), w, h, c, o, report);
  return std::vector<float>(r.begin(), r.end());
}

}  // namespace gp
