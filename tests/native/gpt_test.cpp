// Gradient-domain path tracing (integrators/gradient/gpt) and its shift mapping
// (integrators/shift/shift): Jacobians against finite differences, convergence to a
// path-traced reference, the paper's Figure 4 trend, zero gradients where the image is flat,
// determinism and finiteness.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "integrators/methods.h"
#include "core/frame.h"
#include "integrators/gradient/gpt.h"
#include "integrators/shift/shift.h"
#include "io/metrics.h"
#include "scene/loader.h"

namespace gp {
namespace {

// ---- Shift Jacobians against finite differences ----

// Solid angle spanned by the finite-difference images of two small tangent steps of w.
struct SphereChart {
  Vec3 w, t1, t2;
  explicit SphereChart(Vec3 w_) : w(normalize(w_)) {
    const Frame f(w);
    t1 = f.s;
    t2 = f.t;
  }
  Vec3 at(double a, double b) const { return normalize(w + t1 * float(a) + t2 * float(b)); }
};
double solid_angle(const Vec3& c, const Vec3& a, const Vec3& b) { return length(cross(a - c, b - c)); }

// |d omega'/d omega| of a direction map by central differences on the sphere.
template <typename Map>
double fd_jacobian(const Vec3& w, Map map, double h = 2e-3) {
  const SphereChart ch(w);
  const Vec3 a0 = ch.at(-h, 0), a1 = ch.at(h, 0), b0 = ch.at(0, -h), b1 = ch.at(0, h);
  const double in = length(cross(a1 - a0, b1 - b0));
  const double out = length(cross(map(a1) - map(a0), map(b1) - map(b0)));
  return out / in;
}

Material glossy_conductor(float alpha) {
  Material m;
  m.type = MaterialType::Conductor;
  m.roughness = alpha;
  return m;
}
Material rough_glass(float alpha) {
  Material m;
  m.type = MaterialType::Dielectric;
  m.roughness = alpha;
  m.ior = 1.5f;
  return m;
}

TEST(Shift, HalfVectorCopyJacobianMatchesFiniteDifferencesReflection) {
  const Material m = glossy_conductor(0.03f);
  const Vec3 wo = normalize(Vec3(0.3f, -0.2f, 0.9f)), wo_off = normalize(Vec3(0.45f, -0.1f, 0.85f));
  const Vec3 wi = normalize(Vec3(-0.35f, 0.25f, 0.88f));
  const DirectionShift s = shift_half_vector(Bsdf(m), wo, wi, wo_off);
  ASSERT_TRUE(s.ok());
  const double fd = fd_jacobian(wi, [&](const Vec3& w) { return shift_half_vector(Bsdf(m), wo, w, wo_off).wi; });
  EXPECT_NEAR(s.jacobian, fd, 2e-3 * fd);
  EXPECT_NE(s.jacobian, 1.0);  // the test would not notice a missing Jacobian otherwise
}

TEST(Shift, HalfVectorCopyJacobianMatchesFiniteDifferencesRefraction) {
  const Material m = rough_glass(0.03f);
  for (float side : {1.0f, -1.0f}) {  // from outside and from inside the glass
    const Vec3 wo = normalize(Vec3(0.3f, -0.2f, 0.9f * side)), wo_off = normalize(Vec3(0.4f, -0.05f, 0.88f * side));
    const Vec3 wi = normalize(Vec3(-0.2f, 0.15f, -0.95f * side));
    const DirectionShift s = shift_half_vector(Bsdf(m), wo, wi, wo_off);
    ASSERT_TRUE(s.ok()) << "side " << side;
    EXPECT_LT(s.wi.z * wo_off.z, 0) << "refraction stays refraction";
    const double fd = fd_jacobian(wi, [&](const Vec3& w) { return shift_half_vector(Bsdf(m), wo, w, wo_off).wi; });
    EXPECT_NEAR(s.jacobian, fd, 3e-3 * fd) << "side " << side;
  }
}

TEST(Shift, HalfVectorCopyReportsTotalInternalReflection) {
  // From inside the glass, an offset wo' far from the normal cannot refract about h.
  const Material m = rough_glass(0.03f);
  const Vec3 wo = normalize(Vec3(0.05f, 0, -1)), wi = normalize(Vec3(-0.05f, 0, 1));
  const DirectionShift s = shift_half_vector(Bsdf(m), wo, wi, normalize(Vec3(0.9f, 0, -0.3f)));
  EXPECT_EQ(s.failure, ShiftFailure::TotalInternalReflection);
  EXPECT_EQ(failure_stat_name(s.failure), "shift failed: total internal reflection");
}

// Where a ray from o along w meets the plane through q with normal n.
Vec3 hit_plane(const Vec3& o, const Vec3& w, const Vec3& q, const Vec3& n) {
  return o + w * (dot(q - o, n) / dot(w, n));
}

TEST(Shift, ReconnectionJacobianMatchesFiniteDifferences) {
  // Base vertex x, offset vertex x', the base's next vertex on a tilted diffuse plane.
  const Vec3 x(0, 0, 0), xo(0.15f, -0.05f, 0.02f), q0(0.3f, 0.2f, 1.4f), n = normalize(Vec3(0.2f, -0.1f, -1));
  const Vec3 w = normalize(q0 - x);
  const ReconnectShift r = shift_reconnect(x, xo, q0, n);
  ASSERT_TRUE(r.ok());
  const double fd = fd_jacobian(w, [&](const Vec3& v) { return normalize(hit_plane(x, v, q0, n) - xo); });
  EXPECT_NEAR(r.jacobian, fd, 2e-3 * fd);
}

TEST(Shift, HalfVectorCopyThenReconnectionJacobianIsTheProductOfBoth) {
  // Camera-side vertices x1 (base) and x1' (offset) on a glossy plane z = 0; the base reflects
  // towards x2 on a diffuse wall, and from x2 towards x3 on a diffuse floor. The offset copies
  // the half-vector at x1', lands on the wall at x2', and reconnects to x3. The joint map
  // (omega_1, omega_2) -> (omega_1', omega_2') is block-triangular; its 4x4 determinant by
  // finite differences must equal J_half * J_reconnect of the shift functions.
  const Material m = glossy_conductor(0.03f);
  const Vec3 cam(0, -2, 1.5f), cam_off(0.02f, -2, 1.5f);
  const Vec3 x1(0, 0, 0), x1o = hit_plane(cam_off, normalize(x1 - cam + Vec3(0.1f, 0, 0)), x1, Vec3(0, 0, 1));
  const Vec3 wall_q(0, 2, 0), wall_n(0, -1, 0), floor_q(0, 0, -1), floor_n(0, 0, 1);
  const Vec3 wo = normalize(cam - x1), wo_off = normalize(cam_off - x1o);  // local = world (normal +z)
  const Vec3 w1 = normalize(Vec3(0.1f, 1, 0.7f)), w2 = normalize(Vec3(-0.2f, -0.5f, -1));
  auto joint = [&](const Vec3& a, const Vec3& b, Vec3* a_off, Vec3* b_off) {
    const DirectionShift hv = shift_half_vector(Bsdf(m), wo, a, wo_off);
    const Vec3 x2 = hit_plane(x1, a, wall_q, wall_n), x2o = hit_plane(x1o, hv.wi, wall_q, wall_n);
    const Vec3 x3 = hit_plane(x2, b, floor_q, floor_n);
    *a_off = hv.wi;
    *b_off = normalize(x3 - x2o);
    return hv.jacobian * shift_reconnect(x2, x2o, x3, floor_n).jacobian;
  };
  Vec3 a_off, b_off;
  const double analytic = joint(w1, w2, &a_off, &b_off);
  // 4x4 finite-difference Jacobian in tangent coordinates of the input and output spheres.
  const SphereChart in1(w1), in2(w2), out1(a_off), out2(b_off);
  const double h = 1e-3;
  double J[4][4];
  for (int k = 0; k < 4; ++k) {
    Vec3 p1, p2, m1, m2;
    const double da = k == 0 ? h : 0, db = k == 1 ? h : 0, dc = k == 2 ? h : 0, dd = k == 3 ? h : 0;
    joint(in1.at(da, db), in2.at(dc, dd), &p1, &p2);
    joint(in1.at(-da, -db), in2.at(-dc, -dd), &m1, &m2);
    const Vec3 d1 = (p1 - m1) / float(2 * h), d2 = (p2 - m2) / float(2 * h);
    J[0][k] = dot(d1, out1.t1);
    J[1][k] = dot(d1, out1.t2);
    J[2][k] = dot(d2, out2.t1);
    J[3][k] = dot(d2, out2.t2);
  }
  // Determinant by Gaussian elimination with partial pivoting.
  double det = 1;
  for (int c = 0; c < 4; ++c) {
    int piv = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::abs(J[r][c]) > std::abs(J[piv][c])) piv = r;
    if (piv != c) {
      std::swap(J[piv], J[c]);
      det = -det;
    }
    det *= J[c][c];
    for (int r = c + 1; r < 4; ++r) {
      const double f = J[r][c] / J[c][c];
      for (int k = c; k < 4; ++k) J[r][k] -= f * J[c][k];
    }
  }
  EXPECT_NEAR(std::abs(det), analytic, 5e-3 * analytic);
}

// ---- The integrator ----

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

Scene cornell(int size, bool glossy_box = false) {
  auto j = nlohmann::json::parse(read_text(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-box.json"));
  if (glossy_box) {  // the paper's Figure 4 setting: a Cornell box with a glossy object
    j["materials"]["glossy"] = {{"type", "conductor"}, {"color", {0.9, 0.8, 0.6}}, {"roughness", 0.02}};
    for (auto& o : j["objects"])
      if (o["name"] == "tall box") o["material"] = "glossy";
  }
  j["camera"]["width"] = size;
  j["camera"]["height"] = size;
  return load_scene_from_string(j.dump(), std::string(GRADPHOTON_SOURCE_DIR) + "/scenes", "cornell.json");
}

std::unique_ptr<Integrator> run(const Scene& s, const std::string& method, int passes, uint64_t seed,
                                int threads = 0, const std::string& recon = "l2", int rr_depth = 3) {
  Params p;
  p.set("seed", seed);
  p.set("rr_depth", rr_depth);
  p.set("threads", threads);
  if (method == "gpt") p.set("recon", recon);
  // gpt's base paths take pt's independent stream (PrimalIsThePathTracersImage...: the same numbers).
  if (method == "pt") p.set("sampling_pattern", "independent");
  auto integ = make_integrator(method, s, p);
  if (passes > 0) run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  return integ;
}

double rel_mse(const Film& a, std::string_view pass, const Film& ref) {
  return diff_images(a.pass(pass), ref.pass(pass::kCombined), a.width(), a.height()).rel_mse;
}

TEST(GradientPathTracer, ConvergesToThePathTracedReference) {
  const Scene s = cornell(24);
  Film ref, gpt;
  run(s, "pt", 3000, 99)->develop(ref);
  auto g = run(s, "gpt", 300, 1);
  g->develop(gpt);
  const DiffResult d = diff_images(gpt.pass(pass::kCombined), ref.pass(pass::kCombined), 24, 24);
  // 300 GPT passes against a 3000-pass reference: the reference's own noise is ~1e-3 here.
  EXPECT_LT(d.rel_mse, 6e-3);
  EXPECT_NEAR(d.mean_ratio, 1.0, 0.02);
  for (const char* key : {"shift failed: occluded", "shift failed: not invertible"})
    EXPECT_GT(g->stats().extra.count(key), 0u) << key;
}

TEST(GradientPathTracer, ReconstructionErrorFallsBelowThePrimalErrorWithAGlossyObject) {
  // Gradient-domain photon density estimation, Figure 4: the L2 reconstruction's error falls
  // as passes grow and stays below the primal (throughput) error. The glossy box (GGX alpha
  // 0.02 < 0.05) makes offsets copy half-vectors before reconnecting.
  const Scene s = cornell(24, true);
  Film ref;
  run(s, "pt", 4000, 77)->develop(ref);
  auto g = run(s, "gpt", 0, 3);
  std::vector<double> recon_err, primal_err;
  for (int target : {8, 32, 128}) {
    run_progressive(*g, StopRule{0, target, 0}, nullptr);
    Film f;
    g->develop(f);
    recon_err.push_back(rel_mse(f, pass::kCombined, ref));
    primal_err.push_back(rel_mse(f, pass::kPrimal, ref));
    std::printf("passes %d: recon %.4g primal %.4g\n", target, recon_err.back(), primal_err.back());
  }
  EXPECT_LT(recon_err[1], 0.6 * recon_err[0]);
  EXPECT_LT(recon_err[2], 0.6 * recon_err[1]);
  // Fixed seed: measured recon/primal ratios 0.88 / 0.67 / 0.72 at 8 / 32 / 128 passes (about
  // 0.5 at 32x32 and 512 passes); fireflies of the glossy box in the relMSE keep this far from
  // Figure 4's 10x.
  EXPECT_LT(recon_err[0], primal_err[0]);
  for (int i = 1; i < 3; ++i)
    EXPECT_LT(recon_err[i], 0.85 * primal_err[i]) << "checkpoint " << i << ": recon " << recon_err[i] << " primal "
                                                   << primal_err[i];
  EXPECT_GT(g->stats().extra.count("shift failed: not invertible") + g->stats().extra.count("shift failed: zero length"),
            0u);
}

TEST(GradientPathTracer, FlatLitDiffusePlaneHasZeroGradients) {
  // A diffuse plane under a uniform sky is uniformly bright; shifted paths see the same sky
  // directions with the same cosines, so every gradient is zero up to round-off.
  const Scene s = load_scene_from_string(R"({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 30, "width": 16, "height": 16},
    "materials": {"grey": {"type": "diffuse", "color": 0.4}},
    "environment": {"color": 2.0},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [50, 0, 0], "v": [0, 50, 0], "material": "grey"}]})",
                                         ".", "plane.json");
  auto g = run(s, "gpt", 8, 5);
  Film f;
  g->develop(f);
  float worst = 0, mean = 0;
  for (float v : f.pass(pass::kGradientX).data) worst = std::max(worst, std::abs(v));
  for (float v : f.pass(pass::kGradientY).data) worst = std::max(worst, std::abs(v));
  for (float v : f.pass(pass::kPrimal).data) mean += v / f.pass(pass::kPrimal).data.size();
  EXPECT_NEAR(mean, 0.8, 0.05);
  EXPECT_LT(worst, 1e-5 * mean);
}

