// Spectral gradient sampling: the eq. 13 Jacobian against finite differences, the 1D screened
// Poisson reconstruction (eq. 14) against known spectra, and sgpt / spt-hero against a long
// spt reference on the prism scene.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <tuple>

#include "core/rng.h"
#include "core/sampling.h"
#include "integrators/integrator.h"
#include "integrators/methods.h"
#include "integrators/spectral/sgpt.h"
#include "integrators/shift/spectral_shift.h"
#include "reconstruction/spectral_poisson.h"
#include "scene/loader.h"

namespace gp {
namespace {

// Solid angle spanned by the images of a small patch around w, over the patch's own.
template <typename Map>
double finite_difference_jacobian(const Vec3& w, Map&& map) {
  const Vec3 t1 = normalize(std::abs(w.z) < 0.9f ? cross(w, Vec3(0, 0, 1)) : cross(w, Vec3(1, 0, 0)));
  const Vec3 t2 = cross(w, t1);
  const float eps = 2e-3f;
  const Vec3 a = normalize(w + t1 * eps), b = normalize(w + t2 * eps);
  const Vec3 m0 = map(w), ma = map(a), mb = map(b);
  const double base = std::abs(dot(cross(a - w, b - w), w));
  const double image = std::abs(dot(cross(ma - m0, mb - m0), m0));
  return image / base;
}

TEST(SpectralShift, RefractionJacobianMatchesFiniteDifferences) {
  // A rough dispersive interface: base at n = 1.52, offset at n = 1.56 (another wavelength).
  // The base's wi varies; the half vector follows (eq. 12) and is copied to the offset.
  struct Case {
    Vec3 wo, wo_offset;
  };
  const Case cases[] = {
      {normalize(Vec3(0.3f, -0.2f, 0.9f)), normalize(Vec3(0.3f, -0.2f, 0.9f))},     // first divergence
      {normalize(Vec3(0.3f, -0.2f, 0.9f)), normalize(Vec3(0.25f, -0.1f, 0.95f))},   // diverged offset
      {normalize(Vec3(-0.2f, 0.4f, -0.8f)), normalize(Vec3(-0.25f, 0.35f, -0.85f))},  // from inside
  };
  for (const Case& c : cases) {
    const Etas e = dielectric_etas(1.52f, c.wo.z, true), e2 = dielectric_etas(1.56f, c.wo_offset.z, true);
    // A refracted direction of wo through a tilted microfacet.
    const Vec3 m = normalize(Vec3(0.1f, 0.05f, 1.0f));
    const auto wi = copy_half_vector(c.wo, m, e, true);
    ASSERT_TRUE(wi.has_value());
    const auto h = half_vector(c.wo, *wi, e, true);
    ASSERT_TRUE(h.has_value());
    EXPECT_NEAR(dot(*h, m), 1.0f, 1e-4f);  // eq. 12 recovers the microfacet
    const auto wi2 = copy_half_vector(c.wo_offset, *h, e2, true);
    ASSERT_TRUE(wi2.has_value());
    const float J = half_vector_jacobian(c.wo, *wi, e, c.wo_offset, *wi2, e2, *h, true);
    const double fd = finite_difference_jacobian(*wi, [&](const Vec3& w) {
      const Vec3 hw = *half_vector(c.wo, w, e, true);
      return *copy_half_vector(c.wo_offset, hw, e2, true);
    });
    EXPECT_NEAR(J, fd, 2e-2 * fd) << "wo " << c.wo.x << " " << c.wo.y << " " << c.wo.z;
    EXPECT_GT(std::abs(J - 1.0), 1e-3) << "the test should exercise a non-trivial Jacobian";
  }
}

TEST(SpectralShift, ReflectionJacobianMatchesFiniteDifferences) {
  const Vec3 wo = normalize(Vec3(0.3f, -0.2f, 0.9f)), wo2 = normalize(Vec3(0.1f, 0.3f, 0.8f));
  const Vec3 wi = normalize(Vec3(-0.5f, 0.1f, 0.7f));
  const auto h = half_vector(wo, wi, Etas{}, false);
  const auto wi2 = copy_half_vector(wo2, *h, Etas{}, false);
  ASSERT_TRUE(wi2.has_value());
  const float J = half_vector_jacobian(wo, wi, Etas{}, wo2, *wi2, Etas{}, *h, false);
  const double fd = finite_difference_jacobian(wi, [&](const Vec3& w) {
    return *copy_half_vector(wo2, *half_vector(wo, w, Etas{}, false), Etas{}, false);
  });
  EXPECT_NEAR(J, fd, 2e-2 * fd);
}

TEST(SpectralPoisson, ExactInputsAreAFixedPoint) {
  // A smooth spectrum and its exact cyclic gradients: the minimiser of eq. 14 is the spectrum.
  const int B = 15, s = 2;
  std::vector<double> I(B), G(B);
  for (int j = 0; j < B; ++j) I[j] = 1.0 + 0.5 * std::sin(0.7 * j) + 0.1 * j;
  for (int j = 0; j < B; ++j) G[j] = I[(j + s) % B] - I[j];
  const SpectralPoisson p(B, s, 0.2);
  const auto r = p.solve(I, G);
  for (int j = 0; j < B; ++j) EXPECT_NEAR(r[j], I[j], 1e-9) << j;
}

TEST(SpectralPoisson, ExactGradientsRecoverTheSpectrumFromANoisyPrimal) {
  // With exact gradients the shape is determined (the cyclic stride-2 difference on 15 bins has
  // only constants in its null space): the reconstruction filters zero-mean primal noise, keeps
  // the primal's total (eq. 14 preserves the sum), and as alpha -> 0 leaves only the noise mean.
  const int B = 15, s = 2;
  std::vector<double> truth(B), noisy(B), G(B);
  Rng rng(3, 0);
  for (int j = 0; j < B; ++j) truth[j] = 2.0 + std::cos(0.4 * j);
  double noise_mean = 0, noisy_err = 0, noisy_sum = 0;
  for (int j = 0; j < B; ++j) {
    const double n = (rng.uniform() - 0.5) * 1.0;
    noisy[j] = truth[j] + n;
    noise_mean += n / B;
    noisy_err += n * n;
    noisy_sum += noisy[j];
  }
  for (int j = 0; j < B; ++j) G[j] = truth[(j + s) % B] - truth[j];
  const auto r = SpectralPoisson(B, s, 0.2).solve(noisy, G);
  double err = 0, sum = 0;
  for (int j = 0; j < B; ++j) {
    err += (r[j] - truth[j]) * (r[j] - truth[j]);
    sum += r[j];
  }
  EXPECT_LT(err, 0.3 * noisy_err);
  EXPECT_NEAR(sum, noisy_sum, 1e-9);
  const auto r0 = SpectralPoisson(B, s, 1e-7).solve(noisy, G);
  for (int j = 0; j < B; ++j) EXPECT_NEAR(r0[j], truth[j] + noise_mean, 1e-5) << j;
}

TEST(SpectralPoisson, RejectsBadSetups) {
  EXPECT_THROW(SpectralPoisson(15, 0, 0.2), std::invalid_argument);
  EXPECT_THROW(SpectralPoisson(15, 15, 0.2), std::invalid_argument);
  EXPECT_THROW(SpectralPoisson(15, 2, 0.0), std::invalid_argument);
}

// scenes/prism.json made test-friendly: a wider slit and light (lower variance), small image.
Scene test_prism() {
  std::ifstream in(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/prism.json");
  std::stringstream ss;
  ss << in.rdbuf();
  nlohmann::json j = nlohmann::json::parse(ss.str());
  for (auto& o : j["objects"]) {
    const std::string name = o["name"];
    if (name == "strip light") o["u"] = {0, 0.1, 0};
    if (name == "tunnel left" || name == "tunnel right") o["center"][1] = o["center"][1].get<double>() * 2.4;
    if (name == "tunnel top" || name == "tunnel bottom" || name == "tunnel back")
      for (const char* key : {"u", "v"})
        if (o[key][1].get<double>() != 0) o[key][1] = o[key][1].get<double>() * 2.4;
  }
  j["materials"]["light"]["strength"] = 16;
  j["camera"]["width"] = 24;
  j["camera"]["height"] = 18;
  return load_scene_from_string(j.dump(), std::string(GRADPHOTON_SOURCE_DIR) + "/scenes", "prism.json");
}

RGB mean_of(const Scene& s, const std::string& method, int passes, uint64_t seed) {
  Params p;
  p.set("seed", seed);
  p.set("max_depth", 6);  // no Russian roulette: its rare, heavy paths would dominate the noise
  p.set("rr_depth", 6);
  auto integ = make_integrator(method, s, p);
  run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  Film f;
  integ->develop(f);
  double m[3] = {0, 0, 0};
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x)
      for (int k = 0; k < 3; ++k) m[k] += f.rgb(pass::kCombined, x, y)[k];
  const double n = double(f.width()) * f.height();
  return RGB(float(m[0] / n), float(m[1] / n), float(m[2] / n));
}

TEST(Sgpt, ConvergesToTheSptReferenceOnThePrism) {
  const Scene s = test_prism();
  const RGB ref = mean_of(s, "spt", 8192, 11);
  const RGB hero = mean_of(s, "spt-hero", 2048, 12);
  const RGB sg = mean_of(s, "sgpt", 2048, 13);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(hero[c] / ref[c], 1.0, 0.05) << "spt-hero channel " << c;
    EXPECT_NEAR(sg[c] / ref[c], 1.0, 0.05) << "sgpt channel " << c;
  }
}

// E[G_j] = E[I_{j+s}] - E[I_j], a z-test per bin on image totals: every pass is an independent
// sample (per-pixel streams keyed by seed, pixel and pass), so the per-pass values of
// D_j = G_j - I_{j+s} + I_j give a mean and a standard error; |mean| must stay below
// z_max standard errors and below `tol` of the largest bin (the bias a test can see). Returns
// the largest |z|.
double check_gradients(const Scene& s, Params p, int passes, double tol, const std::string& what, double z_max = 4.0,
                       std::array<int, 4> region = {0, 0, -1, -1}) {
  SpectralGradientPathTracer sg(s, find_method("sgpt").bind(p));
  const int B = sg.bins(), st = sg.stride();
  std::vector<double> sum(B, 0.0), sum2(B, 0.0), prev_d(B, 0.0), I, G;
  for (int k = 1; k <= passes; ++k) {
    sg.iterate(nullptr);
    sg.image_totals(&I, &G, region[0], region[1], region[2], region[3]);
    for (int j = 0; j < B; ++j) {
      const double d = (G[j] - I[(j + st) % B] + I[j]) * k;  // cumulative sum of D_j
      const double x = d - prev_d[j];                         // this pass's D_j
      prev_d[j] = d;
      sum[j] += x;
      sum2[j] += x * x;
    }
  }
  double scale = 0, worst_z = 0;
  for (int j = 0; j < B; ++j) scale = std::max(scale, I[j]);
  for (int j = 0; j < B; ++j) {
    const double mean = sum[j] / passes;
    const double se = std::sqrt(std::max(0.0, sum2[j] / passes - mean * mean) / (passes - 1));
    if (!(std::isfinite(mean) && std::isfinite(se) && se > 0)) {  // NaN/Inf never pass
      ADD_FAILURE() << what << " bin " << j << ": mean " << mean << " se " << se;
      return kInfinity;
    }
    const double z = mean / se;
    worst_z = std::max(worst_z, std::abs(z));
    EXPECT_LT(std::abs(z), z_max) << what << " bin " << j << ": E[G] - dE[I] = " << mean << " +- " << se
                                  << " (max I " << scale << ")";
    EXPECT_LT(std::abs(mean), tol * scale) << what << " bin " << j;
  }
  EXPECT_GT(sg.stats().extra.at("shifted pairs"), 0) << what;
  return worst_z;
}

// A smooth or rough flint sphere (B = 0.03 um^2) on a coloured floor, size x size pixels; `lamp`
// is the material of a 1 x 1 m emitter 2 m up facing down ("" for none), `extra` more top-level
// JSON (",\"environment\": ..." or lights).
Scene sphere_on_floor(int size, float roughness, const std::string& lamp, const std::string& extra) {
  const std::string n = std::to_string(size);
  return load_scene_from_string(
      R"({"camera": {"position": [0, -1.6, 1.0], "look_at": [0, 0, 0.3], "fov": 40, "width": )" + n +
          R"(, "height": )" + n + R"(},
    "materials": {"floor": {"type": "diffuse", "color": [0.8, 0.7, 0.5]},
                  "glass": {"type": "dielectric", "ior": 1.6, "cauchy_b": 0.03, "roughness": )" +
          std::to_string(roughness) + "}" + (lamp.empty() ? "" : R"(, "light": )" + lamp) + R"(},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "floor"},
                {"type": "sphere", "center": [0, 0, 0.45], "radius": 0.4, "segments": 24, "material": "glass"})" +
          (lamp.empty() ? "" : R"(,
                {"type": "quad", "center": [0, 0, 2], "u": [0, 1, 0], "v": [1, 0, 0], "material": "light"})") +
          "]" + extra + "}",
      ".", "sphere.json");
}

TEST(Sgpt, GradientsMatchPrimalDifferencesThroughDispersiveGlass) {
  // E[G_j] = E[I_{j+s}] - E[I_j]: checked on image totals, where the shift runs through smooth
  // and rough dispersive refraction, half-vector copies, reconnections and next-event
  // estimation; for one wavelength per path (§3) and for four (the hero combination of §3.4,
  // eq. 17-18).
  for (auto [rough, wavelengths] : {std::pair{0.0f, 1}, {0.15f, 1}, {0.0f, 4}, {0.15f, 4}}) {
    const Scene s = sphere_on_floor(16, rough, R"({"type": "emission", "emission": [1, 0.9, 0.8], "strength": 2})",
                                    R"(, "environment": {"color": [0.1, 0.2, 0.4]})");
    Params p;
    p.set("seed", 21);
    p.set("max_depth", 8);
    p.set("rr_depth", 8);
    p.set("wavelengths", wavelengths);
    check_gradients(s, p, 1024, 0.04, "roughness " + std::to_string(rough) + " wavelengths " + std::to_string(wavelengths));
  }
}

TEST(Sgpt, GradientsNeedTheReconnectionJacobian) {
  // A floor seen through a thick, smooth, strongly dispersive slab (B = 0.08 um^2) and lit by a
  // small light 2 cm above it, under the slab. The offsets' floor points lie up to about a
  // centimetre from the base's (dispersion across 30 cm of glass), and both connect to the same
  // light point by NEE (or to the same next vertex): the reconnection Jacobian ([KMA*15] §5.2,
  // cos / d^2 at the shared vertex, offset over base) is far from 1 near the light. Summed over
  // the whole image its effect nearly cancels (J - 1 integrates a derivative of the
  // irradiance), so the z-test uses the half of the image beyond the light (rows 0-7). Measured: with the Jacobian, largest |z| over the 15 bins 1.85; with it replaced by 1,
  // E[G] - dE[I] reaches 28 % of the largest bin, |z| = 9.8.
  const Scene s = load_scene_from_string(
      R"({"camera": {"position": [0, -0.55, 0.75], "look_at": [0, 0, 0], "fov": 22, "width": 16, "height": 16},
    "materials": {"floor": {"type": "diffuse", "color": 0.8},
                  "glass": {"type": "dielectric", "ior": 1.6, "cauchy_b": 0.08, "roughness": 0},
                  "light": {"type": "emission", "emission": 1, "strength": 50}},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "floor"},
                {"type": "box", "min": [-0.6, -0.6, 0.05], "max": [0.6, 0.6, 0.35], "material": "glass"},
                {"type": "quad", "center": [0, 0, 0.02], "u": [0, 0.02, 0], "v": [0.02, 0, 0], "material": "light"}]})",
      ".", "slab.json");
  Params p;
  p.set("seed", 5);
  p.set("max_depth", 8);
  const double z = check_gradients(s, p, 3072, 1.0, "slab", 4.0, {0, 0, 16, 8});
  std::cout << "slab: largest |z| of E[G] - dE[I] over the bins = " << z << "\n";
}

