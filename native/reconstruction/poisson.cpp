// Screened Poisson reconstruction, L2 by DCT and L1 by IRLS + PCG (see poisson.h).
#include "reconstruction/poisson.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <mutex>
#include <stdexcept>

#include <Eigen/Dense>

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

// Weighted normal equations of one channel, a graph Laplacian plus a diagonal:
//   A = diag(c) + D_x^T W_x D_x + D_y^T W_y D_y,  c = lambda wp,
//   b = lambda wp I_0 + D_x^T W_x G_x + D_y^T W_y G_y.
// wx[i] couples pixel i with i+1, wy[i] pixel i with i+w (0 across the border). The multigrid
// levels below are systems of the same form on coarser grids.
struct WeightedSystem {
  int w = 0, h = 0, threads = 0;
  std::vector<double> c, wx, wy;
  std::vector<double> diag;  // c + the weights of the pixel's edges

  void make_diagonal() {
    diag.resize(c.size());
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r)
        for (int x = 0; x < w; ++x) {
          const size_t i = r * w + x;
          double d = c[i] + wx[i] + wy[i];
          if (x > 0) d += wx[i - 1];
          if (r > 0) d += wy[i - w];
          diag[i] = d;
        }
    });
  }
  // Sum of the neighbours' values weighted by their edges (A v = diag v - neighbours(v)).
  double neighbours(const double* v, size_t i, int x, size_t r) const {
    double s = 0;
    if (x > 0) s += wx[i - 1] * v[i - 1];
    if (x < w - 1) s += wx[i] * v[i + 1];
    if (r > 0) s += wy[i - w] * v[i - w];
    if (static_cast<int>(r) < h - 1) s += wy[i] * v[i + w];
    return s;
  }
  // y = A v; with `dots`, also the per-row sums of v.y.
  void apply(const std::vector<double>& v, std::vector<double>& y, std::vector<double>* dots = nullptr) const {
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r) {
        double dot = 0;
        for (int x = 0; x < w; ++x) {
          const size_t i = r * w + x;
          y[i] = diag[i] * v[i] - neighbours(v.data(), i, x, r);
          dot += v[i] * y[i];
        }
        if (dots) (*dots)[r] = dot;
      }
    });
  }
};

// Sums of per-row partial results taken serially, so that the result (and the image) does
// not depend on the thread count.
double sum_rows(const std::vector<double>& row_sums) {
  double s = 0;
  for (double v : row_sums) s += v;
  return s;
}

// Multigrid V-cycle used as the PCG preconditioner. Jacobi alone needed thousands of PCG
// iterations per round on rendered images (29 s at 1920 x 1080): the IRLS weights of smooth,
// well-estimated regions are 1 / eps, those of the noisy primal small, so errors spread over
// tens of pixels and only a coarse-grid correction removes them cheaply.
//   - Coarsening: 2 x 2 aggregates, piecewise-constant prolongation P, Galerkin coarse operator
//     P^T A P. For A = diag(c) + sum_e w_e (e_i - e_j)(e_i - e_j)^T this is again a diagonal
//     plus a 4-neighbour graph Laplacian: c summed over the aggregate, the weights of the fine
//     edges between two aggregates summed, edges inside an aggregate dropped. So every level is
//     a WeightedSystem and the IRLS weights reach every level exactly.
//   - Smoothing: one red-black Gauss-Seidel sweep before the coarse correction (red, then black)
//     and its adjoint after (black, then red), so the V-cycle is a symmetric positive definite
//     operator as CG requires; each colour updates independent pixels, so the result does not
//     depend on the thread count.
//   - The coarse correction is not scaled: Vanek's over-correction of piecewise-constant
//     aggregates (x1.2, 1.5, 1.8) took 1.4-2.8x more PCG iterations on a rendered GPM buffer.
//   - Coarsest level (at most kCoarsest unknowns): exact dense Cholesky (Eigen).
class MultigridPreconditioner {
 public:
  static constexpr int kCoarsest = 64;