TEST(GradientPathTracer, SameImageWhateverTheThreadCountAndFinite) {
  Scene s = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-glass.json");
  s.camera.width = 20;
  s.camera.height = 16;
  for (const char* recon : {"l2", "l1"}) {
    Film one, two;
    run(s, "gpt", 3, 42, 1, recon)->develop(one);
    run(s, "gpt", 3, 42, 2, recon)->develop(two);
    for (auto name : {pass::kCombined, pass::kPrimal, pass::kGradientX, pass::kGradientY}) {
      EXPECT_EQ(one.pass(name).data, two.pass(name).data) << recon << " " << name;
      for (float v : one.pass(name).data) ASSERT_TRUE(std::isfinite(v)) << name;
    }
  }
}

TEST(GradientPathTracer, PrimalIsThePathTracersImageAndL2OfThePassesIsCombined) {
  const Scene s = cornell(16);
  Film pt, g;
  // Without Russian roulette: pt decides it at the next hit (Cycles' placement, camera_path.h),
  // gpt's base path right after each scatter, so their random numbers part there.
  run(s, "pt", 4, 11, 0, "l2", 1000)->develop(pt);
  run(s, "gpt", 4, 11, 0, "l2", 1000)->develop(g);
  const auto& a = g.pass(pass::kPrimal).data;
  const auto& b = pt.pass(pass::kCombined).data;
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-5f * (1 + std::abs(b[i])));
  // The gradient passes include the direct light's differences: reconstructing the primal pass
  // with them gives the combined pass.
  const auto rec = screened_poisson(a, g.pass(pass::kGradientX).data, g.pass(pass::kGradientY).data, 16, 16, 3);
  const auto& comb = g.pass(pass::kCombined).data;
  for (size_t i = 0; i < rec.size(); ++i) ASSERT_NEAR(rec[i], comb[i], 1e-4f * (1 + std::abs(comb[i])));
}

TEST(GradientPathTracer, RejectsBadParameters) {
  const Scene s = cornell(8);
  Params bad_recon(nlohmann::json{{"recon", "l3"}});
  EXPECT_THROW(make_integrator("gpt", s, bad_recon), ParamError);
  Params bad_lambda(nlohmann::json{{"lambda", 0}});
  EXPECT_THROW(make_integrator("gpt", s, bad_lambda), ParamError);
  Params typo(nlohmann::json{{"lamda", 0.3}});
  make_integrator("gpt", s, typo);
  EXPECT_EQ(typo.unused(), std::vector<std::string>{"lamda"});
}

}  // namespace
}  // namespace gp