TEST(SpectralShift, ReconnectionJacobianMatchesFiniteDifferences) {
  // The base leaves x along w and hits the plane through x' with normal n; the offset at y
  // reconnects to the same point. |d w_y / d w| against finite differences.
  const Vec3 x(0, 0, 0), y(0.03f, -0.02f, 0.01f), n = normalize(Vec3(0.2f, 0.1f, -1.0f));
  const Vec3 plane_p(0.05f, 0.02f, 0.06f);
  auto hit = [&](const Vec3& w) { return x + w * (dot(plane_p - x, n) / dot(w, n)); };
  const Vec3 w = normalize(Vec3(0.4f, 0.1f, 1.0f));
  const Vec3 xn = hit(w);
  const double fd = finite_difference_jacobian(w, [&](const Vec3& v) { return normalize(hit(v) - y); });
  const float J = reconnection_jacobian<float>(x, y, xn, n);
  EXPECT_NEAR(J, fd, 2e-2 * fd);
  EXPECT_GT(std::abs(J - 1.0), 0.2) << "the test should exercise a Jacobian far from 1";
}

// An sgpt render of `passes` passes, developed into *film.
std::unique_ptr<Integrator> render_sgpt(const Scene& s, const Params& p, int passes, Film* film) {
  auto integ = make_integrator("sgpt", s, p);
  run_progressive(*integ, StopRule{0, passes, 0}, nullptr);
  integ->develop(*film);
  return integ;
}