  // Allocates the levels for `fine`'s size; update() fills them from its current weights.
  explicit MultigridPreconditioner(const WeightedSystem& fine) : fine_(fine), fine_r_(fine.c.size()) {
    int w = fine.w, h = fine.h;
    while (static_cast<size_t>(w) * h > kCoarsest) {
      w = (w + 1) / 2;
      h = (h + 1) / 2;
      const size_t n = static_cast<size_t>(w) * h;
      Level& L = coarse_.emplace_back();
      L.A.w = w;
      L.A.h = h;
      L.A.threads = fine.threads;
      for (auto* v : {&L.A.c, &L.A.wx, &L.A.wy, &L.A.diag, &L.b, &L.x, &L.r}) v->resize(n);
    }
  }

  // Galerkin coarse operators of the fine system's current weights, and the coarsest's Cholesky.
  void update() {
    const WeightedSystem* cur = &fine_;
    for (Level& L : coarse_) {
      coarsen(*cur, L.A);
      cur = &L.A;
    }
    const int n = cur->w * cur->h;
    Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
    for (int r = 0; r < cur->h; ++r)
      for (int x = 0; x < cur->w; ++x) {
        const int i = r * cur->w + x;
        M(i, i) = cur->diag[i];
        if (x < cur->w - 1) M(i, i + 1) = M(i + 1, i) = -cur->wx[i];
        if (r < cur->h - 1) M(i, i + cur->w) = M(i + cur->w, i) = -cur->wy[i];
      }
    llt_.compute(M);
  }

  // z = M^{-1} r (one V-cycle from z = 0).
  void apply(const std::vector<double>& r, std::vector<double>& z) {
    vcycle(0, r, z);
  }

 private:
  struct Level {
    WeightedSystem A;
    std::vector<double> b, x, r;  // right-hand side, solution and residual on this level
  };

  static void coarsen(const WeightedSystem& f, WeightedSystem& c) {
    for_rows(c.w, c.h, c.threads, [&](size_t r0, size_t r1) {
      for (size_t R = r0; R < r1; ++R) {
        for (size_t I = R * c.w; I < (R + 1) * c.w; ++I) c.c[I] = c.wx[I] = c.wy[I] = 0.0;
        for (int fy = 2 * static_cast<int>(R); fy < std::min(2 * static_cast<int>(R) + 2, f.h); ++fy)
          for (int fx = 0; fx < f.w; ++fx) {
            const size_t i = static_cast<size_t>(fy) * f.w + fx;
            const size_t I = R * c.w + fx / 2;
            c.c[I] += f.c[i];
            if (fx % 2 == 1) c.wx[I] += f.wx[i];  // edge to the next aggregate (0 at the border)
            if (fy % 2 == 1) c.wy[I] += f.wy[i];
          }
      }
    });
    c.make_diagonal();
  }

