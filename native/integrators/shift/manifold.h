// Manifold walk (Jakob & Marschner 2012, "Manifold exploration", §4-5; JM12 below) for the
// light-subpath shift of gradient-domain photon density estimation (GPM §4.2 step 2, eq. 7-10).
//
// A chain x_0 .. x_{k+1}: x_0 = y_b is fixed (the reconnection vertex: the last diffuse vertex of
// the light subpath, or its light vertex), x_1 .. x_k = y_{b+1} .. y_{s-1} are specular or glossy
// ("treated as specular", GPM §4.2), and x_{k+1} = y_s is the endpoint (the photon). Every chain
// vertex i carries the half-vector constraint of JM12 eq. 4-5,
//   c_i = tangential components of h_i - o_i,   h_i = normalize(eta_in w_in + eta_out w_out),
// in the BSDF's shading frame, with o_i = 0 at delta vertices and o_i = the base path's value at
// glossy ones (a shift preserves half-vectors, GPM §4.2). Each vertex lives on its triangle's
// plane with orthonormal tangent coordinates (a, b), and its shading normal is the mesh's vertex
// normals interpolated there (linear in (a, b), so the surface model is exact within a triangle;
// JM12 §4.1 uses the same first-order model). The derivative of the constraints is block
// tridiagonal (JM12 eq. 6); its blocks are taken by forward-mode automatic differentiation of
// c_i (Eigen's AutoDiffScalar) rather than JM12's hand-derived formulas: the same matrix.
//
// With A = dc/d(x_1..x_k) and B = dc/dx_{k+1}, moving the endpoint moves the chain by the tangent
// map T = -A^{-1} B (JM12 eq. 7). Its first block gives the generalized geometry term of the
// chain (GPM eq. 8): |d x_1 / d x_{k+1}| = G(y_b .. y_s) / G(y_b, y_{b+1}), returned here as the
// solid angle at y_b per unit area at the endpoint,
//   |d omega_b / dA(y_s)| = |det T_1| cos(x_1) / |x_1 - x_0|^2,
// with every chain vertex's half-vector held (delta ones at 0, glossy ones at o_i). From a
// distant light it is the beam's cross-section per unit area at the endpoint instead,
// |det T_1| |cos(x_1)| with cos(x_1) against the beam's direction (the ratio of two chains' values
// is the Jacobian either way).
//
// The walk (JM12 §5.2) moves the endpoint to a target on a surface: it predicts x_1 along the
// tangent map, then projects by ray tracing: a ray from x_0 through the predicted x_1 is
// propagated through the chain, each vertex reflecting or refracting (the base's lobe) about its
// prescribed half-vector, and must meet the same meshes in the same order. A step that brings the
// endpoint closer is taken (and the step size doubled, up to 1); otherwise the step is halved.
// It stops when the endpoint lies within `tolerance` of the target, or fails after
// `max_iterations` projections (GPM §5 uses 5, Mitsuba 20) or once the step has been halved
// below 1/10 (stuck).
#pragma once

#include <array>
#include <optional>

#include "core/math.h"
#include "integrators/shift/shift.h"
#include "integrators/paths/light_chain.h"
#include "scene/scene.h"