TEST(Sgpt, ColouredFurnaceAndPasses) {
  const Scene s = load_scene_from_string(
      R"({"camera": {"position": [0, -3, 0], "look_at": [0, 0, 0], "fov": 40, "width": 12, "height": 12},
    "materials": {"white": {"type": "diffuse", "color": 1}},
    "environment": {"color": [0.5, 1.0, 2.0], "strength": 1},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "segments": 32, "material": "white"}]})",
      ".", "furnace.json");
  for (int wavelengths : {1, 4}) {
    Params p;
    p.set("seed", 4);
    p.set("wavelengths", wavelengths);
    Film f;
    const auto integ = render_sgpt(s, p, 512, &f);
    ASSERT_TRUE(f.has_pass(pass::kSpectralPrimal));
    ASSERT_TRUE(f.has_pass(pass::kSpectralGradient));
    double m[3] = {0, 0, 0};
    for (int y = 0; y < f.height(); ++y)
      for (int x = 0; x < f.width(); ++x)
        for (int k = 0; k < 3; ++k) m[k] += f.rgb(pass::kCombined, x, y)[k] / (f.width() * f.height());
    EXPECT_NEAR(m[0], 0.5, 0.015);
    EXPECT_NEAR(m[1], 1.0, 0.03);
    EXPECT_NEAR(m[2], 2.0, 0.06);
    EXPECT_GT(integ->stats().extra.at("shifted pairs"), 0);
  }
}