  // One red-black Gauss-Seidel half-sweep over the pixels of colour `colour` ((x + y) % 2).
  static void smooth_colour(const WeightedSystem& A, const std::vector<double>& b, std::vector<double>& x,
                            int colour) {
    for_rows(A.w, A.h, A.threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r)
        for (int c = static_cast<int>((r + colour) % 2); c < A.w; c += 2) {
          const size_t i = r * A.w + c;
          x[i] = (b[i] + A.neighbours(x.data(), i, c, r)) / A.diag[i];
        }
    });
  }

  void vcycle(size_t level, const std::vector<double>& b, std::vector<double>& x) {
    if (level == coarse_.size()) {  // coarsest: exact
      Eigen::Map<const Eigen::VectorXd> bv(b.data(), static_cast<Eigen::Index>(b.size()));
      Eigen::Map<Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size())) = llt_.solve(bv);
      return;
    }
    const WeightedSystem& A = level == 0 ? fine_ : coarse_[level - 1].A;
    std::vector<double>& r = level == 0 ? fine_r_ : coarse_[level - 1].r;
    Level& C = coarse_[level];
    // Pre-smoothing from x = 0 (the red half-sweep then sees zero neighbours).
    std::fill(x.begin(), x.end(), 0.0);
    smooth_colour(A, b, x, 0);
    smooth_colour(A, b, x, 1);
    A.apply(x, r);
    // Restriction P^T (b - A x): sums over the aggregates.
    for_rows(C.A.w, C.A.h, C.A.threads, [&](size_t R0, size_t R1) {
      for (size_t R = R0; R < R1; ++R) {
        for (int X = 0; X < C.A.w; ++X) C.b[R * C.A.w + X] = 0.0;
        for (int fy = 2 * static_cast<int>(R); fy < std::min(2 * static_cast<int>(R) + 2, A.h); ++fy)
          for (int fx = 0; fx < A.w; ++fx) {
            const size_t i = static_cast<size_t>(fy) * A.w + fx;
            C.b[R * C.A.w + fx / 2] += b[i] - r[i];
          }
      }
    });
    vcycle(level + 1, C.b, C.x);
    // Prolongation x += P x_c.
    for_rows(A.w, A.h, A.threads, [&](size_t r0, size_t r1) {
      for (size_t fy = r0; fy < r1; ++fy)
        for (int fx = 0; fx < A.w; ++fx)
          x[fy * A.w + fx] += C.x[(fy / 2) * C.A.w + fx / 2];
    });
    // Post-smoothing: the adjoint of the pre-smoother.
    smooth_colour(A, b, x, 1);
    smooth_colour(A, b, x, 0);
  }

  const WeightedSystem& fine_;
  std::vector<double> fine_r_;
  std::deque<Level> coarse_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

// Multigrid-preconditioned conjugate gradients on one channel's weighted system, its work
// vectors and multigrid levels allocated once for all IRLS rounds.
class Pcg {
 public:
  explicit Pcg(const WeightedSystem& A)
      : A_(A), M_(A), r_(A.c.size()), z_(A.c.size()), p_(A.c.size()), q_(A.c.size()), rows_a_(A.h), rows_b_(A.h) {}

  // Warm-started from `x`, until |r| <= max(rel_tol |b|, shrink |r_0|) or `iterations`, for
  // A's current weights; returns the iterations taken.
  int solve(const std::vector<double>& b, std::vector<double>& x, int iterations, double rel_tol, double shrink);

 private:
  const WeightedSystem& A_;
  MultigridPreconditioner M_;
  std::vector<double> r_, z_, p_, q_, rows_a_, rows_b_;
};

int Pcg::solve(const std::vector<double>& b, std::vector<double>& x, int iterations, double rel_tol,
               double shrink) {
  const WeightedSystem& A = A_;
  const int w = A.w, h = A.h, threads = A.threads;
  std::vector<double>&r = r_, &z = z_, &p = p_, &q = q_, &rows_a = rows_a_, &rows_b = rows_b_;
  MultigridPreconditioner& M = M_;
  A.apply(x, q);
  for_rows(w, h, threads, [&](size_t r0, size_t r1) {
    for (size_t row = r0; row < r1; ++row) {
      double rr = 0, bb = 0;
      for (size_t i = row * w; i < (row + 1) * w; ++i) {
        r[i] = b[i] - q[i];
        rr += r[i] * r[i];
        bb += b[i] * b[i];
      }
      rows_a[row] = rr;
      rows_b[row] = bb;
    }
  });
  const double r0_norm2 = sum_rows(rows_a);
  const double b_norm2 = sum_rows(rows_b);
  const double stop2 = std::max({rel_tol * rel_tol * b_norm2, shrink * shrink * r0_norm2, 1e-28 * b_norm2});
  if (r0_norm2 <= stop2) return 0;
  M.update();
  M.apply(r, z);
  for_rows(w, h, threads, [&](size_t r0, size_t r1) {
    for (size_t row = r0; row < r1; ++row) {
      double rz = 0;
      for (size_t i = row * w; i < (row + 1) * w; ++i) {
        p[i] = z[i];
        rz += r[i] * z[i];
      }
      rows_a[row] = rz;
    }
  });
  double rz = sum_rows(rows_a);
  int it = 0;
  while (it < iterations && rz > 0) {
    ++it;
    A.apply(p, q, &rows_a);  // q = A p, rows_a = per-row p.q
    const double pq = sum_rows(rows_a);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t row = r0; row < r1; ++row) {
        double rr_row = 0;
        for (size_t i = row * w; i < (row + 1) * w; ++i) {
          x[i] += alpha * p[i];
          r[i] -= alpha * q[i];
          rr_row += r[i] * r[i];
        }
        rows_b[row] = rr_row;
      }
    });
    if (sum_rows(rows_b) <= stop2) break;  // converged
    M.apply(r, z);
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t row = r0; row < r1; ++row) {
        double rz_row = 0;
        for (size_t i = row * w; i < (row + 1) * w; ++i) rz_row += r[i] * z[i];
        rows_a[row] = rz_row;
      }
    });
    const double rz_new = sum_rows(rows_a);
    const double beta = rz_new / rz;
    rz = rz_new;
    for_rows(w, h, threads, [&](size_t r0, size_t r1) {
      for (size_t i = r0 * w; i < r1 * w; ++i) p[i] = z[i] + beta * p[i];
    });
  }
  return it;
}

