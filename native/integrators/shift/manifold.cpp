// Manifold walk for GPM's light-subpath shift (see manifold.h for the method and references).
#include "integrators/shift/manifold.h"

#include <Eigen/Dense>
#include <unsupported/Eigen/AutoDiff>
#include <cmath>

#include "materials/bsdf.h"

namespace gp {

namespace {

bool distant(const ManifoldChain& c) { return c.start_dir.x != 0 || c.start_dir.y != 0 || c.start_dir.z != 0; }

using Vec3d = Eigen::Vector3d;
// Derivatives with respect to the tangent coordinates (a, b) of a vertex and its two neighbours.
using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 6, 1>>;
template <class S>
using V3 = Eigen::Matrix<S, 3, 1>;
// Constraint matrices sized at run time but stored inline (no heap allocation per walk step).
constexpr int kMaxRows = 2 * kMaxChainVertices;
using ConstraintMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxRows, kMaxRows + 2>;
using SquareMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxRows, kMaxRows>;
using TangentMap = Eigen::Matrix<double, Eigen::Dynamic, 2, 0, kMaxRows, 2>;

Vec3d to_d(const Vec3& v) { return Vec3d(v.x, v.y, v.z); }
Vec3 to_f(const Vec3d& v) { return Vec3(float(v.x()), float(v.y()), float(v.z())); }

// First-order model of the surface around a vertex (manifold.h): position p + a s + b t on the
// triangle's plane, unnormalised shading normal n + a dn_a + b dn_b.
struct LocalSurface {
  Vec3d p, s, t, ng, n, dn_a, dn_b;
  float ior = 1.5f;
};

LocalSurface local_surface(const Scene& scene, int mesh, int prim, const Vec3& p) {
  const Mesh& m = scene.meshes[mesh];
  const uint32_t i0 = m.indices[3 * prim], i1 = m.indices[3 * prim + 1], i2 = m.indices[3 * prim + 2];
  Vec3 v[3];
  scene.triangle_at(mesh, prim, shutter_time(), v);  // where a moving mesh is at the path's time
  const Vec3d p0 = to_d(v[0]), e1 = to_d(v[1]) - p0, e2 = to_d(v[2]) - p0;
  LocalSurface ls;
  ls.p = to_d(p);
  ls.ng = e1.cross(e2).normalized();
  ls.s = e1.normalized();
  ls.t = ls.ng.cross(ls.s);
  ls.ior = scene.material(static_cast<int>(m.material_ids[prim])).ior;
  if (m.normals.empty()) {
    ls.n = ls.ng;
    ls.dn_a = ls.dn_b = Vec3d::Zero();
    return ls;
  }
  // Barycentrics (b1, b2) as a linear function of the tangent coordinates: (a, b) = G (b1, b2).
  Eigen::Matrix2d g;
  g << e1.dot(ls.s), e2.dot(ls.s), e1.dot(ls.t), e2.dot(ls.t);
  const Eigen::Matrix2d g_inv = g.inverse();
  const Vec3d d = ls.p - p0;
  const Eigen::Vector2d bary = g_inv * Eigen::Vector2d(d.dot(ls.s), d.dot(ls.t));
  Vec3 nv[3] = {m.normals[i0], m.normals[i1], m.normals[i2]};
  if (m.motion && !m.motion->transform.empty() && !m.motion->object_normals.empty()) {
    const Transform to_world = m.motion->transform.at(shutter_time());  // a turning object's normals turn
    for (int k = 0; k < 3; ++k) nv[k] = normalize(to_world.normal(m.motion->object_normals[m.indices[3 * prim + k]]));
  }
  const Vec3d n0 = to_d(nv[0]), dn1 = to_d(nv[1]) - n0, dn2 = to_d(nv[2]) - n0;
  ls.n = n0 + bary[0] * dn1 + bary[1] * dn2;
  ls.dn_a = g_inv(0, 0) * dn1 + g_inv(1, 0) * dn2;
  ls.dn_b = g_inv(0, 1) * dn1 + g_inv(1, 1) * dn2;
  if (ls.n.dot(ls.ng) < 0) {  // shading normal on the geometric side (as Scene::intersect)
    ls.n = -ls.n;
    ls.dn_a = -ls.dn_a;
    ls.dn_b = -ls.dn_b;
  }
  return ls;
}

// The endpoint only moves on its tangent plane (its normal does not enter any constraint).
LocalSurface end_plane(const Vec3& p, const Vec3& ng) {
  LocalSurface ls;
  ls.p = to_d(p);
  ls.ng = ls.n = to_d(ng).normalized();
  const Frame f(to_f(ls.ng));
  ls.s = to_d(f.s);
  ls.t = to_d(f.t);
  ls.dn_a = ls.dn_b = Vec3d::Zero();
  return ls;
}

template <class S>
V3<S> position(const LocalSurface& ls, const S& a, const S& b) {
  return ls.p.cast<S>() + ls.s.cast<S>() * a + ls.t.cast<S>() * b;
}
template <class S>
V3<S> shading_normal(const LocalSurface& ls, const S& a, const S& b) {
  return (ls.n.cast<S>() + ls.dn_a.cast<S>() * a + ls.dn_b.cast<S>() * b).normalized();
}

// Frame's branchless basis (Duff et al. 2017) around unit n, for any scalar type: half-vectors
// are expressed in the same frame the BSDFs use.
template <class S>
void duff_basis(const V3<S>& n, V3<S>& s, V3<S>& t) {
  const double sign = n.z() >= S(0) ? 1.0 : -1.0;
  const S a = S(-1.0) / (S(sign) + n.z());
  const S b = n.x() * n.y() * a;
  s = V3<S>(S(1.0) + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
  t = V3<S>(b, S(sign) + n.y() * n.y() * a, -n.y());
}

// JM12 eq. 4-5: tangential components of the generalized half-vector at x (unit normal n) between
// the directions to prev and next; refraction weights each by the index on its side.
template <class S>
Eigen::Matrix<S, 2, 1> half_vector(const V3<S>& prev, const V3<S>& x, const V3<S>& n, const V3<S>& next, float ior,
                                   bool transmission) {
  const V3<S> w_in = (prev - x).normalized(), w_out = (next - x).normalized();
  V3<S> h;
  if (transmission) {
    const double eta_in = w_in.dot(n) > S(0) ? 1.0 : double(ior);
    const double eta_out = w_out.dot(n) > S(0) ? 1.0 : double(ior);
    h = w_in * S(eta_in) + w_out * S(eta_out);
  } else {
    h = w_in + w_out;
  }
  if (h.dot(n) < S(0)) h = -h;
  h.normalize();
  V3<S> s, t;
  duff_basis(n, s, t);
  return Eigen::Matrix<S, 2, 1>(h.dot(s), h.dot(t));
}

// Local surfaces of x_1 .. x_k and the endpoint plane.
using Surfaces = std::array<LocalSurface, kMaxChainVertices + 1>;

// Computes them for a chain; false on a degenerate triangle.
bool chain_surfaces(const Scene& scene, const ManifoldChain& c, Surfaces& out) {
  for (int j = 0; j < c.count; ++j) {
    out[j] = local_surface(scene, c.v[j].mesh, c.v[j].prim, c.v[j].p);
    if (!out[j].ng.allFinite() || !out[j].n.allFinite() || out[j].n.squaredNorm() == 0) return false;
  }
  out[c.count] = end_plane(c.end, c.end_ng);
  return out[c.count].ng.allFinite();
}

}  // namespace

// Eigen's PartialPivLU of a matrix sized at run time, and its solve, go through machinery made
// for large matrices (blocked LU, packed triangular solves): for the 2x2 and 4x4 systems of one-
// and two-vertex chains that was a third of tangent_map's instructions (callgrind, cornell-glass).
// Here are the very operations Eigen 3.4 performs on them, in its order, and nothing else, so the
// tangent map is the same to the bit (manifold_test checks it against Eigen):
//  - PartialPivLU (LU/PartialPivLU.h, partial_lu_impl::unblocked_lu, sizes below 16): per
//    column k, the first row of largest |a| below the diagonal is the pivot (strict >), the rows
//    are swapped, the column below is divided by the pivot, and the trailing block takes
//    a_rc -= a_rk a_kc;
//  - the determinant as the diagonal's product from the first element on, its sign aside;
//  - solve (PartialPivLU::_solve_impl): the transpositions applied to B in order, then
//    triangular_solve_matrix (products/TriangularSolverMatrix.h, column-major, OnTheLeft) whose
//    first panel (4 wide with SSE2 doubles) holds the whole system: unit lower, forward,
//    x_r -= x_i l_ri; upper, backward, x_i *= 1 / u_ii, then x_r -= x_i u_ri.
// (Built with FMA contraction, -march=native, either side may fuse a - b c: the test would say.)
bool eigen_tangent_solve(int n, const double* a, const double* b, double* t) {
  const SquareMatrix A = Eigen::Map<const Eigen::MatrixXd>(a, n, n);
  const TangentMap B = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 2>>(b, n, 2);
  const Eigen::PartialPivLU<SquareMatrix> lu(A);
  if (!(std::abs(lu.determinant()) > 1e-300)) return false;
  const TangentMap T = -lu.solve(B);
  if (!T.allFinite()) return false;
  for (int c = 0; c < 2; ++c)
    for (int r = 0; r < n; ++r) t[c * n + r] = T(r, c);
  return true;
}

bool small_tangent_solve(int n, const double* a, const double* b, double* t) {
  double lu[kSmallSolve][kSmallSolve];  // [row][column]
  double x[kSmallSolve][2];
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) lu[r][c] = a[c * n + r];
    x[r][0] = b[r];
    x[r][1] = b[n + r];
  }
  int transposition[kSmallSolve];
  for (int k = 0; k < n; ++k) {
    int p = k;
    double biggest = std::abs(lu[k][k]);
    for (int r = k + 1; r < n; ++r)
      if (std::abs(lu[r][k]) > biggest) {
        biggest = std::abs(lu[r][k]);
        p = r;
      }
    transposition[k] = p;
    if (biggest != 0.0) {
      if (p != k)
        for (int c = 0; c < n; ++c) std::swap(lu[k][c], lu[p][c]);
      for (int r = k + 1; r < n; ++r) lu[r][k] /= lu[k][k];
    }
    for (int c = k + 1; c < n; ++c)
      for (int r = k + 1; r < n; ++r) lu[r][c] -= lu[k][c] * lu[r][k];
  }
  double det = lu[0][0];
  for (int i = 1; i < n; ++i) det *= lu[i][i];
  if (!(std::abs(det) > 1e-300)) return false;  // as tangent_map's test of Eigen's determinant
  for (int k = 0; k < n; ++k)
    if (transposition[k] != k) std::swap(x[k], x[transposition[k]]);
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < n; ++i) {  // unit lower
      const double bi = x[i][j];
      for (int r = i + 1; r < n; ++r) x[r][j] -= bi * lu[r][i];
    }
    for (int i = n - 1; i >= 0; --i) {  // upper
      x[i][j] *= 1.0 / lu[i][i];
      const double bi = x[i][j];
      for (int r = 0; r < i; ++r) x[r][j] -= bi * lu[r][i];
    }
  }
  for (int j = 0; j < 2; ++j)
    for (int r = 0; r < n; ++r) {
      t[j * n + r] = -x[r][j];
      if (!std::isfinite(t[j * n + r])) return false;
    }
  return true;
}