TEST(Sgpt, TauComparesPathContributions) {
  // Eq. 15-16: a pair is shifted only when both paths' contributions f exceed tau, otherwise its
  // gradient is sampled in the standard way. Two white emitters fill the view, radiance 1 (left)
  // and 4 (right); camera paths end on them, so f = 1 or 4 at every wavelength and an offset's
  // f equals its base's. With tau = 2 the right half is shifted, and its gradients are exactly 0
  // (f(y) - f(x) = 0), while the left half falls back to standard sampling (+-f / p per sample:
  // non-zero). (Compared against f / p, as before, both halves would be shifted.) tau = 0.5
  // shifts both, tau = 8 neither; the image means stay 1 and 4 in every case.
  const Scene s = load_scene_from_string(
      R"({"camera": {"position": [0, -3, 0], "look_at": [0, 0, 0], "fov": 20, "width": 16, "height": 16},
    "materials": {"dim": {"type": "emission", "emission": 1, "strength": 1},
                  "bright": {"type": "emission", "emission": 1, "strength": 4}},
    "objects": [{"type": "quad", "center": [-0.5, 0, 0], "u": [0.5, 0, 0], "v": [0, 0, 1], "material": "dim"},
                {"type": "quad", "center": [0.5, 0, 0], "u": [0.5, 0, 0], "v": [0, 0, 1], "material": "bright"}]})",
      ".", "emitters.json");
  for (double tau : {0.5, 2.0, 8.0}) {
    Params p;
    p.set("seed", 3);
    p.set("tau", tau);
    Film f;
    const auto integ = render_sgpt(s, p, 256, &f);
    for (const auto& [x0, x1, radiance] : {std::tuple{0, 7, 1.0}, std::tuple{9, 16, 4.0}}) {
      const bool shifted = radiance > tau;
      double mean = 0, g_max = 0;
      for (int y = 0; y < 16; ++y)
        for (int x = x0; x < x1; ++x) {
          const RGB c = f.rgb(pass::kCombined, x, y);
          mean += (c[0] + c[1] + c[2]) / 3 / (16.0 * (x1 - x0));
          g_max = std::max(g_max, double(f.pass(pass::kSpectralGradient).data[y * 16 + x]));
        }
      if (shifted)
        EXPECT_EQ(g_max, 0.0) << "tau " << tau << ", radiance " << radiance << ": shifted pairs of equal f";
      else
        EXPECT_GT(g_max, 0.1 * radiance) << "tau " << tau << ", radiance " << radiance << ": standard sampling";
      EXPECT_NEAR(mean, radiance, 0.02 * radiance) << "tau " << tau;
    }
    const auto& extra = integ->stats().extra;
    if (tau > 4) EXPECT_EQ(extra.at("shifted pairs"), 0);
    if (tau < 1) EXPECT_EQ(extra.at("standard pairs"), 0);
    if (tau == 2.0) {
      EXPECT_GT(extra.at("shifted pairs"), 0);
      EXPECT_GT(extra.at("standard pairs"), 0);
    }
  }
}

