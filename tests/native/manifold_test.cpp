// Manifold walk of GPM's light-subpath shift (integrators/shift/manifold): the generalized
// geometry term of a two-vertex refraction chain (GPM eq. 8) and a glossy chain with held
// half-vectors against finite differences of the ray-traced chain, the half-vector Jacobian of
// eq. 9 against finite differences, and the walk reaching a target on the floor.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "core/frame.h"
#include "integrators/shift/manifold.h"
#include "scene/loader.h"

namespace gp {
namespace {

// A glass sphere (smooth vertex normals) above a floor; `roughness` 0 is delta glass, 0.02 is
// glossy glass below the photon threshold (treated as specular by the walk).
Scene sphere_scene(float roughness) {
  const std::string json = R"({
    "camera": {"position": [0, -3, 1], "look_at": [0, 0, 0.3], "fov": 40, "width": 16, "height": 16},
    "materials": {
      "white": {"type": "diffuse", "color": 0.7},
      "glass": {"type": "dielectric", "ior": 1.5, "roughness": )" + std::to_string(roughness) + R"(}
    },
    "objects": [
      {"name": "floor", "type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "white"},
      {"name": "ball", "type": "sphere", "center": [0, 0, 1.0], "radius": 0.3, "segments": 64, "material": "glass"}
    ]
  })";
  return load_scene_from_string(json, ".", "manifold-test");
}

constexpr int kBall = 1;  // mesh index of the sphere (objects in order)

// A two-vertex chain through the sphere from `start` along `dir`, with half-vector targets `o`.
ManifoldChain chain_through_ball(const Scene& scene, const Vec3& start, const Vec3& dir, Vec2 o,
                                 ShiftFailure* failure = nullptr) {
  ManifoldChain tmpl;
  tmpl.start = start;
  tmpl.count = 2;
  for (int j = 0; j < 2; ++j) {
    tmpl.v[j].mesh = kBall;
    tmpl.v[j].transmission = true;
    tmpl.target[j] = o;
  }
  ManifoldChain out;
  SurfacePoint end;
  const ShiftFailure f = propagate_chain(scene, tmpl, Vec3(0, 0, 0), start + normalize(dir), out, end);
  if (failure) *failure = f;
  return out;
}

// |d omega / dA(end)| by central differences of the ray-traced chain map.
double fd_direction_per_area(const Scene& scene, const Vec3& start, const Vec3& dir, Vec2 o) {
  const Frame f(normalize(dir));
  const double h = 5e-4;
  auto end_at = [&](double a, double b) {
    const Vec3 d = normalize(f.n + f.s * float(a) + f.t * float(b));
    return chain_through_ball(scene, start, d, o).end;
  };
  const Vec3 da = end_at(h, 0) - end_at(-h, 0), db = end_at(0, h) - end_at(0, -h);
  const double area = std::abs(dot(cross(da, db), Vec3(0, 0, 1)));  // the floor's normal
  return (4 * h * h) / area;
}

TEST(Manifold, RefractionChainGeometryTermMatchesFiniteDifferences) {
  const Scene scene = sphere_scene(0.0f);
  const Vec3 light(0.05f, -0.02f, 2.2f);
  for (const Vec3 aim : {Vec3(0.1f, 0.05f, 1.0f), Vec3(-0.12f, 0.02f, 1.0f), Vec3(0.0f, 0.18f, 1.02f)}) {
    const Vec3 dir = normalize(aim - light);
    ShiftFailure f;
    const ManifoldChain c = chain_through_ball(scene, light, dir, Vec2(0, 0), &f);
    ASSERT_EQ(f, ShiftFailure::None);
    ASSERT_NEAR(c.end.z, 0.0f, 1e-4f);  // the chain ends on the floor
    const auto D = chain_direction_per_area(scene, c);
    ASSERT_TRUE(D.has_value());
    const double fd = fd_direction_per_area(scene, light, dir, Vec2(0, 0));
    EXPECT_NEAR(*D, fd, 0.005 * fd) << "aim " << aim.x << " " << aim.y;
    // Focusing: the sphere concentrates directions, unlike a free segment (cos/d^2).
    const double free_segment = std::abs(dir.z) / length_squared(c.end - light);
    EXPECT_GT(std::abs(*D / free_segment - 1.0), 0.1);
  }
}

TEST(Manifold, GlossyChainWithHeldHalfVectorsMatchesFiniteDifferences) {
  const Scene scene = sphere_scene(0.02f);
  const Vec3 light(0.05f, -0.02f, 2.2f);
  const Vec2 o(0.04f, -0.03f);  // non-zero half-vectors (glossy vertices off their mirror direction)
  const Vec3 dir = normalize(Vec3(0.08f, 0.04f, 1.0f) - light);
  ShiftFailure f;
  const ManifoldChain c = chain_through_ball(scene, light, dir, o, &f);
  ASSERT_EQ(f, ShiftFailure::None);
  // The propagated chain holds the prescribed half-vectors (the constraint of JM12 eq. 4-5).
  std::array<Vec2, kMaxChainVertices> h;
  ASSERT_TRUE(chain_half_vectors(scene, c, h));
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(h[j].x, o.x, 1e-4);
    EXPECT_NEAR(h[j].y, o.y, 1e-4);
  }
  const auto D = chain_direction_per_area(scene, c);
  ASSERT_TRUE(D.has_value());
  const double fd = fd_direction_per_area(scene, light, dir, o);
  EXPECT_NEAR(*D, fd, 0.005 * fd);
}