namespace {

// Tangent map T = -A^{-1} B (JM12 eq. 7): the motion of x_1..x_k (2k rows) per unit motion of
// the endpoint in its tangent plane (2 columns). nullopt when A is singular.
std::optional<TangentMap> tangent_map(const Scene& scene, const ManifoldChain& c,
                                           const Surfaces& surf) {
  const int k = c.count;
  ConstraintMatrix M = ConstraintMatrix::Zero(2 * k, 2 * k + 2);
  for (int j = 0; j < k; ++j) {
    // Variables: (a, b) of x_{j} (previous; x_0 is fixed), x_{j+1} (this vertex), x_{j+2} (next).
    AD v[6];
    for (int q = 0; q < 6; ++q) v[q] = AD(0.0, 6, q);
    const V3<AD> x = position(surf[j], v[2], v[3]);
    // x_0 fixed, or at infinity for a distant light (w_in held at -start_dir: no derivative).
    const V3<AD> prev = j > 0 ? position(surf[j - 1], v[0], v[1])
                        : distant(c) ? V3<AD>(x - to_d(c.start_dir).cast<AD>())
                                     : V3<AD>(to_d(c.start).cast<AD>());
    const V3<AD> n = shading_normal(surf[j], v[2], v[3]);
    const V3<AD> next = position(surf[j + 1], v[4], v[5]);
    const auto h = half_vector(prev, x, n, next, surf[j].ior, c.v[j].transmission);
    for (int r = 0; r < 2; ++r) {
      const auto& d = h[r].derivatives();
      if (!d.allFinite()) return std::nullopt;
      if (j > 0) M.block<1, 2>(2 * j + r, 2 * (j - 1)) = d.segment<2>(0).transpose();
      M.block<1, 2>(2 * j + r, 2 * j) = d.segment<2>(2).transpose();
      M.block<1, 2>(2 * j + r, 2 * (j + 1)) = d.segment<2>(4).transpose();
    }
  }
  const int n = 2 * k;
  double a[kMaxRows * kMaxRows], b[2 * kMaxRows], t[2 * kMaxRows];  // column-major
  for (int c = 0; c < n; ++c)
    for (int r = 0; r < n; ++r) a[c * n + r] = M(r, c);
  for (int c = 0; c < 2; ++c)
    for (int r = 0; r < n; ++r) b[c * n + r] = M(r, n + c);
  // One or two vertices (a mirror, a glass ball: most chains) by the small solve.
  if (!(n <= kSmallSolve ? small_tangent_solve(n, a, b, t) : eigen_tangent_solve(n, a, b, t))) return std::nullopt;
  TangentMap T(n, 2);
  for (int c = 0; c < 2; ++c)
    for (int r = 0; r < n; ++r) T(r, c) = t[c * n + r];
  return T;
}



// |d omega_b / dA(y_s)| from the tangent map (see chain_direction_per_area); from a distant
// light the beam's cross-section per endpoint area.
std::optional<double> direction_per_area(const ManifoldChain& c, const Surfaces& surf, const TangentMap& T) {
  if (distant(c)) {
    const double D = std::abs(T.topRows(2).determinant()) * std::abs(surf[0].ng.dot(to_d(c.start_dir)));
    if (!std::isfinite(D) || !(D > 0)) return std::nullopt;
    return D;
  }
  const Vec3d d = to_d(c.start) - surf[0].p;
  const double d2 = d.squaredNorm();
  if (!(d2 > 0)) return std::nullopt;
  const double cos1 = std::abs(surf[0].ng.dot(d)) / std::sqrt(d2);
  const double D = std::abs(T.topRows(2).determinant()) * cos1 / d2;  // GPM eq. 8 over cos at y_b
  if (!std::isfinite(D) || !(D > 0)) return std::nullopt;
  return D;
}

ChainThroughput throughput(const Scene& scene, const ManifoldChain& c, const Surfaces& surf) {
  ChainThroughput out;
  for (int j = 0; j < c.count; ++j) {
    const ChainVertex& x = c.v[j];
    const Vec3 prev = j > 0 ? c.v[j - 1].p : distant(c) ? x.p - c.start_dir : c.start;
    const Vec3 next = j + 1 == c.count ? c.end : c.v[j + 1].p;
    const Vec3 ns = to_f(surf[j].n.normalized()), ng = x.ng;
    const Frame frame(ns);
    const Vec3 wo_w = normalize(prev - x.p), wi_w = normalize(next - x.p);
    const Vec3 wo = frame.to_local(wo_w), wi = frame.to_local(wi_w);
    const Bsdf bsdf = scene.bsdf_at(x.mesh, x.prim, x.p, wo_w, ns);
    const float corr = adjoint_shading_correction(wo_w, wi_w, ng, ns);
    if (corr == 0 || wo.z == 0) return out;
    out.correction *= corr;
    if (bsdf.is_delta()) {
      // The base's lobe at this configuration (the walk put wi on its specular direction).
      const float uc = x.transmission ? 1.0f - 0x1p-24f : 0.0f;
      const auto s = bsdf.sample(wo, uc, Vec2(0.5f, 0.5f), TransportMode::Importance);
      if (!s || s->transmission != x.transmission || !(s->pdf > 0)) return out;
      out.f *= s->f * (std::abs(s->wi.z) * corr);
      out.pdf *= s->pdf;
    } else {
      out.f *= bsdf.eval(wo, wi, TransportMode::Importance) * (std::abs(wi.z) * corr);
      out.pdf *= bsdf.pdf(wo, wi);
      out.jacobian *= half_vector_direction_jacobian(wo, wi, bsdf.params().ior, x.transmission);
    }
  }
  out.wi_end = normalize((c.count > 0 ? c.v[c.count - 1].p : c.start) - c.end);
  out.ok = !out.f.is_black() && out.pdf > 0 && out.jacobian > 0 && std::isfinite(out.jacobian);
  return out;
}

}  // namespace