// Mean and standard error of a method's image mean (average of R, G, B over the image), from
// the per-pass values recovered from the cumulative images (passes are independent samples).
struct MeanSe {
  double mean = 0, se = 0;
  bool finite = true;
};
MeanSe image_mean(const Scene& s, const std::string& method, Params p, int passes) {
  auto integ = make_integrator(method, s, p);
  double prev = 0, sum = 0, sum2 = 0;
  MeanSe r;
  for (int k = 1; k <= passes; ++k) {
    integ->iterate(nullptr);
    Film f;
    integ->develop(f);
    double m = 0;
    for (int y = 0; y < f.height(); ++y)
      for (int x = 0; x < f.width(); ++x) {
        const RGB c = f.rgb(pass::kCombined, x, y);
        r.finite &= c.is_finite();
        m += (c[0] + c[1] + c[2]) / 3.0;
      }
    m = m / (double(f.width()) * f.height()) * k;
    const double v = m - prev;  // this pass's image mean
    prev = m;
    sum += v;
    sum2 += v * v;
  }
  r.mean = sum / passes;
  r.se = std::sqrt(std::max(0.0, sum2 / passes - r.mean * r.mean) / (passes - 1));
  r.finite &= std::isfinite(r.mean) && std::isfinite(r.se);
  return r;
}