namespace gp {

struct ManifoldChain {
  Vec3 start;                                       // x_0 = y_b (fixed)
  // Non-zero for a distant light: x_0 is at infinity and every chain leaves along this unit
  // direction, so moving the endpoint moves x_1 across the parallel beam (w_in at x_1 held at
  // -start_dir); `start` is then only the photon's point on the emission disk.
  Vec3 start_dir;
  std::array<ChainVertex, kMaxChainVertices> v{};   // x_1 .. x_k
  int count = 0;                                    // k
  Vec3 end;                                         // x_{k+1} = y_s
  Vec3 end_ng;                                      // geometric normal at the endpoint
  std::array<Vec2, kMaxChainVertices> target{};     // o_i: prescribed half-vector components
};

// The half-vector components c_i + o_i (in the BSDF's Frame around the interpolated shading
// normal) at every chain vertex; false when a vertex is degenerate. Used to set the targets o_i
// of glossy vertices from the base path (delta vertices keep 0).
bool chain_half_vectors(const Scene& scene, const ManifoldChain& chain, std::array<Vec2, kMaxChainVertices>& out);

// |d omega_b / dA(y_s)| of the chain with all half-vectors held (see above); nullopt when the
// constraint matrix is singular or the chain degenerate.
std::optional<double> chain_direction_per_area(const Scene& scene, const ManifoldChain& chain);

// Propagates a ray leaving x_0 towards the point `aim` through the chain's vertices (each reflecting or
// refracting about its prescribed half-vector, the base's lobe) to the surface it reaches after
// the last one. Fills `out` (its vertices and end) and `end_hit`; fails (with the reason) when a
// ray misses, meets another mesh than the chain's, or the lobe is impossible (total internal
// reflection, wrong side).
ShiftFailure propagate_chain(const Scene& scene, const ManifoldChain& chain, const Vec3& start_ng, const Vec3& aim,
                             ManifoldChain& out, SurfacePoint& end_hit);

// What the chain's vertices do to a photon (importance transport), for the shift's throughput
// and MIS ratios: the product over x_1..x_k of f |cos wi| with the adjoint shading-normal
// correction (delta lobes: the Dirac weight of the base's lobe, Fresnel), of their pdfs (delta:
// the lobe's selection probability), and of |d omega_i / d o| at glossy vertices (the
// half-vector parameterisation of eq. 9, see below). wi_end: unit world direction from the
// endpoint back to x_k. ok = false when a vertex scatters nothing along the chain.
struct ChainThroughput {
  RGB f{1.0f};
  double pdf = 1;
  double jacobian = 1;
  // Product of the vertices' adjoint shading-normal corrections (included in f). Far from 1 only
  // where a direction grazes a facet; there it swings by orders of magnitude with round-off
  // (gpm.cpp kMaxShadingCorrection).
  double correction = 1;
  Vec3 wi_end;
  bool ok = false;
};
struct ManifoldWalk {
  ShiftFailure failure = ShiftFailure::None;
  ManifoldChain chain;       // the offset chain (its end within tolerance of the target)
  SurfacePoint end_hit;      // the surface point it ends on
  int iterations = 0;        // projections traced
  double dir_per_area = 0;   // chain_direction_per_area of the offset chain
  ChainThroughput through;   // what the offset chain's vertices do to the photon
  bool ok() const { return failure == ShiftFailure::None; }
};

// The base chain of a shift prepared for walks, from one evaluation of its local surfaces: its
// half-vector targets (0 at delta vertices, its own at glossy ones: GPM §4.2), the first block
// d x_1 / d x_{k+1} of its tangent map (JM12 eq. 7), its eq. 8 term and its throughput, shared
// by the walks to the four neighbours.
struct PreparedChain {
  ManifoldChain chain;          // with the targets set
  double t1[4] = {0, 0, 0, 0};  // row-major 2x2, tangent coordinates of x_1 and of the endpoint
  double dir_per_area = 0;      // chain_direction_per_area(chain)
  ChainThroughput through;
  bool ok = false;              // false: degenerate chain, singular constraints, or no throughput
};
PreparedChain prepare_chain(const Scene& scene, const ManifoldChain& chain);

// Walks `base` so that its endpoint reaches `target` (a point on a surface), x_0 fixed.
// start_ng: geometric normal at x_0 (zero for a point light) for the first ray's offset.
ManifoldWalk manifold_walk(const Scene& scene, const PreparedChain& base, const Vec3& start_ng, const Vec3& target,
                           float tolerance, int max_iterations);
// The same for prepare_chain(base): the walk holds base's own half-vectors at glossy vertices.
ManifoldWalk manifold_walk(const Scene& scene, const ManifoldChain& base, const Vec3& start_ng, const Vec3& target,
                           float tolerance, int max_iterations);


// T = -A^{-1} B for the constraint system of a chain of one or two vertices (A n x n, B n x 2,
// n <= kSmallSolve, column-major), as tangent_map solves it: false where |det A| <= 1e-300 or T
// is not finite. The same to the bit as Eigen's PartialPivLU and its solve (manifold.cpp).
inline constexpr int kSmallSolve = 4;
bool small_tangent_solve(int n, const double* a, const double* b, double* t);
// The same by Eigen's PartialPivLU, for any n <= 2 kMaxChainVertices (longer chains).
bool eigen_tangent_solve(int n, const double* a, const double* b, double* t);

// Solid-angle Jacobian |d omega_i / d o| of a glossy vertex's outgoing direction wi with respect
// to the tangential components o of its (unit, local) half-vector h, for incoming wo:
// |d omega_h / d o| = 1 / |h.z|, times |d omega_i / d omega_h| = 4 |wo.h| (reflection) or
// (eta_o wo.h + eta_i wi.h)^2 / (eta_i^2 |wi.h|) (refraction, Walter et al. 2007 eq. 16-17), with
// eta_o, eta_i the indices on the sides of wo and wi.
double half_vector_direction_jacobian(const Vec3& wo, const Vec3& wi, float ior, bool transmission);

}  // namespace gp