namespace {

bool half_vectors(const ManifoldChain& c, const Surfaces& surf, std::array<Vec2, kMaxChainVertices>& out) {
  for (int j = 0; j < c.count; ++j) {
    const Vec3d prev = j > 0 ? surf[j - 1].p : distant(c) ? Vec3d(surf[0].p - to_d(c.start_dir)) : to_d(c.start);
    const Eigen::Vector2d h =
        half_vector<double>(prev, surf[j].p, surf[j].n.normalized(), surf[j + 1].p, surf[j].ior, c.v[j].transmission);
    if (!h.allFinite()) return false;
    out[j] = Vec2(float(h[0]), float(h[1]));
  }
  return true;
}

}  // namespace

bool chain_half_vectors(const Scene& scene, const ManifoldChain& c, std::array<Vec2, kMaxChainVertices>& out) {
  Surfaces surf;
  return c.count > 0 && c.count <= kMaxChainVertices && chain_surfaces(scene, c, surf) && half_vectors(c, surf, out);
}

std::optional<double> chain_direction_per_area(const Scene& scene, const ManifoldChain& c) {
  Surfaces surf;
  if (c.count <= 0 || c.count > kMaxChainVertices || !chain_surfaces(scene, c, surf)) return std::nullopt;
  const auto T = tangent_map(scene, c, surf);
  return T ? direction_per_area(c, surf, *T) : std::nullopt;
}