// z-test of two methods' image means (seeds `seed` and seed + 1), |z| < 4 and within `rel`.
void expect_same_mean(const Scene& s, const std::string& a, const std::string& b, Params p, int passes,
                      uint64_t seed, double rel, const std::string& what, double se_ratio_max = 0) {
  p.set("seed", seed);
  const MeanSe ma = image_mean(s, a, p, passes);
  p.set("seed", seed + 1);
  const MeanSe mb = image_mean(s, b, p, passes);
  ASSERT_TRUE(ma.finite && mb.finite) << what;  // NaN/Inf never pass
  const double z = (ma.mean - mb.mean) / std::hypot(ma.se, mb.se);
  std::cout << what << ": " << a << " " << ma.mean << " +- " << ma.se << ", " << b << " " << mb.mean << " +- " << mb.se
            << ", z " << z << "\n";
  EXPECT_LT(std::abs(z), 4.0) << what;
  EXPECT_NEAR(ma.mean / mb.mean, 1.0, rel) << what;
  if (se_ratio_max > 0) EXPECT_LT(ma.se, se_ratio_max * mb.se) << what << ": a heavy tail is back";
}

TEST(Sgpt, LineSpectrumLightStaysFiniteAndUnbiased) {
  // The spiky-illuminant case (§4): a mercury lamp (five 4 nm lines) over a floor with a rough
  // dispersive sphere. Most sampled wavelengths miss the lines and the offsets, 62.7 nm away,
  // nearly always do: sgpt falls back to standard sampling for those pairs (f(y) = 0 <= tau).
  // The image stays finite and its mean agrees with spt's (z-test of the two image means, each
  // with its standard error from per-pass values; |z| < 4 and within 5 %).
  const Scene s =
      sphere_on_floor(12, 0.15f, R"({"type": "emission", "spectrum": {"preset": "mercury", "fwhm": 4}, "strength": 3})", "");
  Params p;
  p.set("max_depth", 8);
  expect_same_mean(s, "sgpt", "spt", p, 4096, 31, 0.05, "mercury");
}

TEST(Sgpt, PointAndSunLightsAreReachedByNee) {
  // Delta lights exist for sgpt only through next-event estimation: the offsets connect to the
  // same light position (point) or direction (sun), with no Jacobian. Image mean against spt,
  // and E[G] = dE[I]. The mean over 8192 passes: standard errors 0.29 % (sgpt) and 0.55 % (spt,
  // whose caustics through the rough sphere are the noisy part), 0.6 % on the ratio, so the 3 %
  // bound is 5 of them (over 1024 passes it was 1.7: spt's Sobol pattern moved its mean at the
  // old seed and the ratio read 0.965, z -2.0). Measured: 0.989 (z -1.7); seeds 201-202 over
  // 16384 passes 0.9988, seeds 101-102 over 8192 0.990; over 65536 passes sgpt 0.18190, spt
  // 0.18254 (Sobol) and 0.18172 (independent), standard errors 0.1 % and 0.2 %: no bias.
  const Scene s = sphere_on_floor(12, 0.15f, "", R"(, "lights": [
      {"type": "point", "position": [0.3, -0.2, 1.5], "power": 30, "color": [1, 0.9, 0.7]},
      {"type": "sun", "direction": [0.3, 0.4, -1], "strength": 1}])");
  Params p;
  p.set("max_depth", 8);
  expect_same_mean(s, "sgpt", "spt", p, 8192, 51, 0.03, "point and sun");
  p.set("seed", 53);
  std::cout << "point and sun: largest |z| of E[G] - dE[I] = " << check_gradients(s, p, 1024, 0.15, "point and sun gradients") << "\n";
}

// A rough flint sphere on a floor that is a Mix of a diffuse and a rough Glossy, under a lamp and
// a sky with the switches `lamp_keys` and `world_keys` (Light::visible_lobes): offsets leave
// their base at the sphere's dispersive refractions and meet the lamp and the sky from floor
// points of their own, where both lobes see a light, one lobe or none. `extra`: more top-level
// JSON.
Scene sphere_on_mixed_floor(int size, const std::string& lamp_keys, const std::string& world_keys,
                            const std::string& extra = "") {
  const std::string n = std::to_string(size);
  return load_scene_from_string(
      R"({"camera": {"position": [0, -1.6, 1.0], "look_at": [0, 0, 0.3], "fov": 40, "width": )" + n +
          R"(, "height": )" + n + R"(},
    "materials": {"d": {"type": "diffuse", "color": [0.9, 0.15, 0.05]},
                  "g": {"type": "conductor", "color": [0.05, 0.3, 0.9], "roughness": 0.3, "fresnel": false},
                  "floor": {"type": "mix", "a": "d", "b": "g", "factor": 0.5},
                  "glass": {"type": "dielectric", "ior": 1.6, "cauchy_b": 0.03, "roughness": 0.15},
                  "light": {"type": "emission", "emission": [1, 0.9, 0.8], "strength": 2)" + lamp_keys + R"(}},
    "environment": {"color": [0.1, 0.2, 0.4])" + world_keys + R"(},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "floor"},
                {"type": "sphere", "center": [0, 0, 0.45], "radius": 0.4, "segments": 24, "material": "glass"},
                {"type": "quad", "center": [0.3, 0, 1.6], "u": [0, 1, 0], "v": [1, 0, 0], "material": "light"}])" +
          extra + "}",
      ".", "mixed_floor.json");
}