// The objective IRLS with weights 1 / max(|r|, eps) minimises (it is the majorised function
// of those weights): Huber's function of every residual, |r| beyond eps and r^2 / (2 eps) +
// eps / 2 within, the primal's weighted by lambda (GPM paper eq. 3 with the L1 norm, smoothed
// within eps). `l1` gets the plain sum of |r| (same weights), for reports.
double huber_objective(const double* primal, const double* gx, const double* gy, int w, int h, double lambda,
                       double eps, const std::vector<double>& x, int threads, std::vector<double>& rows,
                       std::vector<double>& rows_l1, double* l1) {
  auto hub = [eps](double r) {
    r = std::abs(r);
    return r >= eps ? r : r * r / (2 * eps) + eps / 2;
  };
  for_rows(w, h, threads, [&](size_t r0, size_t r1) {
    for (size_t r = r0; r < r1; ++r) {
      double f = 0, a = 0;
      for (int c = 0; c < w; ++c) {
        const size_t i = r * w + c;
        const double rp = x[i] - primal[i];
        f += lambda * hub(rp);
        a += lambda * std::abs(rp);
        if (c < w - 1) {
          const double re = x[i + 1] - x[i] - gx[i];
          f += hub(re);
          a += std::abs(re);
        }
        if (static_cast<int>(r) < h - 1) {
          const double re = x[i + w] - x[i] - gy[i];
          f += hub(re);
          a += std::abs(re);
        }
      }
      rows[r] = f;
      rows_l1[r] = a;
    }
  });
  if (l1) *l1 = sum_rows(rows_l1);
  return sum_rows(rows);
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
  WeightedSystem A;
  A.w = w;
  A.h = h;
  A.threads = o.threads;
  A.c.assign(n, 0.0);
  A.wx.assign(n, 0.0);
  A.wy.assign(n, 0.0);
  Pcg pcg(A);
  std::vector<double> b(n), rows_f(h), rows_a(h);
  // Inexact rounds: each PCG stops once it has cut its starting residual by kInexact. IRLS is
  // a majorise-minimise method (the weighted quadratic touches the objective at the current
  // image and lies above it elsewhere), and CG lowers that quadratic from its warm start, so
  // even an inexact round lowers the objective. Measured on GPM buffers: 0.1-0.5 cut the PCG
  // iterations 2-4x against exact rounds for +-2 rounds.
  constexpr double kInexact = 0.3;
  constexpr double kOverRelax = 2.0;
  std::vector<double> x_prev(n), x_try(n);
  double l1 = 0;
  // The objective after each round (f[0]: the L2 start).
  std::vector<double> f{huber_objective(primal, gx, gy, w, h, o.lambda, eps, x, o.threads, rows_f, rows_a, &l1)};
  bool converged = false;
  double estimate = HUGE_VAL;
  for (int round = 0; round < o.max_irls_iterations && !converged; ++round) {
    // IRLS weights 1 / max(|r|, eps) of the current residuals (LKL*13), the primal's scaled by
    // lambda as eq. 3 of the GPM paper weights its term.
    for_rows(w, h, o.threads, [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r)
        for (int c = 0; c < w; ++c) {
          const size_t i = r * w + c;
          A.c[i] = o.lambda / std::max(std::abs(x[i] - primal[i]), eps);
          if (c < w - 1) A.wx[i] = 1.0 / std::max(std::abs(x[i + 1] - x[i] - gx[i]), eps);
          if (static_cast<int>(r) < h - 1) A.wy[i] = 1.0 / std::max(std::abs(x[i + w] - x[i] - gy[i]), eps);
        }
    });
    A.make_diagonal();
    for (int y = 0; y < h; ++y)
      for (int c = 0; c < w; ++c) {
        const size_t i = static_cast<size_t>(y) * w + c;
        double v = A.c[i] * primal[i];
        if (c > 0) v += A.wx[i - 1] * gx[i - 1];
        if (c < w - 1) v -= A.wx[i] * gx[i];
        if (y > 0) v += A.wy[i - w] * gy[i - w];
        if (y < h - 1) v -= A.wy[i] * gy[i];
        b[i] = v;
      }
    x_prev = x;
    report.cg_iterations += pcg.solve(b, x, o.max_cg_iterations, 1e-12, kInexact);  // (1e-12: rounding)
    ++report.irls_iterations;
    double fx = huber_objective(primal, gx, gy, w, h, o.lambda, eps, x, o.threads, rows_f, rows_a, &l1);
    // Over-relaxation: the round's step doubled, kept where it lowers the objective further
    // (one more pass over the image; the objective still falls every round). Near the minimum
    // the weights change little from round to round, so each majoriser's minimum lies a short,
    // similar step along the way: measured 1.7-1.9x fewer rounds and PCG iterations for the same
    // distance to the minimum on 48 x 36 GPM, GPT and GD-MLT buffers (x1.6: 1.5x).
    for_rows(w, h, o.threads, [&](size_t r0, size_t r1) {
      for (size_t i = r0 * w; i < r1 * w; ++i) x_try[i] = x_prev[i] + kOverRelax * (x[i] - x_prev[i]);
    });
    double l1_try = 0;
    const double f_try = huber_objective(primal, gx, gy, w, h, o.lambda, eps, x_try, o.threads, rows_f, rows_a, &l1_try);
    if (f_try < fx) {
      std::swap(x, x_try);
      fx = f_try;
      l1 = l1_try;
    }
    f.push_back(fx);
    // The stop: the distance of the objective to its minimum, estimated from how fast it falls.
    // IRLS converges about linearly, so the decrease of the last two rounds, s_now, against that
    // of the two before, s_before, gives the ratio r per two rounds, and the rounds still to
    // come would lower it by about s_now r / (1 - r) (a geometric tail). Pairs of rounds, not
    // single ones, because an inexact round that took one PCG iteration lowers it little and
    // the next one more. The decrease slows as IRLS nears the minimum, so the estimate runs
    // low (measured 2-4x on GPM, GPT and GD-MLT buffers: the default tolerance has that
    // headroom); it stops IRLS where the change of the image did not mean nearness (docs/gradient.md).
    const size_t k = f.size() - 1;
    if (k >= 4) {
      const double s_now = f[k - 2] - f[k], s_before = f[k - 4] - f[k - 2];
      const double r = s_before > 0 ? s_now / s_before : 1.0;
      estimate = s_now <= 0 ? 0.0 : r < 1 ? std::max(s_now * r / (1 - r), f[k - 1] - f[k]) : HUGE_VAL;
      converged = estimate <= o.tolerance * f[k];
    }
  }
  report.estimated_excess = std::max(report.estimated_excess, f.back() > 0 ? estimate / f.back() : 0.0);
  report.objective += f.back();
  report.objective_l1 += l1;
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