namespace {

ShiftFailure propagate(const Scene& scene, const ManifoldChain& c, const Vec3& start_ng, const Vec3& aim,
                       ManifoldChain& out, SurfacePoint& end_hit, Surfaces& surf) {
  out = c;
  // Aim from the ray's actual origin (pushed off x_0's surface), so that aiming at a chain's own
  // x_1 gives that chain back: near a caustic a 1e-5 origin shift moves the endpoint visibly.
  const bool on_surface = start_ng.x != 0 || start_ng.y != 0 || start_ng.z != 0;
  // A distant light's ray runs along its direction through the aim, from outside the scene.
  const float back = length(scene.bounds().diagonal()) + length(aim - scene.bounds().center());
  const Vec3 o = distant(c)     ? aim - c.start_dir * back
                 : on_surface ? offset_ray_origin(c.start, start_ng, aim - c.start)
                              : c.start;
  const Vec3 dir = distant(c) ? c.start_dir : normalize(aim - o);
  if (!(length_squared(dir) > 0)) return ShiftFailure::ZeroLength;
  Ray ray(o, dir);
  for (int j = 0; j < c.count; ++j) {
    const auto hit = scene.intersect_point(ray);
    if (!hit) return ShiftFailure::Missed;
    if (hit->mesh != c.v[j].mesh) return ShiftFailure::Occluded;  // another surface in the way
    surf[j] = local_surface(scene, hit->mesh, hit->prim, hit->p);
    const LocalSurface& ls = surf[j];
    // A degenerate triangle (zero area, or normals cancelling) has no frame: no NaN ray is traced.
    if (!ls.n.allFinite() || !ls.ng.allFinite() || !(ls.n.squaredNorm() > 0)) return ShiftFailure::ZeroLength;
    const Vec3d n = ls.n.normalized();
    Vec3d s, t;
    duff_basis<double>(n, s, t);
    const Vec3d wo_w = -to_d(ray.d).normalized();
    const Vec3d wo(wo_w.dot(s), wo_w.dot(t), wo_w.dot(n));
    const Vec2 o = c.target[j];
    const double o2 = double(o.x) * o.x + double(o.y) * o.y;
    if (!(o2 < 1.0)) return ShiftFailure::ZeroLength;
    const Vec3d h(o.x, o.y, std::sqrt(1.0 - o2));
    Vec3d wi;
    if (c.v[j].transmission) {
      const bool outside = wo.z() > 0;
      const Vec3d hh = wo.dot(h) >= 0 ? h : Vec3d(-h);
      const double eta = outside ? ls.ior : 1.0 / ls.ior;  // n_wi / n_wo
      if (!refract_oriented(wo, hh, wo.dot(hh), eta, &wi)) return ShiftFailure::TotalInternalReflection;
      if (wi.z() * wo.z() >= 0) return ShiftFailure::NotInvertible;
    } else {
      wi = 2.0 * wo.dot(h) * h - wo;
      if (wi.z() * wo.z() <= 0) return ShiftFailure::NotInvertible;
    }
    const Vec3d wi_w = (wi.x() * s + wi.y() * t + wi.z() * n).normalized();
    if (!wi_w.allFinite()) return ShiftFailure::ZeroLength;
    out.v[j].p = hit->p;
    out.v[j].ng = hit->ng;
    out.v[j].prim = hit->prim;
    const Vec3 d = to_f(wi_w);
    ray = Ray(offset_ray_origin(hit->p, hit->ng, d), d);
  }
  const auto hit = scene.intersect_point(ray);
  if (!hit) return ShiftFailure::Missed;
  out.end = hit->p;
  out.end_ng = hit->ng;
  end_hit = *hit;
  surf[c.count] = end_plane(out.end, out.end_ng);
  return ShiftFailure::None;
}

}  // namespace