TEST(Sgpt, HonoursTheLightsSwitchesAtTheBaseAndTheOffsets) {
  // The lamp hidden from diffuse rays (it lights the floor's glossy lobe and what the sphere
  // refracts) and the sky from glossy rays (it lights the floor's diffuse lobe by Cycles' rule
  // for the World, lobe_split.h). The base: the image mean against spt's (z-test, |z| < 4, within
  // 3 %: 5 standard errors of the ratio; the switches move spt's mean by -30 %). Measured: 1.0076
  // (z 1.3); over 8192 passes (seeds 101-102) 1.002, each channel within 0.5 %. With the lights'
  // rule for the World (f_V, next-event estimation; sgpt's before) 0.975 (z -4.1; over 8192
  // passes 0.970, R +9.3 %, B -9.7 %); before issue 14, lights lighting every lobe, 1.339 (z 52).
  // With the World still sampled by next-event estimation too, 1.059 (z 9.6). The offsets: E[G] = dE[I] per bin
  // (|z| < 4, within 4 % of the largest bin), which needs each offset to weigh the light it meets
  // at its own floor point by the lobes that see it, with the base's lobe sampled (an offset is
  // the base path until the sphere); the colours are saturated because a wrong offset biases
  // E[G] by about half the spectral difference of its error. Measured: largest |z| 1.3, 2.4,
  // 2.9 (seeds 63, 73, 83); with the offsets' lights lighting every lobe 6.5 (bins 5-7).
  const Scene s = sphere_on_mixed_floor(16, R"(, "visible_to_diffuse": false)", R"(, "visible_to_glossy": false)");
  EXPECT_TRUE(s.light_set().lights().size() > 1);
  Params p;
  p.set("max_depth", 8);
  p.set("rr_depth", 8);
  expect_same_mean(s, "sgpt", "spt", p, 1024, 61, 0.03, "lamp hidden from diffuse, sky from glossy");
  p.set("seed", 63);
  std::cout << "lights' switches: largest |z| of E[G] - dE[I] = "
            << check_gradients(s, p, 1024, 0.04, "lights' switches gradients") << "\n";
  // Delta lights, reached by next-event estimation only: a point light hidden from glossy rays
  // and a sun hidden from diffuse rays light one lobe of the floor each. Measured: 0.993 of spt
  // (z -0.6; against 4096 passes of spt, seeds 201-202: 0.98-1.00); with f_V left out for Dirac
  // lights (the point and the sun lit nothing) 0.858, z -8.2 (512 passes).
  const Scene delta = sphere_on_mixed_floor(12, "", "", R"(, "lights": [
      {"type": "point", "position": [0.3, -0.2, 1.5], "power": 30, "color": [1, 0.9, 0.7], "visible_to_glossy": false},
      {"type": "sun", "direction": [0.3, 0.4, -1], "strength": 1, "visible_to_diffuse": false}])");
  expect_same_mean(delta, "sgpt", "spt", p, 1024, 65, 0.04, "point hidden from glossy, sun from diffuse");
}

TEST(Sgpt, LightObjectsAreCrossedAsSptCrossesThem) {
  // A Blender area light is a pass-through emitter that casts no shadow (docs/blender.md): a
  // BSDF ray that crosses it and finds the sky behind is weighed against next-event estimation
  // from the vertex that sent it, which sees the sky through the light too. A floor under a
  // large light object and a sky: the image mean against spt's (z-test, |z| < 4, within 2 %).
  // Measured 1.000; before issue 14, 1.114 (the sky through the light counted with weight 1 by
  // the ray and again by NEE). Then the same through a dispersive sphere, where offsets cross
  // the light on their own: E[G] = dE[I].
  const std::string lamp =
      R"({"type": "dielectric", "ior": 1, "emission": 1, "strength": 0.5, "visible_to_camera": false, "casts_shadow": false})";
  const Scene floor = load_scene_from_string(
      R"({"camera": {"position": [0, -2, 1.5], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 50, "width": 12, "height": 12},
    "materials": {"floor": {"type": "diffuse", "color": 0.6}, "lamp": )" + lamp + R"(},
    "environment": {"color": 1, "strength": 1},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [2, 0, 0], "v": [0, 2, 0], "material": "floor"},
                {"type": "quad", "center": [0, 0, 0.5], "u": [0, 1.5, 0], "v": [1.5, 0, 0], "material": "lamp"}]})",
      ".", "light_object.json");
  Params p;
  p.set("max_depth", 5);
  expect_same_mean(floor, "sgpt", "spt", p, 1024, 71, 0.02, "light object over a floor under a sky");
  const Scene sphere = sphere_on_floor(12, 0.15f, lamp, R"(, "environment": {"color": [0.1, 0.2, 0.4]})");
  p.set("max_depth", 8);
  p.set("rr_depth", 8);
  p.set("seed", 73);
  std::cout << "light object: largest |z| of E[G] - dE[I] = " << check_gradients(sphere, p, 1024, 0.04, "light object")
            << "\n";
}