TEST(Manifold, WalkReachesATargetOnTheFloor) {
  const Scene scene = sphere_scene(0.0f);
  const Vec3 light(0.05f, -0.02f, 2.2f);
  const ManifoldChain base = chain_through_ball(scene, light, normalize(Vec3(0.1f, 0.05f, 1.0f) - light), Vec2(0, 0));
  int converged = 0;
  for (const Vec3 step : {Vec3(0.01f, 0, 0), Vec3(0, -0.01f, 0), Vec3(0.02f, 0.015f, 0), Vec3(-0.005f, 0.003f, 0)}) {
    const Vec3 target = base.end + step;
    const float tol = 1e-5f;
    const ManifoldWalk w = manifold_walk(scene, base, Vec3(0, 0, 0), target, tol, 5);
    ASSERT_TRUE(w.ok()) << "step " << step.x << " " << step.y << ": " << failure_stat_name(w.failure);
    EXPECT_LE(length(w.chain.end - target), tol);
    EXPECT_LE(w.iterations, 5);
    // The walked chain is still a refraction path (half-vectors along the normals).
    std::array<Vec2, kMaxChainVertices> h;
    ASSERT_TRUE(chain_half_vectors(scene, w.chain, h));
    for (int j = 0; j < 2; ++j) EXPECT_LT(std::hypot(h[j].x, h[j].y), 1e-4);
    ++converged;
  }
  EXPECT_EQ(converged, 4);
  // A target the chain cannot reach (behind the light's side of the ball): counted, not a crash.
  const ManifoldWalk bad = manifold_walk(scene, base, Vec3(0, 0, 0), Vec3(2.5f, 2.5f, 0), 1e-5f, 5);
  EXPECT_FALSE(bad.ok());
  EXPECT_EQ(bad.failure, ShiftFailure::WalkNotConverged);
}

// The 2x2 and 4x4 solve of one- and two-vertex chains' tangent maps is Eigen's PartialPivLU and
// solve to the bit (the walks, and so GPM's images, are the same as with Eigen's): random
// systems, ones whose pivots tie or need every row swap, a zero column (singular), tiny entries.
TEST(Manifold, SmallTangentSolveIsEigensLuToTheBit) {
  uint64_t state = 12345;
  auto uniform = [&state] {  // splitmix64
    uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1p-53 * 2.0 - 1.0;
  };
  int solved = 0, refused = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const int n = trial % 2 ? 4 : 2;
    double a[16], b[8];  // column-major
    for (int c = 0; c < n; ++c)
      for (int r = 0; r < n; ++r) a[c * n + r] = uniform() * (trial % 7 == 0 ? 1e-80 : 3.0);
    for (double& v : b) v = uniform();
    if (trial % 11 == 0)  // singular: a zero column
      for (int r = 0; r < n; ++r) a[(trial % n) * n + r] = 0;
    if (trial % 13 == 0) a[1] = -a[0];  // a tie for the first pivot
    if (trial % 17 == 0)                // every column pivots below the first row
      for (int c = 0; c < n; ++c) a[c * n] *= 1e-9;
    if (trial % 19 == 0) a[0] = 1, a[1] = 0, a[n] = 0, a[n + 1] = 1;  // an identity block: no swaps
    double t_small[8], t_eigen[8];
    const bool ok = small_tangent_solve(n, a, b, t_small);
    ASSERT_EQ(ok, eigen_tangent_solve(n, a, b, t_eigen)) << "trial " << trial;
    if (!ok) {
      ++refused;
      continue;
    }
    ++solved;
    for (int i = 0; i < 2 * n; ++i)
      ASSERT_EQ(std::memcmp(&t_small[i], &t_eigen[i], sizeof(double)), 0)
          << "trial " << trial << " n " << n << " entry " << i << ": " << t_small[i] << " vs " << t_eigen[i];
  }
  EXPECT_GT(solved, 3000);
  EXPECT_GT(refused, 100);
}

// |d omega_i / d o| (eq. 9's reparameterisation) against finite differences of wi(o).
TEST(Manifold, HalfVectorDirectionJacobianMatchesFiniteDifferences) {
  const Vec3 wo = normalize(Vec3(0.3f, -0.2f, 0.9f));
  const float ior = 1.5f;
  for (bool transmission : {false, true}) {
    for (const Vec2 o : {Vec2(0.05f, 0.02f), Vec2(-0.1f, 0.07f)}) {
      auto wi_of = [&](double ox, double oy) {
        const double hz = std::sqrt(1.0 - ox * ox - oy * oy);
        const double h[3] = {ox, oy, hz};
        const double c = wo.x * h[0] + wo.y * h[1] + wo.z * h[2];
        double w[3];
        if (!transmission) {
          for (int k = 0; k < 3; ++k) w[k] = 2 * c * h[k] - (&wo.x)[k];
        } else {
          const double eta = 1.0 / ior;  // wo outside
          const double cos_t = std::sqrt(1 - eta * eta * (1 - c * c));
          for (int k = 0; k < 3; ++k) w[k] = -eta * (&wo.x)[k] + (eta * c - cos_t) * h[k];
        }
        return Vec3(float(w[0]), float(w[1]), float(w[2]));
      };
      const double e = 1e-3;
      const Vec3 a = wi_of(o.x + e, o.y) - wi_of(o.x - e, o.y), b = wi_of(o.x, o.y + e) - wi_of(o.x, o.y - e);
      const double fd = length(cross(a, b)) / (4 * e * e);
      const double j = half_vector_direction_jacobian(wo, wi_of(o.x, o.y), ior, transmission);
      EXPECT_NEAR(j, fd, 1e-2 * fd) << (transmission ? "refraction" : "reflection");
    }
  }
}

}  // namespace
}  // namespace gp