ShiftFailure propagate_chain(const Scene& scene, const ManifoldChain& c, const Vec3& start_ng, const Vec3& aim,
                             ManifoldChain& out, SurfacePoint& end_hit) {
  Surfaces surf;
  return propagate(scene, c, start_ng, aim, out, end_hit, surf);
}

PreparedChain prepare_chain(const Scene& scene, const ManifoldChain& chain) {
  PreparedChain out;
  out.chain = chain;
  Surfaces surf;
  if (chain.count <= 0 || chain.count > kMaxChainVertices || !chain_surfaces(scene, chain, surf)) return out;
  // Half-vector targets o_i: 0 at delta vertices, the base's own at glossy ones (GPM §4.2).
  std::array<Vec2, kMaxChainVertices> h;
  if (!half_vectors(chain, surf, h)) return out;
  for (int j = 0; j < chain.count; ++j) {
    const ChainVertex& x = chain.v[j];
    const Bsdf bsdf = scene.bsdf_at(x.mesh, x.prim, x.p, x.ng, x.ng);
    out.chain.target[j] = bsdf.is_delta() ? Vec2(0, 0) : h[j];
  }
  const auto T = tangent_map(scene, chain, surf);
  if (!T) return out;
  const auto D = direction_per_area(chain, surf, *T);
  if (!D) return out;
  out.t1[0] = (*T)(0, 0);
  out.t1[1] = (*T)(0, 1);
  out.t1[2] = (*T)(1, 0);
  out.t1[3] = (*T)(1, 1);
  out.dir_per_area = *D;
  out.through = throughput(scene, chain, surf);
  out.ok = out.through.ok;
  return out;
}