Scene small_pool(int w, int h) {
  std::ifstream in(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/pool.json");
  std::stringstream ss;
  ss << in.rdbuf();
  nlohmann::json j = nlohmann::json::parse(ss.str());
  j["camera"]["width"] = w;
  j["camera"]["height"] = h;
  return load_scene_from_string(j.dump(), std::string(GRADPHOTON_SOURCE_DIR) + "/scenes", "pool.json");
}

TEST(Sgpt, PoolImageMeanMatchesSptHero) {
  // Bias or heavy tail (docs/spectral.md): sgpt's image mean on pool against spt-hero's, a
  // z-test with each mean's standard error from its per-pass values, fixed seeds, |z| < 4.
  // Before roulette acted on the compensated throughput, sgpt's per-pass means had skew 20-123
  // and a standard error 6-15x this one's: unbiased, but heavy-tailed.
  expect_same_mean(small_pool(24, 18), "sgpt", "spt-hero", Params(), 2048, 41, 0.05, "pool", 3.0);
}

TEST(Sgpt, ParametersAreValidated) {
  const Scene s = test_prism();
  auto make = [&](const char* k, nlohmann::json v) {
    Params p;
    p.set(k, v);
    return make_integrator("sgpt", s, p);
  };
  EXPECT_THROW(make("bins", 2), ParamError);
  EXPECT_THROW(make("delta", 0.0), ParamError);
  EXPECT_THROW(make("tau", -1.0), ParamError);
  EXPECT_THROW(make("wavelengths", 9), ParamError);
  EXPECT_NO_THROW(make("bins", 30));
}

TEST(Sgpt, ConnectableFollowsTheMaterialsLobes) {
  // Reconnection needs a lobe the offset can evaluate at a new direction pair: any diffuse lobe,
  // or a glossy one at least as rough as the specular threshold, and no dispersion.
  auto mat = [](MaterialType type, float roughness, float cauchy_b = 0) {
    Material m;
    m.type = type;
    m.roughness = roughness;
    m.cauchy_b = cauchy_b;
    return m;
  };
  EXPECT_TRUE(connectable(mat(MaterialType::Diffuse, 0)));
  EXPECT_TRUE(connectable(mat(MaterialType::Emission, 0)));
  // A smooth coat or specular lobe beside a diffuse one: still connectable (its diffuse lobe).
  for (float r : {0.0f, 0.01f, 0.3f}) {
    EXPECT_TRUE(connectable(mat(MaterialType::Principled, r))) << r;
    EXPECT_TRUE(connectable(mat(MaterialType::Plastic, r))) << r;
  }
  EXPECT_FALSE(connectable(mat(MaterialType::Conductor, 0)));
  EXPECT_FALSE(connectable(mat(MaterialType::Conductor, 0.01f)));
  EXPECT_TRUE(connectable(mat(MaterialType::Conductor, 0.3f)));
  EXPECT_FALSE(connectable(mat(MaterialType::Dielectric, 0)));
  EXPECT_TRUE(connectable(mat(MaterialType::Dielectric, 0.3f)));
  EXPECT_FALSE(connectable(mat(MaterialType::Dielectric, 0.3f, 0.01f)));  // dispersive
  // A mix: by its parts; without them (made by hand) it scatters as a diffuse surface.
  Material mix = mat(MaterialType::Mix, 0);
  EXPECT_TRUE(connectable(mix));
  mix.mix_a = std::make_shared<Material>(mat(MaterialType::Conductor, 0));
  mix.mix_b = std::make_shared<Material>(mat(MaterialType::Dielectric, 0));
  EXPECT_FALSE(connectable(mix));
  mix.mix_b = std::make_shared<Material>(mat(MaterialType::Principled, 0));
  EXPECT_TRUE(connectable(mix));
}

}  // namespace
}  // namespace gp