ManifoldWalk manifold_walk(const Scene& scene, const ManifoldChain& base, const Vec3& start_ng, const Vec3& target,
                           float tolerance, int max_iterations) {
  return manifold_walk(scene, prepare_chain(scene, base), start_ng, target, tolerance, max_iterations);
}

// A walk whose step has been halved below this (four steps in a row from a full one that did not
// bring the endpoint closer) is stuck. Giving up there, with a cap of 20 projections, converges
// more walks than a cap of 5 at 17 % more projections on cornell-glass; a cap that cuts off walks
// still converging biases GPM's gradients (gpm_test, ExpectedGradient...).
constexpr double kStuckStep = 0.1;

ManifoldWalk manifold_walk(const Scene& scene, const PreparedChain& prepared, const Vec3& start_ng,
                           const Vec3& target, float tolerance, int max_iterations) {
  ManifoldWalk w;
  const ManifoldChain& base = prepared.chain;
  w.chain = base;
  if (!prepared.ok) {
    w.failure = ShiftFailure::SpecularChain;
    return w;
  }
  const Vec3d goal = to_d(target);
  double dist = (to_d(base.end) - goal).norm();
  bool have_end = false;
  double beta = 1.0;  // step size (JM12 §5.2)
  // The current chain and its surfaces, and the projection being tried: two buffers each,
  // swapped by index when a step is taken (they are kilobytes; a copy per step showed in profiles).
  ManifoldChain chains[2];
  Surfaces surfs[2];
  SurfacePoint ends[2];
  int cur = 0;
  chains[0] = base;
  if (!chain_surfaces(scene, base, surfs[0])) {
    w.failure = ShiftFailure::SpecularChain;
    return w;
  }
  // The first step predicts with the prepared chain's tangent map.
  std::optional<TangentMap> T = TangentMap::Zero(2 * base.count, 2);
  (*T)(0, 0) = prepared.t1[0];
  (*T)(0, 1) = prepared.t1[1];
  (*T)(1, 0) = prepared.t1[2];
  (*T)(1, 1) = prepared.t1[3];
  bool need_map = false;
  for (int it = 0; it < max_iterations; ++it) {
    const Surfaces& surf = surfs[cur];
    if (need_map) {
      T = tangent_map(scene, chains[cur], surf);
      if (!T) break;
      need_map = false;
    }
    // Linear prediction of x_1 for the endpoint's motion in its tangent plane.
    const int k = base.count;
    const Vec3d delta = goal - surf[k].p;
    const Eigen::Vector2d d_end(delta.dot(surf[k].s), delta.dot(surf[k].t));
    const Eigen::Vector2d d1 = beta * (T->topRows(2) * d_end);
    const Vec3d x1 = surf[0].p + d1[0] * surf[0].s + d1[1] * surf[0].t;
    ++w.iterations;
    const int nxt = 1 - cur;
    const ShiftFailure f = x1.allFinite()
                               ? propagate(scene, chains[cur], start_ng, to_f(x1), chains[nxt], ends[nxt], surfs[nxt])
                               : ShiftFailure::ZeroLength;
    const double next_dist = f == ShiftFailure::None ? (to_d(chains[nxt].end) - goal).norm() : kInfinity;
    if (f == ShiftFailure::None && (next_dist < dist || (!have_end && next_dist <= tolerance))) {
      cur = nxt;
      have_end = true;
      dist = next_dist;
      need_map = true;
      if (dist <= tolerance) {
        // Converged: the offset chain's eq. 8 term and throughput, from the surfaces at hand.
        w.chain = chains[cur];
        w.end_hit = ends[cur];
        const auto T_end = tangent_map(scene, w.chain, surfs[cur]);
        const auto D = T_end ? direction_per_area(w.chain, surfs[cur], *T_end) : std::nullopt;
        if (!D) break;
        w.dir_per_area = *D;
        w.through = throughput(scene, w.chain, surfs[cur]);
        return w;
      }
      beta = std::min(1.0, 2.0 * beta);
    } else {
      beta *= 0.5;
      if (beta < kStuckStep) break;  // stuck: more projections would not converge either
    }
  }
  w.chain = chains[cur];
  w.end_hit = ends[cur];
  w.failure = ShiftFailure::WalkNotConverged;
  return w;
}

double half_vector_direction_jacobian(const Vec3& wo_f, const Vec3& wi_f, float ior, bool transmission) {
  const Vec3d wo = to_d(wo_f).normalized(), wi = to_d(wi_f).normalized();
  if (!transmission) {
    Vec3d h = (wo + wi).normalized();
    if (!(std::abs(h.z()) > 0)) return 0.0;
    return 4.0 * std::abs(wo.dot(h)) / std::abs(h.z());
  }
  const double n_wo = wo.z() > 0 ? 1.0 : ior, n_wi = wi.z() > 0 ? 1.0 : ior;
  Vec3d h = n_wo * wo + n_wi * wi;
  if (!(h.squaredNorm() > 0)) return 0.0;
  h.normalize();
  const double denom = n_wi * n_wi * std::abs(wi.dot(h)) * std::abs(h.z());
  if (!(denom > 0)) return 0.0;
  const double num = n_wo * wo.dot(h) + n_wi * wi.dot(h);
  return num * num / denom;  // Walter et al. 2007 eq. 16-17, over |d o / d omega_h| = |h.z|
}

}  // namespace gp
