// Tests of materials/bsdf: chi-square goodness of fit of every non-delta sampler against its
// own pdf (after pbrt-v4's src/pbrt/bsdfs_test.cpp and Mitsuba 3's chi2.py), sample/eval
// consistency, reciprocity, Fresnel energy conservation and white-furnace albedo bounds.
#include "materials/bsdf.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <functional>
#include <mutex>
#include <numeric>
#include <string>
#include <vector>

#include "core/frame.h"
#include "core/parallel.h"
#include "core/rng.h"
#include "chi2.h"

namespace gp {
namespace {

// ============================================================================================
// Chi-square goodness-of-fit helper
// ============================================================================================

// Adaptive Simpson quadrature with Richardson extrapolation and Lyness's stopping rule, as in
// pbrt-v4's bsdfs_test.cpp.
double adaptive_simpson(const std::function<double(double)>& f, double x0, double x1, double eps,
                        int max_depth) {
  auto integrate = [&](auto&& self, double a, double b, double c, double fa, double fb, double fc,
                       double whole, double tol, int depth) -> double {
    const double d = 0.5 * (a + b), e = 0.5 * (b + c);
    const double fd = f(d), fe = f(e);
    const double h = c - a;
    const double left = h / 12 * (fa + 4 * fd + fb), right = h / 12 * (fb + 4 * fe + fc);
    const double both = left + right;
    if (depth <= 0 || std::abs(both - whole) < 15 * tol) return both + (both - whole) / 15;
    return self(self, a, d, b, fa, fd, fb, left, tol / 2, depth - 1) +
           self(self, b, e, c, fb, fe, fc, right, tol / 2, depth - 1);
  };
  const double a = x0, b = 0.5 * (x0 + x1), c = x1;
  const double fa = f(a), fb = f(b), fc = f(c);
  return integrate(integrate, a, b, c, fa, fb, fc, (c - a) / 6 * (fa + 4 * fb + fc), eps,
                   max_depth);
}

// Nested adaptive Simpson over [x0,x1] x [y0,y1]. The rectangle is first cut into k x k panels
// so that a lobe narrower than a bin cannot slip between the first few nodes.
double integrate_2d(const std::function<double(double, double)>& f, double x0, double x1, double y0,
                    double y1, double eps, int k = 4, int max_depth = 6) {
  double sum = 0;
  const double dx = (x1 - x0) / k, dy = (y1 - y0) / k;
  // Half of each panel's share of eps for the outer integral, half for the inner ones (an
  // inner error e adds e dy to the outer integral).
  const double panel_eps = 0.5 * eps / (k * k);
  for (int j = 0; j < k; ++j) {
    const double ya = y0 + j * dy, yb = ya + dy;
    for (int i = 0; i < k; ++i) {
      const double xa = x0 + i * dx, xb = xa + dx;
      auto inner = [&](double y) {
        return adaptive_simpson([&](double x) { return f(x, y); }, xa, xb, panel_eps / dy,
                                max_depth);
      };
      sum += adaptive_simpson(inner, ya, yb, panel_eps, max_depth);
    }
  }
  return sum;
}

// The sphere of directions binned uniformly in (cos theta, phi): equal solid angle per bin and
// a unit Jacobian, d omega = d cos(theta) d phi.
constexpr int kCosThetaRes = 20;
constexpr int kPhiRes = 40;
constexpr int kSamples = 400000;
constexpr double kMinExpected = 5;
constexpr double kSignificance = 0.01;

Vec3 direction(double cos_theta, double phi) {
  const double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  return {static_cast<float>(sin_theta * std::cos(phi)),
          static_cast<float>(sin_theta * std::sin(phi)), static_cast<float>(cos_theta)};
}

int bin_of(const Vec3& w) {
  const double c = clamp(w.z, -1.0f, 1.0f);
  double phi = std::atan2(static_cast<double>(w.y), static_cast<double>(w.x));
  if (phi < 0) phi += 2 * M_PI;
  const int ci = std::min(static_cast<int>((c + 1) * 0.5 * kCosThetaRes), kCosThetaRes - 1);
  const int pi = std::min(static_cast<int>(phi / (2 * M_PI) * kPhiRes), kPhiRes - 1);
  return ci * kPhiRes + pi;
}


using Sampler = std::function<std::optional<BsdfSample>(float uc, Vec2 u)>;
using Density = std::function<float(const Vec3& wi)>;

// Draws kSamples directions from `sample` (called from several threads), histograms the
// non-delta ones, integrates `pdf` over every bin for the expected counts, pools bins with
// expected < 5 (pbrt-v4's Chi2Test) and returns Pearson's statistic with its p-value. Samples
// that do not come back (below the horizon, TIR) form one more cell, expected where the pdf
// integrates to less than one, so the cells' counts sum to kSamples and dof = cells - 1 holds.
Chi2Result chi2_test(const Sampler& sample, const Density& pdf, uint64_t seed) {
  constexpr int kBins = kCosThetaRes * kPhiRes;
  constexpr int kChunk = 1 << 14;
  constexpr int kChunks = (kSamples + kChunk - 1) / kChunk;

  // ---- Observed counts: fixed chunks with their own streams, so any thread count agrees ----
  std::vector<double> observed(kBins, 0.0);
  size_t accepted = 0;
  std::mutex merge;
  parallel_for(kChunks, 0, [&](size_t begin, size_t end) {
    for (size_t chunk = begin; chunk < end; ++chunk) {
      Rng rng = Rng::for_key(seed, chunk, 0x5eed);
      std::vector<double> local(kBins, 0.0);
      size_t local_accepted = 0;
      const int n = std::min<int>(kChunk, kSamples - static_cast<int>(chunk) * kChunk);
      for (int i = 0; i < n; ++i) {
        const float uc = rng.uniform();
        const Vec2 u(rng.uniform(), rng.uniform());
        const auto s = sample(uc, u);
        if (!s || s->delta) continue;
        local[bin_of(s->wi)] += 1;
        ++local_accepted;
      }
      std::lock_guard lock(merge);
      for (int b = 0; b < kBins; ++b) observed[b] += local[b];
      accepted += local_accepted;
    }
  });

  // ---- Expected counts: the pdf integrated over each bin ----
  std::vector<double> expected(kBins, 0.0);
  const double dc = 2.0 / kCosThetaRes, dphi = 2 * M_PI / kPhiRes;
  parallel_for(kBins, 0, [&](size_t begin, size_t end) {
    for (size_t b = begin; b < end; ++b) {
      const int ci = static_cast<int>(b) / kPhiRes, pi = static_cast<int>(b) % kPhiRes;
      const double c0 = -1 + ci * dc, phi0 = pi * dphi;
      auto f = [&](double phi, double c) { return static_cast<double>(pdf(direction(c, phi))); };
      // Absolute tolerance 1e-8 per bin: ~0.004 counts at 4e5 samples.
      expected[b] = integrate_2d(f, phi0, phi0 + dphi, c0, c0 + dc, 1e-8) * kSamples;
    }
  });

  Chi2Result r;
  r.pdf_integral = std::accumulate(expected.begin(), expected.end(), 0.0) / kSamples;
  r.accepted_fraction = static_cast<double>(accepted) / kSamples;

  // The cell of samples that did not come back.
  observed.push_back(static_cast<double>(kSamples - accepted));
  expected.push_back(std::max(0.0, kSamples - r.pdf_integral * kSamples));

  pearson_pooled(observed, expected, kMinExpected, r);
  return r;
}

// ============================================================================================
// Cases
// ============================================================================================

Material make(MaterialType type, float alpha, RGB color = RGB(1.0f), float ior = 1.5f) {
  Material m;
  m.type = type;
  m.roughness = alpha;
  m.color = color;
  m.ior = ior;
  return m;
}

// wo at the given cos(theta) (negative: below the surface) and a fixed, off-axis azimuth.
Vec3 wo_at(float cos_theta_o, float phi = 0.7f) {
  const float s = safe_sqrt(1 - cos_theta_o * cos_theta_o);
  return {s * std::cos(phi), s * std::sin(phi), cos_theta_o};
}

struct Chi2Case {
  std::string name;
  Material material;
  Vec3 wo;
};

constexpr float kCosThetaO[] = {0.9f, 0.5f, 0.15f};

std::vector<Chi2Case> diffuse_cases() {
  std::vector<Chi2Case> cases;
  for (float c : kCosThetaO)
    cases.push_back(
        {fmt::format("diffuse cos_o={}", c), make(MaterialType::Diffuse, 0, RGB(0.7f)), wo_at(c)});
  cases.push_back({"diffuse from below cos_o=-0.5", make(MaterialType::Diffuse, 0), wo_at(-0.5f)});
  return cases;
}

std::vector<Chi2Case> conductor_cases() {
  std::vector<Chi2Case> cases;
  for (float alpha : {0.05f, 0.2f, 0.6f})
    for (float c : kCosThetaO)
      cases.push_back({fmt::format("conductor alpha={} cos_o={}", alpha, c),
                       make(MaterialType::Conductor, alpha, RGB(0.9f, 0.6f, 0.3f)), wo_at(c)});
  cases.push_back({"conductor from below alpha=0.2 cos_o=-0.5",
                   make(MaterialType::Conductor, 0.2f, RGB(0.9f)), wo_at(-0.5f)});
  Material metal = make(MaterialType::Conductor, 0.2f, RGB(0.9f, 0.6f, 0.3f), 1.5f);  // Principled's metal
  metal.conductor_fresnel = ConductorFresnel::Principled;
  cases.push_back({"principled metal alpha=0.2 cos_o=0.5", metal, wo_at(0.5f)});
  // Blender's Glossy BSDF distributions other than GGX (Cycles 3.4's f, sampled by the half
  // vector's own density).
  for (Microfacet d : {Microfacet::Beckmann, Microfacet::AshikhminShirley})
    for (float alpha : {0.1f, 0.4f})
      for (float c : kCosThetaO) {
        Material g = make(MaterialType::Conductor, alpha, RGB(0.9f, 0.6f, 0.3f));
        g.conductor_fresnel = ConductorFresnel::None;
        g.distribution = d;
        cases.push_back({fmt::format("{} alpha={} cos_o={}", d == Microfacet::Beckmann ? "beckmann" : "ashikhmin-shirley",
                                     alpha, c), g, wo_at(c)});
      }
  return cases;
}

std::vector<Chi2Case> dielectric_cases() {
  std::vector<Chi2Case> cases;
  for (float alpha : {0.1f, 0.3f, 0.7f})
    for (float ior : {1.33f, 1.5f, 2.0f})
      for (float side : {1.0f, -1.0f})
        for (float c : kCosThetaO)
          cases.push_back({fmt::format("dielectric alpha={} ior={} {} cos_o={}", alpha, ior,
                                       side > 0 ? "outside" : "inside", c),
                           make(MaterialType::Dielectric, alpha, RGB(1.0f), ior), wo_at(side * c)});
  // Beckmann glass and refraction (Blender's Glass / Refraction BSDF Beckmann: Cycles 3.4's D and
  // separable rational G1, half vectors drawn by D cos).
  for (float alpha : {0.1f, 0.4f})
    for (bool refraction : {false, true})
      for (float side : {1.0f, -1.0f})
        for (float c : kCosThetaO) {
          // Refraction from inside away from the normal is mostly total internal reflection,
          // which the Refraction BSDF absorbs: too few samples for the test there.
          if (refraction && side < 0 && c < 0.9f) continue;
          Material g = make(MaterialType::Dielectric, alpha, RGB(1.0f), 1.5f);
          g.distribution = Microfacet::Beckmann;
          g.refraction_only = refraction;
          cases.push_back({fmt::format("beckmann {} alpha={} {} cos_o={}", refraction ? "refraction" : "glass", alpha,
                                       side > 0 ? "outside" : "inside", c),
                           g, wo_at(side * c)});
        }
  return cases;
}

Material plastic(float alpha, RGB color = RGB(0.6f, 0.3f, 0.1f), float ior = 1.5f) {
  Material m = make(MaterialType::Plastic, alpha, color, ior);
  prepare_material(m);
  return m;
}

Material mix(const Material& a, const Material& b, float factor, bool add = false) {
  Material m;
  m.type = MaterialType::Mix;
  m.mix_a = std::make_shared<Material>(a);
  m.mix_b = std::make_shared<Material>(b);
  m.mix_factor = factor;
  m.mix_add = add;
  return m;
}

std::vector<Chi2Case> plastic_cases() {
  std::vector<Chi2Case> cases;
  for (float alpha : {0.0f, 0.05f, 0.3f, 0.8f})
    for (float c : kCosThetaO)
      cases.push_back({fmt::format("plastic alpha={} cos_o={}", alpha, c), plastic(alpha), wo_at(c)});
  cases.push_back({"plastic from below alpha=0.3 cos_o=-0.5", plastic(0.3f, RGB(0.9f), 1.8f), wo_at(-0.5f)});
  return cases;
}

// Cycles' Principled BSDF (non-metal): smooth, nearly smooth, rough specular lobes; a base of
// each brightness so both lobes get picked.
std::vector<Chi2Case> principled_cases() {
  std::vector<Chi2Case> cases;
  for (float alpha : {0.0f, 0.05f, 0.25f, 0.8f})
    for (float c : kCosThetaO)
      cases.push_back({fmt::format("principled alpha={} cos_o={}", alpha, c),
                       make(MaterialType::Principled, alpha, RGB(0.6f, 0.3f, 0.1f)), wo_at(c)});
  cases.push_back({"principled from below alpha=0.3 cos_o=-0.5", make(MaterialType::Principled, 0.3f, RGB(0.9f)),
                   wo_at(-0.5f)});
  return cases;
}

// Mix and Add of lobes the scenes combine: diffuse + rough metal, rough metal + rough glass (a
// transmission lobe), smooth glass + diffuse (a Dirac lobe beside a smooth one), mix of mixes.
std::vector<Chi2Case> mix_cases() {
  const Material diffuse = make(MaterialType::Diffuse, 0, RGB(0.7f));
  const Material metal = make(MaterialType::Conductor, 0.2f, RGB(0.9f, 0.6f, 0.3f));
  const Material glass = make(MaterialType::Dielectric, 0.3f, RGB(1.0f), 1.5f);
  const Material smooth_glass = make(MaterialType::Dielectric, 0.0f, RGB(1.0f), 1.5f);
  std::vector<Chi2Case> cases;
  for (float c : {0.9f, 0.3f, -0.5f}) {
    cases.push_back({fmt::format("mix diffuse+metal 0.3 cos_o={}", c), mix(diffuse, metal, 0.3f), wo_at(c)});
    cases.push_back({fmt::format("mix metal+glass 0.6 cos_o={}", c), mix(metal, glass, 0.6f), wo_at(c)});
    cases.push_back({fmt::format("add diffuse+smooth glass cos_o={}", c), mix(diffuse, smooth_glass, 0, true), wo_at(c)});
    cases.push_back({fmt::format("mix of mix and plastic cos_o={}", c),
                     mix(mix(diffuse, metal, 0.5f), plastic(0.3f), 0.4f), wo_at(c)});
  }
  return cases;
}

// Cycles 3.4's further closures: Oren-Nayar (Diffuse BSDF with Roughness), Translucent, Velvet,
// Refraction (smooth and rough, from both sides: the inside at grazing angles meets total
// internal reflection), and a Transparent BSDF (a delta lobe) mixed with diffuse parts.
Material refraction(float alpha, float ior = 1.5f) {
  Material m = make(MaterialType::Dielectric, alpha, RGB(0.9f, 0.8f, 0.7f), ior);
  m.refraction_only = true;
  return m;
}
Material transparent(RGB color) { return make(MaterialType::Dielectric, 0.0f, color, 1.0f); }

std::vector<Chi2Case> closure_cases() {
  std::vector<Chi2Case> cases;
  for (float sigma : {0.5f, 1.0f})
    for (float c : {0.9f, 0.3f, -0.5f})
      cases.push_back({fmt::format("oren-nayar sigma={} cos_o={}", sigma, c),
                       make(MaterialType::Diffuse, sigma, RGB(0.7f)), wo_at(c)});
  for (float c : {0.8f, -0.4f})
    cases.push_back({fmt::format("translucent cos_o={}", c), make(MaterialType::Translucent, 0, RGB(0.6f)), wo_at(c)});
  for (float sigma : {0.3f, 1.0f})
    for (float c : {0.9f, 0.4f, -0.6f})
      cases.push_back({fmt::format("velvet sigma={} cos_o={}", sigma, c), make(MaterialType::Velvet, sigma, RGB(0.8f)),
                       wo_at(c)});
  for (float alpha : {0.1f, 0.3f})
    for (float c : {0.9f, 0.4f, -0.9f, -0.75f})  // -0.75: near the critical angle (0.745), half TIR
      cases.push_back({fmt::format("refraction alpha={} cos_o={}", alpha, c), refraction(alpha), wo_at(c)});
  const Material diffuse = make(MaterialType::Diffuse, 0.8f, RGB(0.7f));
  for (float c : {0.7f, -0.4f}) {
    cases.push_back({fmt::format("mix transparent+oren-nayar cos_o={}", c),
                     mix(transparent(RGB(1, 0.2f, 0.2f)), diffuse, 0.6f), wo_at(c)});
    cases.push_back({fmt::format("add translucent+velvet cos_o={}", c),
                     mix(make(MaterialType::Translucent, 0, RGB(0.3f)), make(MaterialType::Velvet, 0.5f, RGB(0.4f)), 0,
                         true),
                     wo_at(c)});
  }
  return cases;
}

// Cycles 3.4's Principled lobes beyond the base: the clearcoat closure (GTR1, from Blender's
// default alpha 0.0009 to 1, from both sides), a principled with sheen and specular tint, and
// a principled plus clearcoat (how the exporter adds them).
Material clearcoat(float alpha, float weight = 1.0f) {
  Material m = make(MaterialType::Clearcoat, alpha);
  m.clearcoat = weight;
  return m;
}
Material principled_lobes(float alpha, float sheen, float sheen_tint, float specular_tint) {
  Material m = make(MaterialType::Principled, alpha, RGB(0.6f, 0.3f, 0.1f));
  m.sheen = sheen;
  m.sheen_tint = sheen_tint;
  m.specular_tint = specular_tint;
  return m;
}
std::vector<Chi2Case> principled_lobe_cases() {
  std::vector<Chi2Case> cases;
  for (float alpha : {0.0009f, 0.05f, 0.3f, 1.0f})
    for (float c : {0.9f, 0.3f, -0.5f})
      cases.push_back({fmt::format("clearcoat alpha={} cos_o={}", alpha, c), clearcoat(alpha), wo_at(c)});
  for (float c : {0.9f, 0.2f, -0.5f}) {
    cases.push_back({fmt::format("principled sheen+tint alpha=0.25 cos_o={}", c), principled_lobes(0.25f, 1.0f, 0.5f, 1.0f),
                     wo_at(c)});
    cases.push_back({fmt::format("principled + clearcoat cos_o={}", c),
                     mix(principled_lobes(0.2f, 0.5f, 0.0f, 0.5f), clearcoat(0.01f), 0, true), wo_at(c)});
  }
  return cases;
}

// Anisotropic lobes (Cycles' Anisotropic BSDF: GGX and Beckmann; Principled's specular lobe),
// stretched along x and along y, seen off the axes.
Material anisotropic(MaterialType type, Microfacet d, float alpha, float an) {
  Material m = make(type, alpha, RGB(0.9f, 0.6f, 0.3f));
  m.conductor_fresnel = ConductorFresnel::None;
  m.distribution = d;
  m.anisotropy = an;
  return m;
}
std::vector<Chi2Case> anisotropic_cases() {
  std::vector<Chi2Case> cases;
  for (Microfacet d : {Microfacet::GGX, Microfacet::Beckmann})
    for (float an : {0.7f, -0.5f})
      for (float c : {0.9f, 0.4f, -0.6f})
        cases.push_back({fmt::format("anisotropic {} an={} cos_o={}", d == Microfacet::GGX ? "ggx" : "beckmann", an, c),
                         anisotropic(MaterialType::Conductor, d, 0.3f, an), wo_at(c)});
  for (float c : {0.8f, 0.3f})
    cases.push_back({fmt::format("principled anisotropic cos_o={}", c),
                     anisotropic(MaterialType::Principled, Microfacet::GGX, 0.2f, -0.6f), wo_at(c)});
  return cases;
}

// Number of chi-square tests in this file, for the Sidak correction of the significance level.
const size_t kNumChi2Tests = diffuse_cases().size() + conductor_cases().size() + dielectric_cases().size() +
                             plastic_cases().size() + principled_cases().size() + mix_cases().size() +
                             closure_cases().size() + principled_lobe_cases().size() + anisotropic_cases().size();

double sidak_alpha() {
  return 1 - std::pow(1 - kSignificance, 1.0 / static_cast<double>(kNumChi2Tests));
}

// Relative difference, with an absolute floor `abs_floor` below which values count as equal:
// near-back-facing microfacets give |wi.wm| ~ 0, where float cancellation leaves tiny values
// with large relative noise (typical BSDF values are 0.1..100).
float rel_diff(float a, float b, float abs_floor = 1e-12f) {
  const float scale = std::max(std::abs(a), std::abs(b));
  return scale < 1e-12f ? 0.0f : std::max(0.0f, std::abs(a - b) - abs_floor) / scale;
}
float rel_diff(const RGB& a, const RGB& b, float abs_floor = 1e-12f) {
  return std::max({rel_diff(a.r, b.r, abs_floor), rel_diff(a.g, b.g, abs_floor),
                   rel_diff(a.b, b.b, abs_floor)});
}

// Runs the chi-square test of one case and checks, for every 4th sample (to save time), that
// sample() returns the f (in both transport modes) and pdf that eval() and pdf() give at the
// sampled wi.
void check_case(const Chi2Case& c, uint64_t seed) {
  SCOPED_TRACE(c.name);
  const Bsdf bsdf(c.material);
  std::atomic<size_t> mismatches{0}, samples{0};
  const Sampler sampler = [&](float uc, Vec2 u) {
    auto s = bsdf.sample(c.wo, uc, u, TransportMode::Radiance);
    // Rng::uniform() is (24 random bits) * 2^-24, so the low bits of u.y pick a fair subset.
    if (!s || s->delta || (static_cast<uint32_t>(u.y * 0x1p24f) & 3u) != 0) return s;
    ++samples;
    const auto s_imp = bsdf.sample(c.wo, uc, u, TransportMode::Importance);
    const float tol = 2e-3f;  // float round-off of the recomputed half vector
    const bool ok = s_imp && s_imp->wi.x == s->wi.x && s_imp->wi.y == s->wi.y &&
                    s_imp->wi.z == s->wi.z && s_imp->pdf == s->pdf &&
                    rel_diff(s->pdf, bsdf.pdf(c.wo, s->wi)) < tol &&
                    rel_diff(s->f, bsdf.eval(c.wo, s->wi, TransportMode::Radiance)) < tol &&
                    rel_diff(s_imp->f, bsdf.eval(c.wo, s->wi, TransportMode::Importance)) < tol &&
                    s->f.is_finite() && std::isfinite(s->pdf) && s->pdf > 0;
    if (!ok) ++mismatches;
    return s;
  };
  const Density density = [&](const Vec3& wi) { return bsdf.pdf(c.wo, wi); };
  const Chi2Result r = chi2_test(sampler, density, seed);

  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_GT(samples.load(), kSamples / 40u);
  // A few samples may disagree at the float noise floor (grazing half vectors); pbrt-v4's
  // tests accept the same order of slack.
  EXPECT_LE(mismatches.load(), samples.load() / 10000) << "sample() disagrees with eval()/pdf()";
  EXPECT_LE(r.pdf_integral, 1.0 + 1e-3);
  EXPECT_NEAR(r.pdf_integral, r.accepted_fraction, 5e-3)
      << "pdf mass differs from the fraction of samples returned";
  EXPECT_LE(r.zero_expected_hits, kSamples / 100000u) << "samples where the pdf is zero";
  EXPECT_GE(r.p_value, sidak_alpha())
      << "chi2 = " << r.statistic << ", dof = " << r.dof << ", p = " << r.p_value;
}

// ============================================================================================
// Tests
// ============================================================================================

TEST(Chi2Helper, IncompleteGammaMatchesClosedForms) {
  for (double x : {0.01, 0.5, 1.0, 3.0, 10.0, 40.0}) {
    EXPECT_NEAR(gamma_q(1.0, x), std::exp(-x), 1e-12);             // Q(1, x) = e^-x
    EXPECT_NEAR(gamma_q(0.5, x), std::erfc(std::sqrt(x)), 1e-12);  // Q(1/2, x) = erfc
    // Integer a: Q(k, x) = e^-x sum_{j<k} x^j / j!.
    double term = 1, sum = 0;
    for (int j = 0; j < 5; ++j) {
      sum += term;
      term *= x / (j + 1);
    }
    EXPECT_NEAR(gamma_q(5.0, x), std::exp(-x) * sum, 1e-12);
  }
  // Chi-square with 100 dof at 100 and at 200 (reference values from mpmath.gammainc).
  EXPECT_NEAR(gamma_q(50.0, 50.0), 0.481191684527957, 1e-12);
  EXPECT_NEAR(gamma_q(50.0, 100.0) / 1.17845007209794e-8, 1.0, 1e-9);
}

TEST(Chi2Helper, RejectsMismatchedPdf) {
  // The test has power: samples from GGX alpha = 0.2 against the pdf of alpha = 0.21, and rough
  // glass of IOR 1.5 against the pdf of IOR 1.45, must both be rejected.
  const Vec3 wo = wo_at(0.5f);
  const Material m_sample = make(MaterialType::Conductor, 0.2f);
  const Material m_pdf = make(MaterialType::Conductor, 0.21f);
  const Bsdf bs(m_sample), bp(m_pdf);
  const Chi2Result r = chi2_test([&](float uc, Vec2 u) { return bs.sample(wo, uc, u); },
                                 [&](const Vec3& wi) { return bp.pdf(wo, wi); }, 1);
  EXPECT_LT(r.p_value, sidak_alpha());

  const Material g_sample = make(MaterialType::Dielectric, 0.3f, RGB(1.0f), 1.5f);
  const Material g_pdf = make(MaterialType::Dielectric, 0.3f, RGB(1.0f), 1.45f);
  const Bsdf gs(g_sample), gpdf(g_pdf);
  const Chi2Result rg = chi2_test([&](float uc, Vec2 u) { return gs.sample(wo, uc, u); },
                                  [&](const Vec3& wi) { return gpdf.pdf(wo, wi); }, 2);
  EXPECT_LT(rg.p_value, sidak_alpha());
}

TEST(BsdfChi2, Diffuse) {
  uint64_t seed = 100;
  for (const auto& c : diffuse_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, RoughConductor) {
  uint64_t seed = 200;
  for (const auto& c : conductor_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, RoughDielectric) {
  uint64_t seed = 300;
  for (const auto& c : dielectric_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, Plastic) {
  uint64_t seed = 400;
  for (const auto& c : plastic_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, Principled) {
  uint64_t seed = 450;
  for (const auto& c : principled_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, MixAndAdd) {
  uint64_t seed = 500;
  for (const auto& c : mix_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, CyclesClosures) {
  uint64_t seed = 600;
  for (const auto& c : closure_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, Anisotropic) {
  uint64_t seed = 800;
  for (const auto& c : anisotropic_cases()) check_case(c, seed++);
}

TEST(BsdfChi2, PrincipledClearcoatSheenTint) {
  uint64_t seed = 700;
  for (const auto& c : principled_lobe_cases()) check_case(c, seed++);
}

// ---- Reciprocity ----

// Uniform directions on the sphere from a fixed stream.
Vec3 random_direction(Rng& rng) {
  const float z = 1 - 2 * rng.uniform();
  const float r = safe_sqrt(1 - z * z), phi = 2 * kPi * rng.uniform();
  return {r * std::cos(phi), r * std::sin(phi), z};
}

TEST(BsdfReciprocity, DiffuseAndRoughConductor) {
  Rng rng(7, 0);
  std::vector<Material> materials = {make(MaterialType::Diffuse, 0, RGB(0.3f, 0.5f, 0.7f))};
  for (float alpha : {0.05f, 0.2f, 0.6f})
    materials.push_back(make(MaterialType::Conductor, alpha, RGB(0.9f, 0.5f, 0.1f)));
  for (const auto& m : materials) {
    const Bsdf bsdf(m);
    int nonzero = 0;
    for (int i = 0; i < 20000; ++i) {
      const Vec3 wo = random_direction(rng), wi = random_direction(rng);
      const RGB a = bsdf.eval(wo, wi), b = bsdf.eval(wi, wo);
      if (!a.is_black()) ++nonzero;
      ASSERT_LT(rel_diff(a, b), 1e-4f) << to_string(m.type) << " alpha " << m.roughness;
    }
    EXPECT_GT(nonzero, 5000);  // about half the pairs share a hemisphere
  }
}

// Rough dielectric. Let eta_o and eta_i be the IORs on the sides of wo and wi, and
// etap = eta_i / eta_o (what the code calls etap). The radiance BTDF is
//   f_R(wo, wi) = f*(wo, wi) / etap^2 with
//   f*(wo, wi) = (1 - F) D G |wi.wm| |wo.wm| / (|cos_i cos_o| (wi.wm + wo.wm / etap)^2),
// where wm, F, D and G are the same for (wo, wi) and (wi, wo). Swapping the arguments inverts
// etap, and (wo.wm + wi.wm etap)^2 = etap^2 (wi.wm + wo.wm / etap)^2, so
//   f*(wi, wo) = f*(wo, wi) / etap^2 = f_R(wo, wi)   and   f_R(wi, wo) = f*(wo, wi).
// Hence (1) the importance BTDF is the adjoint of the radiance one, f_I(wo, wi) = f_R(wi, wo),
// and (2) Veach's generalized reciprocity (thesis eq. 5.14, with f_s(wi -> wo) = f(wo, wi)):
//   f_R(wo, wi) / eta_o^2 = f_R(wi, wo) / eta_i^2.
// Reflection pairs are plainly symmetric.
TEST(BsdfReciprocity, RoughDielectric) {
  Rng rng(11, 0);
  for (float alpha : {0.1f, 0.3f, 0.7f})
    for (float ior : {1.33f, 1.5f, 2.0f}) {
      const Material m = make(MaterialType::Dielectric, alpha, RGB(1.0f), ior);
      const Bsdf bsdf(m);
      int transmissions = 0, reflections = 0;
      for (int i = 0; i < 20000; ++i) {
        const Vec3 wo = random_direction(rng), wi = random_direction(rng);
        const RGB f_r = bsdf.eval(wo, wi, TransportMode::Radiance);
        const RGB f_r_swapped = bsdf.eval(wi, wo, TransportMode::Radiance);
        const RGB f_i = bsdf.eval(wo, wi, TransportMode::Importance);
        SCOPED_TRACE(fmt::format("alpha {} ior {}", alpha, ior));
        if (same_hemisphere(wo, wi)) {
          if (!f_r.is_black()) ++reflections;
          // Looser than for the conductor: from inside near the critical angle F is steep, so
          // the round-off difference between wo.wm and wi.wm shows.
          ASSERT_LT(rel_diff(f_r, f_r_swapped, 1e-5f), 1e-3f);
          ASSERT_EQ(f_r.r, f_i.r);  // transport mode only affects refraction
          continue;
        }
        if (!f_r.is_black()) ++transmissions;
        const float eta_o = wo.z > 0 ? 1.0f : ior, eta_i = wi.z > 0 ? 1.0f : ior;
        ASSERT_LT(rel_diff(f_r.r / sqr(eta_o), f_r_swapped.r / sqr(eta_i), 1e-5f), 1e-3f);
        ASSERT_LT(rel_diff(f_i.r, f_r_swapped.r, 1e-5f), 1e-3f);
      }
      EXPECT_GT(transmissions, 1000);
      EXPECT_GT(reflections, 1000);
    }
}

// ---- Reference values ----

// Independent double-precision transcription of the rough lobes in Walter et al. 2007's own
// notation: i is the direction light arrives from, o the one it leaves along, eta_i and eta_o
// the IORs on their sides. The chi-square test cannot see errors in f that are not in the pdf
// (G, F, the eta^2 scaling), so f is checked against these formulas.
namespace walter {

using D3 = std::array<double, 3>;
double dot3(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
D3 normalized(const D3& v) {
  const double l = std::sqrt(dot3(v, v));
  return {v[0] / l, v[1] / l, v[2] / l};
}
D3 to_d3(const Vec3& v) { return normalized({v.x, v.y, v.z}); }
double tan2(const D3& v) { return (v[0] * v[0] + v[1] * v[1]) / (v[2] * v[2]); }

double D(const D3& m, double a) {  // eq. 33
  if (m[2] <= 0) return 0;
  const double c2 = m[2] * m[2];
  return a * a / (kPi * c2 * c2 * sqr(a * a + tan2(m)));
}
// Smith G1 (eq. 34) without its chi+ factor; Lambda = 1 / G1 - 1 gives the height-correlated
// G2 = 1 / (1 + Lambda_i + Lambda_o) (Heitz 2014 eq. 99) with the chi+ factors of eq. 34.
double G1(const D3& v, double a) { return 2 / (1 + std::sqrt(1 + a * a * tan2(v))); }
double G2(const D3& i, const D3& o, const D3& m, double a) {
  if (dot3(i, m) / i[2] <= 0 || dot3(o, m) / o[2] <= 0) return 0;
  return 1 / (1 + (1 / G1(i, a) - 1) + (1 / G1(o, a) - 1));
}
// Unpolarized dielectric Fresnel in the form of eq. 22 (eta = eta_t / eta_i, c = |i.m|).
double F(double c, double eta) {
  const double g2 = eta * eta - 1 + c * c;
  if (g2 < 0) return 1;  // total internal reflection
  const double g = std::sqrt(g2);
  return 0.5 * sqr((g - c) / (g + c)) * (1 + sqr((c * (g + c) - 1) / (c * (g - c) + 1)));
}

// Radiance BSDF value for light from i scattered into o; `ior` inside (z < 0), 1 outside.
double dielectric(const D3& i, const D3& o, double a, double ior) {
  const double eta_i = i[2] > 0 ? 1 : ior, eta_o = o[2] > 0 ? 1 : ior;
  if (i[2] * o[2] > 0) {  // reflection, eqs. 13 and 20
    D3 h = normalized({i[0] + o[0], i[1] + o[1], i[2] + o[2]});
    if (h[2] < 0) h = {-h[0], -h[1], -h[2]};
    const double eta_t = i[2] > 0 ? ior : 1.0;
    return F(std::abs(dot3(i, h)), eta_t / eta_i) * G2(i, o, h, a) * D(h, a) /
           (4 * std::abs(i[2] * o[2]));
  }
  // Refraction, eqs. 16 and 21.
  D3 h = normalized({-(eta_i * i[0] + eta_o * o[0]), -(eta_i * i[1] + eta_o * o[1]),
                     -(eta_i * i[2] + eta_o * o[2])});
  if (h[2] < 0) h = {-h[0], -h[1], -h[2]};
  const double ih = dot3(i, h), oh = dot3(o, h);
  return std::abs(ih * oh / (i[2] * o[2])) * eta_o * eta_o * (1 - F(std::abs(ih), eta_o / eta_i)) *
         G2(i, o, h, a) * D(h, a) / sqr(eta_i * ih + eta_o * oh);
}

// Eq. 20 with the Fresnel factor fresnel(|i.h|).
template <typename Fresnel>
double conductor_with(const D3& i, const D3& o, double a, Fresnel fresnel) {
  if (i[2] * o[2] <= 0) return 0;
  D3 h = normalized({i[0] + o[0], i[1] + o[1], i[2] + o[2]});
  if (h[2] < 0) h = {-h[0], -h[1], -h[2]};
  return fresnel(std::abs(dot3(i, h))) * G2(i, o, h, a) * D(h, a) / (4 * std::abs(i[2] * o[2]));
}
double conductor(const D3& i, const D3& o, double a, double f0) {  // Schlick's Fresnel
  return conductor_with(i, o, a, [f0](double c) { return f0 + (1 - f0) * std::pow(1 - c, 5); });
}
// Cycles 3.4's Principled metal (bsdf_util.h, interpolate_fresnel_color): the colour blended
// toward white by FH = (F(c) - F(1)) / (1 - F(1)), F the dielectric Fresnel (eq. 22 form).
double principled_metal_fresnel(double c, double color, double ior) {
  const double f0 = F(1, ior), fh = (F(c, ior) - f0) / (1 - f0);
  return color * (1 - fh) + fh;
}

}  // namespace walter

TEST(BsdfReference, RoughLobesMatchWalterFormulas) {
  Rng rng(13, 0);
  for (float alpha : {0.1f, 0.3f, 0.7f}) {
    const Material cond = make(MaterialType::Conductor, alpha, RGB(0.9f, 0.6f, 0.3f));
    for (int k = 0; k < 2000; ++k) {
      const Vec3 wo = random_direction(rng), wi = random_direction(rng);
      const RGB f = Bsdf(cond).eval(wo, wi);
      for (int c = 0; c < 3; ++c)
        ASSERT_LT(rel_diff(f[c],
                           static_cast<float>(walter::conductor(
                               walter::to_d3(wi), walter::to_d3(wo), alpha, cond.color[c])),
                           1e-5f),
                  1e-3f);
    }
    for (float ior : {1.33f, 1.5f, 2.0f}) {
      SCOPED_TRACE(fmt::format("alpha {} ior {}", alpha, ior));
      const Material glass = make(MaterialType::Dielectric, alpha, RGB(1.0f), ior);
      const Bsdf bsdf(glass);
      int nonzero = 0;
      for (int k = 0; k < 2000; ++k) {
        const Vec3 wo = random_direction(rng), wi = random_direction(rng);
        const auto i = walter::to_d3(wi), o = walter::to_d3(wo);
        // Radiance mode is Walter's BTDF with light from wi; importance mode is its adjoint.
        const float ref_radiance = static_cast<float>(walter::dielectric(i, o, alpha, ior));
        const float ref_importance = static_cast<float>(walter::dielectric(o, i, alpha, ior));
        if (ref_radiance > 0) ++nonzero;
        ASSERT_LT(rel_diff(bsdf.eval(wo, wi, TransportMode::Radiance).r, ref_radiance, 1e-5f),
                  1e-3f)
            << "wo " << wo.z << " wi " << wi.z;
        ASSERT_LT(rel_diff(bsdf.eval(wo, wi, TransportMode::Importance).r, ref_importance, 1e-5f),
                  1e-3f)
            << "wo " << wo.z << " wi " << wi.z;
      }
      EXPECT_GT(nonzero, 500);
    }
  }
}

TEST(BsdfReference, PrincipledMetalHasCyclesInterpolatedFresnel) {
  // The metal of Cycles' Principled BSDF: rough lobes against eq. 20 with Cycles' Fresnel, for
  // the IORs of Specular 0.5 (1.5), 0.1 (about 1.18) and 0 (1: the colour at every angle).
  Rng rng(17, 0);
  const RGB color(0.9f, 0.6f, 0.3f);
  for (float ior : {1.5f, 1.18f, 1.0f})
    for (float alpha : {0.1f, 0.4f}) {
      SCOPED_TRACE(fmt::format("alpha {} ior {}", alpha, ior));
      Material m = make(MaterialType::Conductor, alpha, color, ior);
      m.conductor_fresnel = ConductorFresnel::Principled;
      for (int k = 0; k < 2000; ++k) {
        const Vec3 wo = random_direction(rng), wi = random_direction(rng);
        const RGB f = Bsdf(m).eval(wo, wi);
        for (int c = 0; c < 3; ++c) {
          const double ref = walter::conductor_with(walter::to_d3(wi), walter::to_d3(wo), alpha, [&](double cos_h) {
            return walter::principled_metal_fresnel(cos_h, color[c], ior);
          });
          ASSERT_LT(rel_diff(f[c], static_cast<float>(ref), 1e-5f), 1e-3f);
        }
      }
      // The smooth metal's mirror weight: the colour at normal incidence, white at grazing.
      m.roughness = 0;
      for (float c : {1.0f, 0.5f, 0.1f, -0.5f}) {
        const auto s = Bsdf(m).sample(wo_at(c), 0.3f, Vec2(0.2f, 0.8f));
        ASSERT_TRUE(s.has_value());
        const RGB weight = s->f * (abs_cos_theta(s->wi) / s->pdf);
        for (int k = 0; k < 3; ++k)
          EXPECT_NEAR(weight[k], walter::principled_metal_fresnel(std::abs(c), color[k], ior), 1e-5f);
      }
    }
  // It is not Schlick's: at 60 degrees off the normal an IOR-1.5 metal of colour 0.3 reflects
  // 0.3 (1 - FH) + FH with FH = 0.0512, Schlick 0.3 + 0.7 / 32 = 0.322.
  EXPECT_NEAR(walter::principled_metal_fresnel(0.5, 0.3, 1.5), 0.3359, 2e-4);
}

// ---- Fresnel and smooth dielectric ----

// Transmittance from the Fresnel amplitude coefficients (Hecht, Optics, §4.6), independent of
// fresnel_dielectric: T = (n_t cos_t) / (n_i cos_i) * (|t_s|^2 + |t_p|^2) / 2.
double fresnel_transmittance(double cos_i, double eta) {
  double n_i = 1, n_t = eta;
  if (cos_i < 0) {
    std::swap(n_i, n_t);
    cos_i = -cos_i;
  }
  const double sin_t = n_i / n_t * std::sqrt(std::max(0.0, 1 - cos_i * cos_i));
  if (sin_t >= 1) return 0;
  const double cos_t = std::sqrt(1 - sin_t * sin_t);
  const double t_s = 2 * n_i * cos_i / (n_i * cos_i + n_t * cos_t);
  const double t_p = 2 * n_i * cos_i / (n_t * cos_i + n_i * cos_t);
  return n_t * cos_t / (n_i * cos_i) * 0.5 * (t_s * t_s + t_p * t_p);
}

TEST(Fresnel, DielectricReflectancePlusTransmittanceIsOne) {
  for (float eta : {1.33f, 1.5f, 2.0f, 0.75f}) {
    // Normal incidence: ((eta - 1) / (eta + 1))^2.
    EXPECT_NEAR(fresnel_dielectric(1.0f, eta), sqr((eta - 1) / (eta + 1)), 1e-6f);
    for (int k = -99; k <= 99; ++k) {
      const float cos_i = k / 100.0f;
      if (cos_i == 0) continue;
      const float R = fresnel_dielectric(cos_i, eta);
      EXPECT_GE(R, 0.0f);
      EXPECT_LE(R, 1.0f);
      EXPECT_NEAR(R + fresnel_transmittance(cos_i, eta), 1.0, 1e-5) << "cos_i " << cos_i;
    }
  }
  // Same reflectance from both sides at corresponding angles (Stokes relations).
  const float cos_i = 0.6f, eta = 1.5f;
  const float cos_t = std::sqrt(1 - (1 - cos_i * cos_i) / (eta * eta));
  EXPECT_NEAR(fresnel_dielectric(cos_i, eta), fresnel_dielectric(-cos_t, eta), 1e-6f);
  // Beyond the critical angle from inside: total internal reflection.
  EXPECT_EQ(fresnel_dielectric(-0.5f, 1.5f), 1.0f);
  EXPECT_EQ(fresnel_dielectric(0.0f, 1.5f), 1.0f);
}

TEST(SmoothDielectric, ImportanceWeightIsOneAndLobesFollowFresnel) {
  constexpr int kN = 100000;
  for (float ior : {1.33f, 1.5f, 2.0f})
    for (float side : {1.0f, -1.0f})
      for (float c : {0.95f, 0.6f, 0.3f, 0.05f}) {
        const Material m = make(MaterialType::Dielectric, 0.0f, RGB(1.0f), ior);
        const Bsdf bsdf(m);
        const Vec3 wo = wo_at(side * c);
        SCOPED_TRACE(fmt::format("ior {} cos_o {}", ior, wo.z));
        const float R = fresnel_dielectric(wo.z, ior);
        Rng rng(static_cast<uint64_t>(ior * 100), static_cast<uint64_t>(wo.z * 1000 + 1000));
        double sum_importance = 0;
        int reflected = 0, failed = 0;
        for (int i = 0; i < kN; ++i) {
          const float uc = rng.uniform();
          const Vec2 u(rng.uniform(), rng.uniform());
          const auto s = bsdf.sample(wo, uc, u, TransportMode::Importance);
          const auto s_rad = bsdf.sample(wo, uc, u, TransportMode::Radiance);
          if (!s || !s_rad) {
            ++failed;
            continue;
          }
          ASSERT_TRUE(s->delta);
          const float w = s->f.r * abs_cos_theta(s->wi) / s->pdf;
          ASSERT_NEAR(w, 1.0f, 1e-5f);
          sum_importance += w;
          const float w_rad = s_rad->f.r * abs_cos_theta(s_rad->wi) / s_rad->pdf;
          if (s->transmission) {
            // Snell's law and the reported eta; radiance weight 1 / eta^2.
            const float eta_expected = wo.z > 0 ? ior : 1 / ior;
            ASSERT_NEAR(s->eta, eta_expected, 1e-6f);
            ASSERT_NEAR(std::sqrt(sin2_theta(s->wi)) * s->eta, std::sqrt(sin2_theta(wo)), 1e-5f);
            ASSERT_FALSE(same_hemisphere(wo, s->wi));
            ASSERT_NEAR(w_rad, 1 / sqr(s->eta), 1e-5f);
          } else {
            ++reflected;
            ASSERT_NEAR(s->wi.z, wo.z, 1e-7f);
            ASSERT_NEAR(w_rad, 1.0f, 1e-5f);
          }
        }
        EXPECT_EQ(failed, 0);
        EXPECT_NEAR(sum_importance / kN, 1.0, 1e-5);
        // Reflection frequency ~ Binomial(kN, R): within 5 standard deviations.
        EXPECT_NEAR(static_cast<double>(reflected) / kN, R, 5 * std::sqrt(R * (1 - R) / kN) + 1e-6);
      }
}

TEST(SmoothDielectric, TotalInternalReflection) {
  const Material m = make(MaterialType::Dielectric, 0.0f, RGB(1.0f), 1.5f);
  const Bsdf bsdf(m);
  // From inside at sin(theta) > 1 / 1.5 every sample reflects with weight 1.
  for (float c : {-0.7f, -0.5f, -0.1f}) {
    const Vec3 wo = wo_at(c);
    EXPECT_EQ(fresnel_dielectric(c, 1.5f), 1.0f);
    Rng rng(3, static_cast<uint64_t>(-c * 100));
    for (int i = 0; i < 1000; ++i) {
      const auto s = bsdf.sample(wo, rng.uniform(), Vec2(rng.uniform(), rng.uniform()));
      ASSERT_TRUE(s.has_value());
      EXPECT_FALSE(s->transmission);
      EXPECT_NEAR(s->wi.z, wo.z, 1e-7f);
      EXPECT_NEAR(s->f.r * abs_cos_theta(s->wi) / s->pdf, 1.0f, 1e-6f);
    }
  }
  // Rough glass from inside at grazing incidence reflects at least as much as it transmits.
  const Material rough = make(MaterialType::Dielectric, 0.1f, RGB(1.0f), 1.5f);
  const Bsdf rough_bsdf(rough);
  Rng rng(5, 0);
  int transmitted = 0, returned = 0;
  for (int i = 0; i < 10000; ++i) {
    const auto s =
        rough_bsdf.sample(wo_at(-0.2f), rng.uniform(), Vec2(rng.uniform(), rng.uniform()));
    if (!s) continue;
    ++returned;
    if (s->transmission) ++transmitted;
  }
  EXPECT_LT(transmitted, returned / 20);
}

TEST(SmoothConductor, MirrorWithSchlickFresnel) {
  const RGB f0(0.9f, 0.6f, 0.3f);
  const Material m = make(MaterialType::Conductor, 0.0f, f0);
  const Bsdf bsdf(m);
  EXPECT_TRUE(bsdf.is_delta());
  for (float c : {1.0f, 0.5f, 0.1f, -0.5f}) {
    const Vec3 wo = wo_at(c);
    const auto s = bsdf.sample(wo, 0.3f, Vec2(0.2f, 0.8f));
    ASSERT_TRUE(s.has_value());
    EXPECT_TRUE(s->delta);
    EXPECT_NEAR(s->wi.x, -wo.x, 1e-7f);
    EXPECT_NEAR(s->wi.y, -wo.y, 1e-7f);
    EXPECT_NEAR(s->wi.z, wo.z, 1e-7f);
    const float m5 = std::pow(1 - std::abs(c), 5.0f);
    const RGB weight = s->f * (abs_cos_theta(s->wi) / s->pdf);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(weight[k], f0[k] + (1 - f0[k]) * m5, 1e-5f);
    EXPECT_TRUE(bsdf.eval(wo, s->wi).is_black());
    EXPECT_EQ(bsdf.pdf(wo, s->wi), 0.0f);
  }
}

// ---- White furnace ----

// Mean of f |cos| / pdf over n samples (failed samples count as zero), and the largest weight.
std::pair<double, double> albedo(const Bsdf& bsdf, const Vec3& wo, TransportMode mode, int n,
                                 uint64_t seed) {
  Rng rng(seed, 0);
  double sum = 0, max_weight = 0;
  for (int i = 0; i < n; ++i) {
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto s = bsdf.sample(wo, uc, u, mode);
    if (!s) continue;
    const double w = s->f.r * abs_cos_theta(s->wi) / s->pdf;
    sum += w;
    max_weight = std::max(max_weight, w);
  }
  return {sum / n, max_weight};
}

TEST(BsdfFurnace, DiffuseAlbedoOneIsExact) {
  const Material m = make(MaterialType::Diffuse, 0, RGB(1.0f));
  const Bsdf bsdf(m);
  for (float c : {0.9f, 0.3f, -0.6f}) {
    const auto [mean, max_weight] = albedo(bsdf, wo_at(c), TransportMode::Radiance, 100000, 1);
    EXPECT_NEAR(mean, 1.0, 1e-5);
    EXPECT_NEAR(max_weight, 1.0, 1e-5);
  }
}

TEST(BsdfFurnace, RoughConductorLosesLittleEnergy) {
  // Single-scattering GGX with F = 1: weight G2 / G1(wo) <= 1 per sample; the lost energy is
  // multiple scattering between microfacets, a few percent at alpha = 0.2.
  const Material m = make(MaterialType::Conductor, 0.2f, RGB(1.0f));
  const Bsdf bsdf(m);
  for (float c : {0.9f, 0.5f, 0.15f, -0.5f}) {
    SCOPED_TRACE(fmt::format("cos_o {}", c));
    const auto [mean, max_weight] = albedo(bsdf, wo_at(c), TransportMode::Radiance, 200000, 2);
    EXPECT_LE(max_weight, 1.0 + 1e-4);
    EXPECT_LE(mean, 1.0);
    EXPECT_GT(mean, 0.8);
  }
}

TEST(BsdfFurnace, BeckmannAndAshikhminShirleyReflectAtMostAllTheLight) {
  // White Glossy BSDFs: their albedo (the estimator's mean) is at most 1, and most of the light
  // for Beckmann (single scattering loses a few percent, as GGX's). Ashikhmin-Shirley's pump
  // normalisation loses more away from the normal (measured 0.687 at cos 0.5, alpha 0.3; its
  // images match Cycles', docs/blender.md): its bound is 0.6.
  for (Microfacet d : {Microfacet::Beckmann, Microfacet::AshikhminShirley}) {
    Material m = make(MaterialType::Conductor, 0.3f, RGB(1.0f));
    m.conductor_fresnel = ConductorFresnel::None;
    m.distribution = d;
    const Bsdf bsdf(m);
    for (float c : {0.9f, 0.5f, -0.5f}) {
      SCOPED_TRACE(fmt::format("distribution {} cos_o {}", static_cast<int>(d), c));
      const auto [mean, max_weight] = albedo(bsdf, wo_at(c), TransportMode::Radiance, 200000, 3);
      (void)max_weight;
      EXPECT_LE(mean, 1.0 + 2e-3);
      EXPECT_GT(mean, d == Microfacet::Beckmann ? 0.8 : 0.6);
    }
  }
}

TEST(BsdfFurnace, RoughDielectricImportanceAlbedoAtMostOne) {
  // In importance mode each sample weighs G2 / G1(wo) <= 1 whichever lobe it took. The lower
  // bound only catches gross loss: single scattering keeps ~0.52 at worst here (alpha 0.7,
  // IOR 2, from inside at normal incidence).
  for (float alpha : {0.1f, 0.3f, 0.7f})
    for (float ior : {1.33f, 1.5f, 2.0f})
      for (float c : {0.9f, 0.5f, 0.15f, -0.9f, -0.5f, -0.15f}) {
        SCOPED_TRACE(fmt::format("alpha {} ior {} cos_o {}", alpha, ior, c));
        const Material m = make(MaterialType::Dielectric, alpha, RGB(1.0f), ior);
        const Bsdf bsdf(m);
        const auto [mean, max_weight] = albedo(bsdf, wo_at(c), TransportMode::Importance, 20000, 3);
        EXPECT_LE(max_weight, 1.0 + 1e-4);
        EXPECT_LE(mean, 1.0 + 1e-4);
        EXPECT_GT(mean, 0.5);
      }
}

TEST(BsdfFurnace, PlasticReflectsAtMostAllTheLight) {
  // White base, coat of IOR 1.5 or 2: the coat reflects E(mu) and the base all the rest,
  // (1 - E) (the base's weight), so the albedo is one up to the tabulation of E.
  for (float alpha : {0.0f, 0.1f, 0.5f, 1.0f})
    for (float ior : {1.5f, 2.0f})
      for (float c : {0.95f, 0.5f, 0.1f, -0.5f}) {
        SCOPED_TRACE(fmt::format("alpha {} ior {} cos_o {}", alpha, ior, c));
        const Material m = plastic(alpha, RGB(1.0f), ior);
        const Bsdf bsdf(m);
        const auto [mean, max_weight] = albedo(bsdf, wo_at(c), TransportMode::Radiance, 100000, 4);
        EXPECT_LE(mean, 1.0 + 5e-3);
        EXPECT_GT(mean, 0.97);
      }
}

TEST(BsdfFurnace, PrincipledMatchesCyclesClosuresInClosedForm) {
  // Burley's diffuse alone (Specular 0: IOR 1), white, seen from the normal: F_V = 0, so the
  // albedo is 2 int_0^1 [(1 - F_L / 2) + r (1 + mu) F_L] mu dmu = 1 - 1/42 + 5 r / 84 with
  // F_L = (1 - mu)^5 (1.00595 at r = 0.5; 0.976 without the retro-reflection, 1.030 without
  // the Lambertian part's Fresnel factors). Standard error of the estimate ~2e-4.
  for (float r : {0.0f, 0.5f, 1.0f}) {
    const Material m = make(MaterialType::Principled, r * r, RGB(1.0f), 1.0f);
    const auto [mean, max_weight] = albedo(Bsdf(m), Vec3(0, 0, 1), TransportMode::Radiance, 200000, 7);
    EXPECT_NEAR(mean, 1.0 - 1.0 / 42 + 5.0 * r / 84, 1.5e-3) << "r " << r;
  }
  // The specular lobe alone (black base), smooth: a mirror of the exact dielectric Fresnel (each
  // Dirac sample weighs F / 0.9, taken with probability 0.9: relative error ~0.24 %).
  for (float c : {0.9f, 0.5f, 0.1f}) {
    const Material m = make(MaterialType::Principled, 0.0f, RGB(0.0f), 1.5f);
    const auto [mean, max_weight] = albedo(Bsdf(m), wo_at(c), TransportMode::Radiance, 20000, 8);
    EXPECT_NEAR(mean, fresnel_dielectric(c, 1.5f), 0.01 * fresnel_dielectric(c, 1.5f)) << "cos_o " << c;
    EXPECT_NEAR(max_weight, fresnel_dielectric(c, 1.5f) / 0.9, 1e-4) << "cos_o " << c;
  }
  // Both lobes added, not layered: a white base under a rough specular lobe reflects more than
  // all the light (as in Cycles 3.4), by about the specular lobe's albedo.
  const Material both = make(MaterialType::Principled, 0.25f, RGB(1.0f), 1.5f);
  const auto [mean, max_weight] = albedo(Bsdf(both), wo_at(0.9f), TransportMode::Radiance, 200000, 9);
  EXPECT_GT(mean, 1.03);
  EXPECT_LT(mean, 1.07);
}

TEST(BumpShadowing, CyclesTermOnDiffuseLobesOnly) {
  // Shading normal +z bent 30 degrees from the smooth (and geometric) normal ns. Light along
  // w = (-0.5, 0, 0.866): G = (ns.w) / ((n.w)(ns.n)) = 0.5 / 0.75 = 2/3, smoothed to
  // -G^3 + G^2 + G = 0.8148 (Chiang et al. 2019). Light along ns: G >= 1, no change.
  const Vec3 ns(0.5f, 0.0f, std::sqrt(0.75f));
  const Vec3 w_low(-0.5f, 0.0f, std::sqrt(0.75f)), wo = wo_at(0.8f);
  const float g = 2.0f / 3.0f, expected = -g * g * g + g * g + g;
  const Material white = make(MaterialType::Diffuse, 0, RGB(1.0f));
  Bsdf bent(white), flat(white);
  bent.set_surface_normals(ns, ns);
  EXPECT_NEAR(bent.eval(wo, w_low).r / flat.eval(wo, w_low).r, expected, 1e-5);
  EXPECT_NEAR(bent.eval(wo, ns).r / flat.eval(wo, ns).r, 1.0f, 1e-6);
  // Importance transport (photons): the light arrives along wo, so the pair is read reversed.
  EXPECT_NEAR(bent.eval(w_low, wo, TransportMode::Importance).r / flat.eval(w_low, wo).r, expected, 1e-5);
  // A glossy lobe keeps its value; a mix's diffuse part takes the term.
  const Material metal = make(MaterialType::Conductor, 0.3f, RGB(0.9f));
  Bsdf bent_metal(metal);
  bent_metal.set_surface_normals(ns, ns);
  EXPECT_NEAR(bent_metal.eval(wo, w_low).r, Bsdf(metal).eval(wo, w_low).r, 1e-6);
  const Material m = mix(white, metal, 0.5f);
  Bsdf bent_mix(m);
  bent_mix.set_surface_normals(ns, ns);
  const float mixed = 0.5f * flat.eval(wo, w_low).r * expected + 0.5f * Bsdf(metal).eval(wo, w_low).r;
  EXPECT_NEAR(bent_mix.eval(wo, w_low).r, mixed, 1e-5);
}

TEST(BumpShadowing, SampledWeightsIntegrateTheShadowedLobe) {
  // The sampler returns f with the term (its pdf unchanged): the mean weight equals the
  // albedo of f G cos by quadrature over the hemisphere of wo (200 x 400 midpoint grid).
  const Vec3 ns = normalize(Vec3(0.6f, 0.2f, 0.75f));
  for (MaterialType type : {MaterialType::Diffuse, MaterialType::Principled}) {
    const Material m = make(type, 0.25f, RGB(0.8f));
    Bsdf bsdf(m);
    bsdf.set_surface_normals(ns, ns);
    const Vec3 wo = wo_at(0.7f, 2.5f);
    double quad = 0;
    constexpr int kT = 200, kP = 400;
    for (int i = 0; i < kT; ++i)
      for (int j = 0; j < kP; ++j) {
        const float ct = (i + 0.5f) / kT, phi = 2 * kPi * (j + 0.5f) / kP, st = std::sqrt(1 - ct * ct);
        const Vec3 wi(st * std::cos(phi), st * std::sin(phi), ct);
        quad += bsdf.eval(wo, wi).r * ct * (1.0 / kT) * (2 * kPi / kP);  // d omega = d cos d phi
      }
    const auto [mean, max_weight] = albedo(bsdf, wo, TransportMode::Radiance, 200000, 10);
    EXPECT_NEAR(mean, quad, 3e-3) << to_string(type);
    EXPECT_LT(quad, 0.8 * 0.99) << to_string(type);  // the term takes something away here
  }
}

TEST(BsdfLobes, KindsPartitionEvalAndPdfAndSamplesNameTheirLobe) {
  // Per-kind ray visibility (path tracer) evaluates a BSDF over some lobe kinds: the diffuse,
  // glossy and transmission parts must add up to the whole, and a sample must name the kind of
  // the lobe it came from (a refraction: transmission; a reflection of glass: glossy).
  const Material diffuse = make(MaterialType::Diffuse, 0, RGB(0.7f));
  const Material metal = make(MaterialType::Conductor, 0.2f, RGB(0.9f));
  const Material glass = make(MaterialType::Dielectric, 0.3f, RGB(1.0f), 1.5f);
  const std::vector<std::pair<std::string, Material>> cases = {
      {"diffuse", diffuse}, {"metal", metal}, {"glass", glass}, {"plastic", plastic(0.3f)},
      {"principled", make(MaterialType::Principled, 0.3f, RGB(0.6f))}, {"mix", mix(diffuse, glass, 0.4f)}};
  Rng rng(11, 0);
  for (const auto& [name, m] : cases) {
    const Bsdf bsdf(m);
    int kinds_seen = 0;
    for (int i = 0; i < 2000; ++i) {
      const Vec3 wo = wo_at(rng.uniform() * 1.8f - 0.9f + 1e-3f, 6.28f * rng.uniform());
      const auto s = bsdf.sample(wo, rng.uniform(), Vec2(rng.uniform(), rng.uniform()));
      if (!s) continue;
      ASSERT_TRUE(s->lobe == kRayDiffuse || s->lobe == kRayGlossy || s->lobe == kRayTransmission) << name;
      EXPECT_EQ(s->lobe == kRayTransmission, s->transmission) << name;
      kinds_seen |= s->lobe;
      RGB f_sum(0.0f);
      float pdf_sum = 0;
      for (uint8_t k : {kRayDiffuse, kRayGlossy, kRayTransmission}) {
        f_sum += bsdf.eval(wo, s->wi, TransportMode::Radiance, k);
        pdf_sum += bsdf.pdf(wo, s->wi, k);
      }
      const RGB f = bsdf.eval(wo, s->wi);
      EXPECT_NEAR(f_sum.g, f.g, 1e-5f * (1 + f.g)) << name;
      EXPECT_NEAR(pdf_sum, bsdf.pdf(wo, s->wi), 1e-5f * (1 + pdf_sum)) << name;
      if (!s->delta) EXPECT_GT(bsdf.pdf(wo, s->wi, s->lobe), 0.0f) << name << " lobe " << int(s->lobe);
    }
    const int expected = name == "diffuse" ? kRayDiffuse : name == "metal" ? kRayGlossy
                         : name == "glass" ? kRayGlossy | kRayTransmission
                         : name == "mix" ? kAllLobes : kRayDiffuse | kRayGlossy;
    EXPECT_EQ(kinds_seen, expected) << name;
  }
}

TEST(BsdfFurnace, MixIsTheWeightedSumAndAddOfTwoHalvesIsOne) {
  // Mix of white diffuse and a white mirror reflects everything whatever the factor; Add of
  // two half-white diffuse BSDFs reflects as one white diffuse.
  const Material white = make(MaterialType::Diffuse, 0, RGB(1.0f));
  const Material mirror = make(MaterialType::Conductor, 0.0f, RGB(1.0f));
  const Material half = make(MaterialType::Diffuse, 0, RGB(0.5f));
  for (float t : {0.0f, 0.3f, 1.0f}) {
    const auto [mean, max_weight] = albedo(Bsdf(mix(white, mirror, t)), wo_at(0.6f), TransportMode::Radiance, 50000, 5);
    EXPECT_NEAR(mean, 1.0, 1e-4) << "factor " << t;
  }
  const auto [mean, max_weight] = albedo(Bsdf(mix(half, half, 0, true)), wo_at(0.6f), TransportMode::Radiance, 50000, 6);
  EXPECT_NEAR(mean, 1.0, 1e-4);
  EXPECT_NEAR(max_weight, 1.0, 1e-4);
}

TEST(Bsdf, LayeredClassification) {
  // Photon methods store photons on the plastic's diffuse base and on a mix with any diffuse
  // part; a mix is a Dirac BSDF only when both parts are.
  const Material glass = make(MaterialType::Dielectric, 0, RGB(1.0f));
  const Material mirror = make(MaterialType::Conductor, 0);
  const Material diffuse = make(MaterialType::Diffuse, 0);
  EXPECT_TRUE(Bsdf(plastic(0)).is_diffuse_for_photons());
  EXPECT_FALSE(Bsdf(plastic(0)).is_delta());
  EXPECT_TRUE(Bsdf(mix(glass, mirror, 0.5f)).is_delta());
  EXPECT_FALSE(Bsdf(mix(glass, mirror, 0.5f)).is_diffuse_for_photons());
  EXPECT_TRUE(Bsdf(mix(glass, diffuse, 0.5f)).is_diffuse_for_photons());
  EXPECT_FALSE(Bsdf(mix(glass, diffuse, 0.5f)).is_delta());
}

// ---- Classification and degenerate input ----

TEST(Bsdf, Classification) {
  const Material diffuse = make(MaterialType::Diffuse, 0);
  const Material mirror = make(MaterialType::Conductor, 0);
  const Material glossy = make(MaterialType::Conductor, 0.03f);
  const Material rough_glass = make(MaterialType::Dielectric, 0.3f);
  const Material glass = make(MaterialType::Dielectric, 0);
  const Material emitter = make(MaterialType::Emission, 0);
  EXPECT_FALSE(Bsdf(diffuse).is_delta());
  EXPECT_TRUE(Bsdf(mirror).is_delta());
  EXPECT_FALSE(Bsdf(glossy).is_delta());
  EXPECT_TRUE(Bsdf(glass).is_delta());
  EXPECT_FALSE(Bsdf(rough_glass).is_delta());
  EXPECT_FALSE(Bsdf(emitter).is_delta());

  EXPECT_TRUE(Bsdf(diffuse).is_diffuse_for_photons());
  EXPECT_FALSE(Bsdf(mirror).is_diffuse_for_photons());
  EXPECT_FALSE(Bsdf(glossy).is_diffuse_for_photons());  // 0.03 <= 0.05
  EXPECT_TRUE(Bsdf(glossy).is_diffuse_for_photons(0.01f));
  EXPECT_TRUE(Bsdf(rough_glass).is_diffuse_for_photons());
  EXPECT_FALSE(Bsdf(glass).is_diffuse_for_photons());
  EXPECT_FALSE(Bsdf(emitter).is_diffuse_for_photons());

  EXPECT_TRUE(Bsdf(emitter).is_black());
  EXPECT_FALSE(Bsdf(diffuse).is_black());
  EXPECT_FALSE(Bsdf(glass).is_black());
  const Vec3 wo = wo_at(0.5f), wi = wo_at(0.7f, 2.0f);
  EXPECT_TRUE(Bsdf(emitter).eval(wo, wi).is_black());
  EXPECT_EQ(Bsdf(emitter).pdf(wo, wi), 0.0f);
  EXPECT_FALSE(Bsdf(emitter).sample(wo, 0.5f, Vec2(0.5f, 0.5f)).has_value());
  // Delta BSDFs have no density to evaluate.
  EXPECT_TRUE(Bsdf(glass).eval(wo, Vec3(-wo.x, -wo.y, wo.z)).is_black());
  EXPECT_EQ(Bsdf(glass).pdf(wo, Vec3(-wo.x, -wo.y, wo.z)), 0.0f);
}

TEST(Bsdf, DegenerateInputGivesZeroNotNaN) {
  std::vector<Material> materials = {make(MaterialType::Diffuse, 0)};
  for (float alpha : {0.0f, 0.001f, 0.05f, 0.7f, 1.0f}) {
    materials.push_back(make(MaterialType::Conductor, alpha));
    for (float ior : {1.0f, 1.5f})
      materials.push_back(make(MaterialType::Dielectric, alpha, RGB(1.0f), ior));
  }
  const std::vector<Vec3> dirs = {{0, 0, 1},        {0, 0, -1},      {1, 0, 0},
                                  {0, -1, 0},       {0.6f, 0, 0.8f}, {-0.6f, 0, 0.8f},
                                  {0.6f, 0, -0.8f}, {1, 0, 1e-8f},   {1, 0, -1e-8f}};
  const std::vector<float> us = {0.0f, 0.5f, 0.99999994f};
  for (const auto& m : materials) {
    const Bsdf bsdf(m);
    for (const Vec3& wo : dirs) {
      for (const Vec3& wi : dirs)
        for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
          const RGB f = bsdf.eval(wo, wi, mode);
          const float pdf = bsdf.pdf(wo, wi);
          ASSERT_TRUE(f.is_finite()) << to_string(m.type) << " " << m.roughness;
          ASSERT_TRUE(std::isfinite(pdf)) << to_string(m.type) << " " << m.roughness;
        }
      for (float uc : us)
        for (float u0 : us)
          for (float u1 : us) {
            const auto s = bsdf.sample(wo, uc, Vec2(u0, u1));
            if (!s) continue;
            ASSERT_TRUE(s->f.is_finite() && std::isfinite(s->pdf) && s->pdf > 0 && is_finite(s->wi))
                << to_string(m.type) << " " << m.roughness;
          }
    }
    // Grazing wo never yields a sample.
    EXPECT_FALSE(bsdf.sample(Vec3(1, 0, 0), 0.5f, Vec2(0.5f, 0.5f)).has_value());
  }
}

// ---- Cycles 3.4's further closures: values against Cycles' formulas, energy, classification ----

// Cycles' bsdf_oren_nayar.h, written out here in double for wo, wi on the upper side: its
// eval (f cos_i) for sigma = roughness.
double cycles_oren_nayar_cos(double sigma, const Vec3& wo, const Vec3& wi) {
  const double a = 1.0 / (M_PI + (3.0 * M_PI - 4.0) / 6.0 * sigma), b = sigma * a;
  const double nl = std::max(0.0f, wi.z), nv = std::max(0.0f, wo.z);
  double t = double(dot(wi, wo)) - nl * nv;
  if (t > 0) t /= std::max(nl, nv);
  return nl * (a + b * t);
}

TEST(BsdfReference, OrenNayarIsCyclesFormula) {
  Rng rng(17, 0);
  for (float sigma : {0.25f, 0.6f, 1.0f}) {
    const Bsdf bsdf(make(MaterialType::Diffuse, sigma, RGB(1.0f)));
    for (int i = 0; i < 2000; ++i) {
      Vec3 wo = random_direction(rng), wi = random_direction(rng);
      wo.z = std::abs(wo.z);
      wi.z = std::abs(wi.z);
      const double expected = cycles_oren_nayar_cos(sigma, wo, wi);
      EXPECT_NEAR(bsdf.eval(wo, wi).g * wi.z, expected, 1e-5 * std::max(1.0, expected));
      // Two-sided: the mirrored pair below the surface reflects alike.
      EXPECT_NEAR(bsdf.eval(-wo, -wi).g * wi.z, expected, 1e-5 * std::max(1.0, expected));
    }
  }
  // Roughness 0 is Lambert's exactly.
  const Vec3 wo = wo_at(0.4f), wi = wo_at(0.8f, 2.5f);
  EXPECT_EQ(Bsdf(make(MaterialType::Diffuse, 0, RGB(1.0f))).eval(wo, wi).g, kInvPi);
  // Roughness 1 seen and lit along the normal: A = 1 / (pi + (3 pi - 4) / 6), 0.777 / pi: the
  // issue's Lambertian centre was 1 / 0.777 = 1.29 times too bright.
  EXPECT_NEAR(Bsdf(make(MaterialType::Diffuse, 1.0f, RGB(1.0f))).eval(Vec3(0, 0, 1), Vec3(0, 0, 1)).g,
              1.0 / (M_PI + (3 * M_PI - 4) / 6), 1e-6);
}

TEST(BsdfFurnace, OrenNayarAlbedoIsItsIntegral) {
  // Along the normal f is the constant A, so the albedo is pi A exactly (0.7765 at sigma 1); at
  // other angles the sampled albedo matches the quadrature of f |cos| and stays below one.
  const Bsdf on(make(MaterialType::Diffuse, 1.0f, RGB(1.0f)));
  const auto [mean0, max0] = albedo(on, Vec3(0, 0, 1), TransportMode::Radiance, 20000, 31);
  EXPECT_NEAR(mean0, M_PI / (M_PI + (3 * M_PI - 4) / 6), 1e-5);
  for (float sigma : {0.5f, 1.0f})
    for (float c : {0.8f, 0.4f, 0.1f}) {
      SCOPED_TRACE(fmt::format("sigma {} cos_o {}", sigma, c));
      const Bsdf bsdf(make(MaterialType::Diffuse, sigma, RGB(1.0f)));
      const Vec3 wo = wo_at(c);
      const double quad = integrate_2d(
          [&](double phi, double ct) {
            const Vec3 wi = direction(ct, phi);
            return double(bsdf.eval(wo, wi).g) * ct;
          },
          0, 2 * M_PI, 0, 1, 1e-6);
      const auto [mean, max_weight] = albedo(bsdf, wo, TransportMode::Radiance, 400000, 32);
      EXPECT_NEAR(mean, quad, 3e-3);
      EXPECT_LT(quad, 1.0);
      EXPECT_GT(quad, 0.7);  // Oren-Nayar keeps most of the light
    }
}

TEST(BsdfReference, VelvetIsCyclesFormula) {
  // Cycles' bsdf_ashikhmin_velvet.h eval (f cos_i), in double, at a few pairs.
  auto cycles = [](double sigma, const Vec3& wo, const Vec3& wi) {
    const double inv_s2 = 1.0 / (std::max(sigma, 0.01) * std::max(sigma, 0.01));
    Vec3 h = normalize(wo + wi);
    const double cos_nh = h.z, cos_ho = std::abs(dot(wo, h));
    const double r = std::max(cos_nh / cos_ho, 1e-5);
    const double G = std::min(1.0, std::min(2 * r * wo.z, 2 * r * wi.z));
    const double sin2 = 1 - cos_nh * cos_nh;
    const double D = std::exp(-(cos_nh * cos_nh / sin2) * inv_s2) * inv_s2 / M_PI / (sin2 * sin2);
    return 0.25 * D * G / wo.z;
  };
  for (float sigma : {0.2f, 0.5f, 1.0f})
    for (float co : {0.9f, 0.5f, 0.2f})
      for (float ci : {0.95f, 0.6f, 0.1f}) {
        const Vec3 wo = wo_at(co), wi = wo_at(ci, 2.9f);
        const double expected = cycles(sigma, wo, wi);
        const Bsdf bsdf(make(MaterialType::Velvet, sigma, RGB(1.0f)));
        EXPECT_NEAR(bsdf.eval(wo, wi).g * wi.z, expected, 1e-4 * std::max(1.0, expected))
            << "sigma " << sigma << " " << co << " " << ci;
        EXPECT_EQ(bsdf.eval(wo, -wi).g, 0.0f);  // reflection only
      }
}

TEST(BsdfFurnace, TranslucentTransmitsItsColourAndVelvetMatchesItsIntegral) {
  const Bsdf tr(make(MaterialType::Translucent, 0, RGB(1.0f)));
  for (float c : {0.9f, -0.3f}) {
    const auto [mean, max_weight] = albedo(tr, wo_at(c), TransportMode::Radiance, 20000, 41);
    EXPECT_NEAR(mean, 1.0, 1e-5);
    EXPECT_EQ(tr.eval(wo_at(c), wo_at(c, 2.0f)).g, 0.0f);       // nothing reflected
    EXPECT_NEAR(tr.eval(wo_at(c), -wo_at(c, 2.0f)).g, kInvPi, 1e-7);  // all transmitted
  }
  for (float sigma : {0.3f, 1.0f})
    for (float c : {0.9f, 0.3f}) {
      SCOPED_TRACE(fmt::format("velvet sigma {} cos_o {}", sigma, c));
      const Bsdf v(make(MaterialType::Velvet, sigma, RGB(1.0f)));
      const Vec3 wo = wo_at(c);
      const double quad = integrate_2d(
          [&](double phi, double ct) { return double(v.eval(wo, direction(ct, phi)).g) * ct; }, 0, 2 * M_PI, 0, 1,
          1e-6);
      const auto [mean, max_weight] = albedo(v, wo, TransportMode::Radiance, 400000, 42);
      EXPECT_NEAR(mean, quad, 0.01 * quad + 1e-3);
      EXPECT_LT(quad, 1.0);
    }
}

TEST(BsdfReference, RefractionIsGlassWithoutFresnel) {
  // Smooth: every sample refracts, weight colour / etap^2 (radiance) or colour (importance);
  // from inside beyond the critical angle nothing comes back (Cycles absorbs it).
  const Material smooth = refraction(0.0f);
  for (float c : {0.95f, 0.5f, 0.1f, -0.95f, -0.8f}) {
    SCOPED_TRACE(fmt::format("cos_o {}", c));
    const Bsdf bsdf(smooth);
    for (float uc : {0.0f, 0.5f, 0.999f}) {
      const auto s = bsdf.sample(wo_at(c), uc, Vec2(0.5f, 0.5f), TransportMode::Importance);
      ASSERT_TRUE(s.has_value());
      EXPECT_TRUE(s->delta && s->transmission);
      EXPECT_LT(s->wi.z * c, 0.0f);
      const RGB w = s->f * (abs_cos_theta(s->wi) / s->pdf);
      EXPECT_NEAR(w.g, 0.8f, 1e-5f);
      const auto sr = bsdf.sample(wo_at(c), uc, Vec2(0.5f, 0.5f), TransportMode::Radiance);
      EXPECT_NEAR((sr->f * (abs_cos_theta(sr->wi) / sr->pdf)).g, 0.8f / sqr(s->eta), 1e-5f);
    }
  }
  EXPECT_FALSE(Bsdf(smooth).sample(wo_at(-0.3f), 0.5f, Vec2(0.5f, 0.5f)).has_value());  // TIR
  // Rough: the glass's transmission divided by its (1 - F), and no reflection.
  const Material rough = refraction(0.2f);
  Material glass = rough;
  glass.refraction_only = false;
  Rng rng(23, 0);
  int checked = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3 wo = random_direction(rng), wi = random_direction(rng);
    const RGB fr = Bsdf(rough).eval(wo, wi), fg = Bsdf(glass).eval(wo, wi);
    if (wo.z * wi.z > 0) {
      EXPECT_EQ(fr.g, 0.0f);
      continue;
    }
    if (fg.g <= 1e-6f) continue;
    // 1 - F at the pair's microfacet, from the outside direction (as bsdf.cpp).
    const float etap = wo.z > 0 ? 1.5f : 1 / 1.5f;
    Vec3 wm = normalize(wo + wi * etap);
    if (wm.z < 0) wm = -wm;
    const Vec3& w_out = wo.z > 0 ? wo : wi;
    const float T = 1 - fresnel_dielectric(dot(w_out, wm), 1.5f);
    EXPECT_NEAR(fg.g / fr.g, T, 2e-3f * T);
    ++checked;
  }
  EXPECT_GT(checked, 300);
  // Importance albedo (red: 0.9) from outside along the normal: all but the microfacet
  // shadowing (glass would keep only 1 - F = 0.96 of it in its transmission).
  const auto [mean, max_weight] = albedo(Bsdf(refraction(0.1f)), Vec3(0, 0, 1), TransportMode::Importance, 100000, 24);
  EXPECT_GT(mean / 0.9, 0.99);
  EXPECT_LE(mean / 0.9, 1.0 + 1e-4);
}

// Cycles 3.4's Glass BSDF of GGX / Beckmann (svm/closure.h): a reflection closure without
// Fresnel weighted by Fn and a refraction-only closure weighted by 1 - Fn, Fn the Fresnel at the
// shading normal for the camera-side direction (wo in radiance transport, wi in importance).
Material cycles_glass(float alpha, Microfacet d, RGB color = RGB(0.9f, 0.8f, 0.7f)) {
  Material m = make(MaterialType::Dielectric, alpha, color, 1.5f);
  m.distribution = d;
  m.fresnel_at_normal = true;
  return m;
}

TEST(BsdfChi2, CyclesGlassSplit) {
  std::vector<Chi2Case> cases;
  for (Microfacet d : {Microfacet::GGX, Microfacet::Beckmann})
    for (float alpha : {0.03f, 0.3f})
      for (float c : {0.9f, 0.4f, -0.9f, -0.6f})
        cases.push_back({fmt::format("cycles glass {} alpha={} cos_o={}", d == Microfacet::GGX ? "ggx" : "beckmann",
                                     alpha, c),
                         cycles_glass(alpha, d), wo_at(c)});
  uint64_t seed = 950;
  for (const auto& c : cases) check_case(c, seed++);
}

TEST(BsdfReference, CyclesGlassIsNormalFresnelTimesLobesWithoutFresnel) {
  Rng rng(31, 0);
  int reflections = 0, transmissions = 0, samples = 0;
  for (Microfacet d : {Microfacet::GGX, Microfacet::Beckmann}) {
    const Material glass = cycles_glass(0.2f, d);
    Material refr = glass;  // the Refraction BSDF: refraction lobe without Fresnel
    refr.fresnel_at_normal = false;
    refr.refraction_only = true;
    Material glossy = make(MaterialType::Conductor, 0.2f, glass.color);  // the Glossy BSDF
    glossy.distribution = d;
    glossy.conductor_fresnel = ConductorFresnel::None;
    const Bsdf b(glass), br(refr), bg(glossy);
    for (int i = 0; i < 4000; ++i) {
      const Vec3 wo = random_direction(rng), wi = random_direction(rng);
      for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
        const Vec3& cam = mode == TransportMode::Radiance ? wo : wi;
        const float Fn = fresnel_dielectric(cam.z, 1.5f);
        const RGB f = b.eval(wo, wi, mode);
        SCOPED_TRACE(fmt::format("wo {} {} {} wi {} {} {}", wo.x, wo.y, wo.z, wi.x, wi.y, wi.z));
        // Cycles 3.4's GGX closures' separable G1 G1 where the core's GGX lobes (the references
        // here) take the height-correlated G; Beckmann's is separable in both.
        float g_ratio = 1.0f;
        if (d == Microfacet::GGX) {
          const double g1o = walter::G1(walter::to_d3(wo), 0.2), g1i = walter::G1(walter::to_d3(wi), 0.2);
          g_ratio = static_cast<float>(g1o * g1i * (1 / g1o + 1 / g1i - 1));
        }
        if (wo.z * wi.z > 0) {
          // The conductor's frame is one-sided: mirror both into the upper hemisphere.
          const Vec3 so = wo.z > 0 ? wo : -wo, si = wo.z > 0 ? wi : -wi;
          const RGB ref = bg.eval(so, si, mode) * (Fn * g_ratio);
          ASSERT_LT(rel_diff(f, ref, 1e-6f), 2e-3f);
          if (!ref.is_black()) ++reflections;
        } else {
          const RGB ref = br.eval(wo, wi, mode) * ((1.0f - Fn) * g_ratio);
          ASSERT_LT(rel_diff(f, ref, 1e-6f), 2e-3f);
          if (!ref.is_black()) ++transmissions;
        }
      }
      // Photons see the adjoint of what camera paths see: importance from wo equals radiance
      // from wi (the split is not reciprocal in radiance alone: Fn of one side).
      ASSERT_LT(rel_diff(b.eval(wo, wi, TransportMode::Importance), b.eval(wi, wo, TransportMode::Radiance), 1e-6f),
                2e-3f);
      // Samples carry eval's f (the camera side's Fn) and pdf()'s density, in both modes.
      for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
        const auto s = b.sample(wo, rng.uniform(), Vec2(rng.uniform(), rng.uniform()), mode);
        if (!s) continue;
        ASSERT_LT(rel_diff(s->f, b.eval(wo, s->wi, mode), 1e-6f), 2e-3f);
        ASSERT_LT(std::abs(s->pdf - b.pdf(wo, s->wi)), 2e-3f * s->pdf + 1e-6f);
        ++samples;
      }
    }
  }
  EXPECT_GT(reflections, 1000);
  EXPECT_GT(transmissions, 1000);
  EXPECT_GT(samples, 8000);
  // Smooth (Sharp): the split is the same closure as Walter's (the microfacet is the normal).
  const Material sharp = cycles_glass(0.0f, Microfacet::GGX);
  Material walter = sharp;
  walter.fresnel_at_normal = false;
  for (float c : {0.9f, 0.3f, -0.9f})
    for (float uc : {0.01f, 0.99f}) {
      const auto a = Bsdf(sharp).sample(wo_at(c), uc, Vec2(0.5f, 0.5f));
      const auto w = Bsdf(walter).sample(wo_at(c), uc, Vec2(0.5f, 0.5f));
      ASSERT_EQ(a.has_value(), w.has_value());
      if (a) EXPECT_EQ(a->f.g, w->f.g);
    }
}

// Cycles 3.4's Principled glass (svm/closure.h): the Base Color weights the refraction only; the
// reflection's colour is cspec0 = mix(white, Base Color, Specular Tint) blended toward white by
// interpolate_fresnel_color at L.H. The Glass BSDF (principled_glass off) tints both.
TEST(BsdfReference, PrincipledGlassReflectionIsWhiteUnlessTinted) {
  const RGB red(0.8f, 0.15f, 0.05f);
  Rng rng(37, 0);
  int reflections = 0, transmissions = 0;
  for (float alpha : {0.0f, 0.09f}) {
    Material glass = cycles_glass(alpha, Microfacet::GGX, red);
    Material principled = glass;
    principled.principled_glass = true;
    Material tinted = principled;
    tinted.specular_tint = 0.7f;
    const Bsdf bg(glass), bp(principled), bt(tinted);
    for (int i = 0; i < 2000; ++i) {
      const Vec3 wo = random_direction(rng);
      const float uc = rng.uniform();
      const Vec2 u(rng.uniform(), rng.uniform());
      const auto g = bg.sample(wo, uc, u), p = bp.sample(wo, uc, u), t = bt.sample(wo, uc, u);
      ASSERT_EQ(g.has_value(), p.has_value());
      if (!g) continue;
      ASSERT_EQ(g->wi.z, p->wi.z);  // the colour changes no lobe choice nor direction
      if (g->transmission) {  // refraction: tinted alike
        ASSERT_LT(rel_diff(g->f, p->f, 1e-6f), 1e-5f);
        ++transmissions;
        continue;
      }
      ++reflections;
      const float grey = g->f.r / red.r;  // the reflection's magnitude without its colour
      ASSERT_LT(rel_diff(p->f, RGB(grey), 1e-6f), 1e-4f);  // white
      // Tinted: cspec0 blended toward white by FH = (F(cos_h) - F0) / (1 - F0), cos_h = wo.wm.
      // From inside (wo.z < 0) the Fresnel sees the inverse IOR: the signed cosine.
      const float cos_h = absdot(wo, normalize(wo + t->wi)) * (wo.z > 0 ? 1.0f : -1.0f);
      const float f0 = fresnel_dielectric(1.0f, 1.5f);
      const float fh = (fresnel_dielectric(cos_h, 1.5f) - f0) / (1.0f - f0);
      const RGB cspec0 = red * 0.7f + RGB(0.3f);
      ASSERT_LT(rel_diff(t->f, (cspec0 * (1.0f - fh) + RGB(fh)) * grey, 1e-6f), 2e-3f);
      // Eval agrees with the sample (rough lobes).
      if (alpha > 0.0f) ASSERT_LT(rel_diff(bp.eval(wo, p->wi), p->f, 1e-6f), 2e-3f);
    }
  }
  EXPECT_GT(reflections, 200);
  EXPECT_GT(transmissions, 1000);
  // Multiscatter GGX: the walk's reflections white, its refractions red. Walks that leave on
  // wo's side carry, in green, most of white's weight (a Glass BSDF's carry 0.15 of it or less).
  Material walk = cycles_glass(0.3f, Microfacet::MultiGGX, red);
  walk.fresnel_at_normal = false;
  Material pwalk = walk;
  pwalk.principled_glass = true;
  Material white = walk;
  white.color = RGB(1.0f);
  double g_glass = 0, g_principled = 0, g_white = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3 wo = wo_at(0.7f);
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto a = Bsdf(walk).sample(wo, uc, u), b = Bsdf(pwalk).sample(wo, uc, u), c = Bsdf(white).sample(wo, uc, u);
    if (!a || !b || !c || a->transmission) continue;
    g_glass += a->f.g / a->pdf, g_principled += b->f.g / b->pdf, g_white += c->f.g / c->pdf;
  }
  std::printf("reflected green: glass %.4f, principled %.4f, white %.4f\n", g_glass, g_principled, g_white);
  EXPECT_GT(g_white, 0.0);
  EXPECT_LE(g_glass, 0.16 * g_white);
  EXPECT_GT(g_principled, 0.8 * g_white);
}

// Cycles 3.4's GGX reflection masks by the separable G1(wo) G1(wi) (bsdf_microfacet.h): the
// conductor's separable_masking; the default is the height-correlated G ([Heitz14] eq. 99).
TEST(BsdfReference, SeparableMaskingIsG1TimesG1) {
  Rng rng(41, 0);
  Material correlated = make(MaterialType::Conductor, 0.5f, RGB(0.9f, 0.7f, 0.5f));
  correlated.conductor_fresnel = ConductorFresnel::None;
  Material separable = correlated;
  separable.separable_masking = true;
  const Bsdf bc(correlated), bs(separable);
  int n = 0;
  for (int i = 0; i < 4000; ++i) {
    Vec3 wo = random_direction(rng), wi = random_direction(rng);
    if (wo.z < 0) wo = -wo;
    if (wi.z < 0) wi = -wi;
    const double g1o = walter::G1(walter::to_d3(wo), 0.5), g1i = walter::G1(walter::to_d3(wi), 0.5);
    // G1 G1 / G_correlated = G1o G1i (1 / G1o + 1 / G1i - 1).
    const float ratio = static_cast<float>(g1o * g1i * (1 / g1o + 1 / g1i - 1));
    const RGB c = bc.eval(wo, wi), s = bs.eval(wo, wi);
    if (c.is_black()) continue;
    ASSERT_LT(rel_diff(s, c * ratio, 1e-6f), 2e-3f);
    EXPECT_LE(ratio, 1.0f + 1e-5f);
    const auto smp = bs.sample(wo, 0.5f, Vec2(rng.uniform(), rng.uniform()));
    if (smp) ASSERT_LT(rel_diff(smp->f, bs.eval(wo, smp->wi), 1e-6f), 2e-3f);
    ++n;
  }
  EXPECT_GT(n, 3000);
}

TEST(Bsdf, TransparentIsATintedDeltaPassThrough) {
  const Bsdf red(transparent(RGB(1.0f, 0.1f, 0.1f)));
  EXPECT_TRUE(red.is_delta());
  EXPECT_FALSE(red.is_diffuse_for_photons());
  const Vec3 wo = wo_at(0.6f);
  const auto s = red.sample(wo, 0.3f, Vec2(0.2f, 0.7f));
  ASSERT_TRUE(s.has_value());
  EXPECT_TRUE(s->delta && s->transmission);
  EXPECT_FLOAT_EQ(s->wi.x, -wo.x);
  EXPECT_FLOAT_EQ(s->wi.z, -wo.z);
  const RGB w = s->f * (abs_cos_theta(s->wi) / s->pdf);
  EXPECT_NEAR(w.r, 1.0f, 1e-6f);
  EXPECT_NEAR(w.g, 0.1f, 1e-6f);
  // The Mix of a red and a blue Transparent BSDF: purple on average, still delta.
  const Bsdf purple(mix(transparent(RGB(1, 0, 0)), transparent(RGB(0, 0, 1)), 0.5f));
  EXPECT_TRUE(purple.is_delta());
  Rng rng(3, 0);
  RGB sum(0.0f);
  constexpr int n = 20000;
  for (int i = 0; i < n; ++i) {
    const auto t = purple.sample(wo, rng.uniform(), Vec2(rng.uniform(), rng.uniform()));
    ASSERT_TRUE(t.has_value());
    sum += t->f * (abs_cos_theta(t->wi) / t->pdf);
  }
  EXPECT_NEAR(sum.r / n, 0.5, 0.02);
  EXPECT_NEAR(sum.b / n, 0.5, 0.02);
  EXPECT_NEAR(sum.g / n, 0.0, 1e-6);
}

TEST(Bsdf, ClassificationOfCyclesClosures) {
  EXPECT_TRUE(Bsdf(refraction(0.0f)).is_delta());
  EXPECT_FALSE(Bsdf(refraction(0.3f)).is_delta());
  EXPECT_TRUE(Bsdf(refraction(0.3f)).is_diffuse_for_photons());
  for (MaterialType t : {MaterialType::Translucent, MaterialType::Velvet}) {
    EXPECT_FALSE(Bsdf(make(t, 0.5f)).is_delta()) << to_string(t);
    EXPECT_TRUE(Bsdf(make(t, 0.5f)).is_diffuse_for_photons()) << to_string(t);
    EXPECT_TRUE(Bsdf(make(t, 0.5f, RGB(0.0f))).is_black()) << to_string(t);
  }
  const Material m = mix(transparent(RGB(1.0f)), make(MaterialType::Translucent, 0), 0.5f);
  EXPECT_FALSE(Bsdf(m).is_delta());
  EXPECT_TRUE(Bsdf(m).is_diffuse_for_photons());
}

}  // namespace
}  // namespace gp


namespace gp {
namespace {

// ---- Principled clearcoat, sheen and specular tint against Cycles 3.4's formulas ----
//
// The references below are written from the formulas (svm_closure.h's principled case,
// bsdf_microfacet.h's clearcoat, bsdf_principled_sheen.h), in double precision, independently
// of bsdf.cpp.
namespace cycles_ref {
using walter::D3;
double fresnel(double c, double eta) { return walter::F(c, eta); }
double gtr1(double cos_h, double a) {
  const double a2 = a * a;
  if (a2 >= 1) return 1 / kPi;
  return (a2 - 1) / (kPi * std::log(a2) * (1 + (a2 - 1) * cos_h * cos_h));
}
double g1_ggx(double cos_n, double a) {
  const double c2 = cos_n * cos_n;
  return 2 / (1 + std::sqrt(1 + a * a * (1 - c2) / c2));
}
// f of the clearcoat closure of weight `cc`, alpha a, for wi, wo on the +z side.
double clearcoat(const D3& i, const D3& o, double a, double cc) {
  if (i[2] <= 0 || o[2] <= 0) return 0;
  const D3 h = walter::normalized({i[0] + o[0], i[1] + o[1], i[2] + o[2]});
  return 0.25 * cc * fresnel(walter::dot3(o, h), 1.5) * gtr1(h[2], a) * g1_ggx(i[2], 0.25) * g1_ggx(o[2], 0.25) /
         (4 * i[2] * o[2]);
}
// The sheen lobe: sheen x mix(1, colour / Y, tint) x (1 - wi.h)^5.
double sheen(const D3& i, const D3& o, double sheen, double tint, double color, double lum) {
  if (i[2] <= 0 || o[2] <= 0) return 0;
  const D3 h = walter::normalized({i[0] + o[0], i[1] + o[1], i[2] + o[2]});
  return sheen * (1 - tint + tint * color / lum) * std::pow(1 - walter::dot3(i, h), 5);
}
}  // namespace cycles_ref

TEST(BsdfReference, ClearcoatIsCyclesGtr1Lobe) {
  Rng rng(19, 0);
  for (float alpha : {0.0009f, 0.1f, 0.5f, 1.0f})
    for (float cc : {1.0f, 0.3f}) {
      SCOPED_TRACE(fmt::format("alpha {} clearcoat {}", alpha, cc));
      const Bsdf bsdf(clearcoat(alpha, cc));
      for (int k = 0; k < 2000; ++k) {
        Vec3 wo = random_direction(rng), wi = random_direction(rng);
        wo.z = std::abs(wo.z), wi.z = std::abs(wi.z);
        const double ref = cycles_ref::clearcoat(walter::to_d3(wi), walter::to_d3(wo), alpha, cc);
        ASSERT_LT(rel_diff(bsdf.eval(wo, wi).r, static_cast<float>(ref), 1e-6f), 1e-3f);
        // Two-sided, as the other reflection lobes; glossy.
        ASSERT_LT(rel_diff(bsdf.eval(-wo, -wi).r, static_cast<float>(ref), 1e-6f), 1e-3f);
        ASSERT_EQ(bsdf.eval(wo, wi, TransportMode::Radiance, kRayDiffuse).r, 0.0f);
      }
    }
  // Below Cycles' singular alpha (alpha^2 <= 1e-7) a mirror of weight 0.25 clearcoat F(cos_o).
  const Bsdf smooth(clearcoat(1e-4f, 0.8f));
  EXPECT_TRUE(smooth.is_delta());
  for (float c : {1.0f, 0.5f, 0.1f, -0.5f}) {
    const auto s = smooth.sample(wo_at(c), 0.5f, Vec2(0.3f, 0.6f));
    ASSERT_TRUE(s.has_value());
    EXPECT_NEAR(s->f.r * abs_cos_theta(s->wi) / s->pdf, 0.2 * cycles_ref::fresnel(std::abs(c), 1.5), 1e-6);
  }
}

TEST(BsdfFurnace, ClearcoatAlbedoIsItsIntegral) {
  // The sampled albedo against the reference f integrated over the hemisphere in (cos, phi),
  // per alpha and view: a wrong pdf or weight in the sampler moves it. The lobe reflects at
  // most 0.25 clearcoat x F: about 0.01 at normal incidence for clearcoat 1.
  for (float alpha : {0.05f, 0.3f, 1.0f})
    for (float c : {0.9f, 0.4f}) {
      SCOPED_TRACE(fmt::format("alpha {} cos_o {}", alpha, c));
      const Vec3 wo = wo_at(c);
      const auto o = walter::to_d3(wo);
      const double ref = integrate_2d(
          [&](double mu, double phi) {
            const double s = std::sqrt(std::max(0.0, 1 - mu * mu));
            return cycles_ref::clearcoat({s * std::cos(phi), s * std::sin(phi), mu}, o, alpha, 4.0) * mu;
          },
          0, 1, 0, 2 * kPi, 1e-6, 8, 10);
      const auto [mean, max_weight] = albedo(Bsdf(clearcoat(alpha, 4.0f)), wo, TransportMode::Radiance, 200000, 21);
      EXPECT_NEAR(mean, ref, 0.01 * ref);
      EXPECT_LE(mean, 1.0);
    }
}

TEST(BsdfReference, PrincipledSheenAndSpecularTintAreCycles) {
  // Base colour (0.6, 0.3, 0.1): Rec. 709 Y 0.3585 (the sheen's tint), 0.3 x 0.6 + 0.6 x 0.3 +
  // 0.1 x 0.1 = 0.37 (the specular tint's "luminance approx.").
  const RGB color(0.6f, 0.3f, 0.1f);
  const double y709 = 0.2126729 * 0.6 + 0.7151522 * 0.3 + 0.0721750 * 0.1, y_spec = 0.37;
  Rng rng(23, 0);
  for (float sheen : {0.0f, 1.0f, 0.4f})
    for (float tint : {0.0f, 0.5f, 1.0f}) {
      SCOPED_TRACE(fmt::format("sheen {} tint {}", sheen, tint));
      Material with = make(MaterialType::Principled, 0.3f, color), without = with;
      with.sheen = sheen;
      with.sheen_tint = tint;
      for (int k = 0; k < 500; ++k) {
        Vec3 wo = random_direction(rng), wi = random_direction(rng);
        wo.z = std::abs(wo.z), wi.z = std::abs(wi.z);
        // The sheen is a diffuse closure: the difference of the diffuse parts.
        const RGB d = Bsdf(with).eval(wo, wi, TransportMode::Radiance, kRayDiffuse) -
                      Bsdf(without).eval(wo, wi, TransportMode::Radiance, kRayDiffuse);
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(d[c], cycles_ref::sheen(walter::to_d3(wi), walter::to_d3(wo), sheen, tint, color[c], y709), 2e-5);
      }
    }
  // Specular Tint t: cspec0 = F0 mix(1, colour / 0.37, t) interpolated toward white by
  // FH = (F(c) - F0) / (1 - F0) (the glossy part; untinted it is F(c) itself).
  for (float t : {0.0f, 0.5f, 1.0f}) {
    Material m = make(MaterialType::Principled, 0.2f, color), plain = m;
    m.specular_tint = t;
    for (int k = 0; k < 500; ++k) {
      Vec3 wo = random_direction(rng), wi = random_direction(rng);
      wo.z = std::abs(wo.z), wi.z = std::abs(wi.z);
      const RGB f = Bsdf(m).eval(wo, wi, TransportMode::Radiance, kRayGlossy);
      const RGB f_plain = Bsdf(plain).eval(wo, wi, TransportMode::Radiance, kRayGlossy);
      if (!(f_plain.r > 1e-6f)) continue;
      const Vec3 h = normalize(wo + wi);
      const double fd = cycles_ref::fresnel(std::abs(dot(wo, h)), 1.5), f0 = cycles_ref::fresnel(1, 1.5);
      const double fh = (fd - f0) / (1 - f0);
      for (int c = 0; c < 3; ++c) {
        const double cspec0 = std::min(1.0, f0 * (1 - t + t * color[c] / y_spec));
        ASSERT_NEAR(f[c] / f_plain[c], (cspec0 * (1 - fh) + fh) / fd, 1e-4) << "t " << t;
      }
    }
  }
}

TEST(BsdfFurnace, SheenAlbedoSeenFromTheNormal) {
  // Seen from the normal, wi.h = cos(theta / 2): the sheen's albedo is
  // 2 pi int_0^1 (1 - sqrt((1 + mu) / 2))^5 mu dmu per unit Sheen (white, untinted), which the
  // sampled albedo of a black-based principled with Specular 0 (IOR 1) must reproduce.
  const double ref = 2 * kPi * adaptive_simpson([](double mu) { return std::pow(1 - std::sqrt(0.5 * (1 + mu)), 5) * mu; },
                                                0, 1, 1e-12, 20);
  Material m = make(MaterialType::Principled, 0.3f, RGB(0.0f), 1.0f);
  m.sheen = 1.0f;
  m.sheen_tint = 0.0f;
  const auto [mean, max_weight] = albedo(Bsdf(m), Vec3(0, 0, 1), TransportMode::Radiance, 400000, 25);
  EXPECT_NEAR(mean, ref, 0.02 * ref) << "reference " << ref;
  EXPECT_GT(ref, 1e-4);
}

// Cycles 3.4's anisotropic lobes against their formulas: alpha_x = alpha (1 - an), alpha_y =
// alpha / (1 - an) (an >= 0; alpha / (1 + an), alpha (1 + an) below), x the tangent. GGX: Heitz
// 2014 eq. 85 (D) and 86 (Lambda; G separable, as Cycles' anisotropic branch); Beckmann: D with
// Cycles' bsdf_beckmann_aniso_G1 (Walter's rational fit of the projected alpha), separable.
namespace aniso_ref {
using walter::D3;
void alphas(double a, double an, double* ax, double* ay) {
  if (an < 0) *ax = a / (1 + an), *ay = a * (1 + an);
  else *ax = a * (1 - an), *ay = a / (1 - an);
}
double ggx_D(const D3& m, double ax, double ay) {
  const double d = m[0] * m[0] / (ax * ax) + m[1] * m[1] / (ay * ay) + m[2] * m[2];
  return 1 / (kPi * ax * ay * d * d);
}
double ggx_lambda(const D3& w, double ax, double ay) {
  const double t = (ax * ax * w[0] * w[0] + ay * ay * w[1] * w[1]) / (w[2] * w[2]);
  return (std::sqrt(1 + t) - 1) / 2;
}
double beckmann_D(const D3& m, double ax, double ay) {
  const double sx = m[0] / (m[2] * ax), sy = m[1] / (m[2] * ay);
  return std::exp(-sx * sx - sy * sy) / (kPi * ax * ay * std::pow(m[2], 4));
}
double beckmann_G1(const D3& w, double ax, double ay) {
  const double r2 = w[0] * w[0] + w[1] * w[1];
  if (r2 == 0) return 1;  // along the normal
  const double a2 = (w[0] * w[0] * ax * ax + w[1] * w[1] * ay * ay) / r2;
  const double inv_a = std::sqrt(a2 * r2 / (w[2] * w[2]));
  if (inv_a < 0.625) return 1;
  const double a = 1 / inv_a;
  return ((2.181 * a + 3.535) * a) / ((2.577 * a + 2.276) * a + 1);
}
// f of the lobe (no Fresnel: the Glossy BSDF) for a pair above the surface.
double f(const D3& i, const D3& o, double alpha, double an, bool beckmann) {
  double ax, ay;
  alphas(alpha, an, &ax, &ay);
  const D3 h = walter::normalized({i[0] + o[0], i[1] + o[1], i[2] + o[2]});
  if (beckmann) return beckmann_D(h, ax, ay) * beckmann_G1(i, ax, ay) * beckmann_G1(o, ax, ay) / (4 * i[2] * o[2]);
  return ggx_D(h, ax, ay) / ((1 + ggx_lambda(i, ax, ay)) * (1 + ggx_lambda(o, ax, ay))) / (4 * i[2] * o[2]);
}
}  // namespace aniso_ref

TEST(BsdfReference, AnisotropicLobesAreCyclesFormulas) {
  Rng rng(29, 0);
  for (bool beckmann : {false, true})
    for (float an : {0.7f, -0.5f, 0.3f}) {
      SCOPED_TRACE(fmt::format("beckmann {} anisotropy {}", beckmann, an));
      const Material m = anisotropic(MaterialType::Conductor, beckmann ? Microfacet::Beckmann : Microfacet::GGX, 0.3f, an);
      int checked = 0;
      for (int k = 0; k < 2000; ++k) {
        Vec3 wo = random_direction(rng), wi = random_direction(rng);
        wo.z = std::abs(wo.z), wi.z = std::abs(wi.z);
        if (wo.z < 0.05f || wi.z < 0.05f) continue;
        const double ref = aniso_ref::f(walter::to_d3(wi), walter::to_d3(wo), 0.3, an, beckmann);
        const RGB v = Bsdf(m).eval(wo, wi);
        ASSERT_LT(rel_diff(v.g, static_cast<float>(0.6 * ref), 1e-6f), 2e-3f) << "wo " << wo.z << " wi " << wi.z;
        ++checked;
      }
      EXPECT_GT(checked, 1500);
    }
  // Anisotropy an along x is -an along y: the lobe of (x, y) swapped.
  const Material a = anisotropic(MaterialType::Conductor, Microfacet::GGX, 0.4f, 0.6f);
  const Material b = anisotropic(MaterialType::Conductor, Microfacet::GGX, 0.4f, -0.6f);
  const Vec3 wo(0.3f, 0.5f, 0.81f), wi(-0.6f, 0.1f, 0.79f);
  EXPECT_NEAR(Bsdf(a).eval(wo, wi).r, Bsdf(b).eval(Vec3(wo.y, wo.x, wo.z), Vec3(wi.y, wi.x, wi.z)).r, 1e-4f);
  EXPECT_GT(std::abs(Bsdf(a).eval(wo, wi).r - Bsdf(b).eval(wo, wi).r), 0.01f);
}

TEST(BsdfFurnace, AnisotropicGlossyAlbedoIsItsIntegral) {
  // White Glossy lobes of alpha 0.3, anisotropy 0.5 (alpha_x 0.15, alpha_y 0.6): the sampled
  // albedo against the reference f integrated over the hemisphere (single scattering loses
  // about a quarter of the light for GGX here, 7-10 % for Beckmann's separable G).
  for (Microfacet d : {Microfacet::GGX, Microfacet::Beckmann})
    for (float c : {0.9f, 0.5f}) {
      SCOPED_TRACE(fmt::format("beckmann {} cos_o {}", d == Microfacet::Beckmann, c));
      Material m = anisotropic(MaterialType::Conductor, d, 0.3f, 0.5f);
      m.color = RGB(1.0f);
      const Vec3 wo = wo_at(c);
      const auto o = walter::to_d3(wo);
      const double ref = integrate_2d(
          [&](double mu, double phi) {
            if (mu <= 0) return 0.0;
            const double s = std::sqrt(std::max(0.0, 1 - mu * mu));
            return aniso_ref::f({s * std::cos(phi), s * std::sin(phi), mu}, o, 0.3, 0.5, d == Microfacet::Beckmann) * mu;
          },
          0, 1, 0, 2 * kPi, 1e-5, 8, 10);
      const auto [mean, max_weight] = albedo(Bsdf(m), wo, TransportMode::Radiance, 200000, 31);
      EXPECT_NEAR(mean, ref, 0.01 * ref);
      EXPECT_LE(mean, 1.0);
    }
}

// ============================================================================================
// Multiscatter GGX (Heitz et al. 2016's random walk, bsdf.cpp) and Beckmann glass
// ============================================================================================

Material multi(MaterialType type, float alpha, RGB color = RGB(1.0f), float ior = 1.5f) {
  Material m = make(type, alpha, color, ior);
  m.distribution = Microfacet::MultiGGX;
  if (type == MaterialType::Conductor) m.conductor_fresnel = ConductorFresnel::None;  // Glossy BSDF
  return m;
}

TEST(MultiscatterFurnace, WhiteConductorKeepsTheEnergySingleScatteringLoses) {
  // A white Glossy BSDF: single-scattering GGX loses the light that meets a second microfacet,
  // the more the rougher (Heitz et al. 2016, §1 and fig. 1: "up to 60 %" at alpha 1); the walk
  // keeps all of it but what still bounces after Cycles' 10 scatterings. Measured (200 000
  // samples each; an independent quadrature of single GGX agrees to 1e-3), multi / single:
  //   alpha 0.5: cos 0.9 1.0000 / 0.6842, cos 0.5 1.0000 / 0.6985, cos 0.15 1.0000 / 0.8207;
  //   alpha 1:   cos 0.9 1.0000 / 0.3284, cos 0.5 1.0000 / 0.4507, cos 0.15 1.0000 / 0.6944.
  // Bounds: multi within [0.995, 1] (float round-off above), single below multi - 0.1.
  for (float alpha : {0.5f, 1.0f})
    for (float c : {0.9f, 0.5f, 0.15f}) {
      SCOPED_TRACE(fmt::format("alpha {} cos_o {}", alpha, c));
      const Material m = multi(MaterialType::Conductor, alpha);
      Material s = m;
      s.distribution = Microfacet::GGX;
      const auto [mean, max_weight] = albedo(Bsdf(m), wo_at(c), TransportMode::Radiance, 200000, 41);
      const auto [single, single_max] = albedo(Bsdf(s), wo_at(c), TransportMode::Radiance, 200000, 41);
      std::printf("multiscatter furnace alpha %.1f cos %.2f: multi %.4f single %.4f\n", alpha, c, mean, single);
      EXPECT_LE(max_weight, 1.0 + 1e-4);  // a white walk's throughput is 1 where it escapes
      EXPECT_LE(mean, 1.0 + 1e-6);
      EXPECT_GT(mean, 0.995);
      EXPECT_LT(single, mean - 0.1);
    }
}

TEST(MultiscatterFurnace, WhiteGlassKeepsTheEnergy) {
  // White Multiscatter glass in importance mode (flux): every walk leaves with weight 1, on one
  // side or the other, unless it is still inside after 10 scatterings. Measured 0.9990-1.0000
  // (alpha 0.5 and 1, IOR 1.5, both sides). Cycles' stand-in pdf is 0 where no single
  // microfacet refracts wo into wi, and its sampler drops those walks: 0.77 at alpha 1, cos 0.5
  // (bsdf.cpp keeps them).
  for (float alpha : {0.5f, 1.0f})
    for (float c : {0.9f, 0.5f, -0.5f}) {
      SCOPED_TRACE(fmt::format("alpha {} cos_o {}", alpha, c));
      const auto [mean, max_weight] =
          albedo(Bsdf(multi(MaterialType::Dielectric, alpha)), wo_at(c), TransportMode::Importance, 100000, 43);
      std::printf("multiscatter glass furnace alpha %.1f cos %.2f: %.4f\n", alpha, c, mean);
      EXPECT_LE(max_weight, 1.0 + 1e-4);
      EXPECT_GT(mean, 0.995);
    }
}

// The walk's sampler and its stochastic eval describe one BSDF: per bin of directions (16 in
// cos theta over both sides x 8 in phi), the sampled weights' mean against eval |cos|
// integrated over the bin (20 x 20 jittered points, one walk each). Both are estimates; a bin
// fails when they differ by more than 5 of their joint standard errors plus 2e-3 (absolute:
// the bins' share of the albedo is 1e-3..0.1). The totals (albedo) likewise.
void check_walk_consistency(const Material& m, const Vec3& wo, TransportMode mode, uint64_t seed) {
  const Bsdf bsdf(m);
  constexpr int kZ = 16, kPhi = 8, kBins = kZ * kPhi, kN = 200000, kJ = 20;
  std::vector<double> s_sum(kBins * 3, 0.0), s_sq(kBins * 3, 0.0), e_mean(kBins * 3, 0.0), e_var(kBins * 3, 0.0);
  auto bin_of = [&](const Vec3& w) {
    const int iz = std::clamp(static_cast<int>((w.z + 1.0f) * 0.5f * kZ), 0, kZ - 1);
    float phi = std::atan2(w.y, w.x);
    if (phi < 0) phi += 2 * kPi;
    const int ip = std::clamp(static_cast<int>(phi / (2 * kPi) * kPhi), 0, kPhi - 1);
    return iz * kPhi + ip;
  };
  Rng rng(seed, 0);
  for (int i = 0; i < kN; ++i) {
    const float uc = rng.uniform();
    const Vec2 u(rng.uniform(), rng.uniform());
    const auto s = bsdf.sample(wo, uc, u, mode);
    if (!s || s->delta) continue;
    const RGB w = s->f * (abs_cos_theta(s->wi) / s->pdf);
    const int b = bin_of(s->wi);
    for (int k = 0; k < 3; ++k) {
      const double v = k == 0 ? w.r : k == 1 ? w.g : w.b;
      s_sum[b * 3 + k] += v;
      s_sq[b * 3 + k] += v * v;
    }
  }
  const double bin_area = (2.0 / kZ) * (2 * kPi / kPhi);
  for (int iz = 0; iz < kZ; ++iz)
    for (int ip = 0; ip < kPhi; ++ip) {
      const int b = iz * kPhi + ip;
      double sum[3] = {0, 0, 0}, sq[3] = {0, 0, 0};
      for (int a = 0; a < kJ; ++a)
        for (int c = 0; c < kJ; ++c) {
          const float z = -1.0f + 2.0f * (iz + (a + rng.uniform()) / kJ) / kZ;
          const float phi = 2 * kPi * (ip + (c + rng.uniform()) / kJ) / kPhi;
          const float r = safe_sqrt(1 - z * z);
          const Vec3 wi(r * std::cos(phi), r * std::sin(phi), z);
          const RGB f = bsdf.eval(wo, wi, mode) * (std::abs(z) * bin_area);
          for (int k = 0; k < 3; ++k) {
            const double v = k == 0 ? f.r : k == 1 ? f.g : f.b;
            sum[k] += v;
            sq[k] += v * v;
          }
        }
      for (int k = 0; k < 3; ++k) {
        const double n = kJ * kJ, mean = sum[k] / n;
        e_mean[b * 3 + k] = mean;
        e_var[b * 3 + k] = std::max(0.0, sq[k] / n - mean * mean) / n;
      }
    }
  double tot_s[3] = {0, 0, 0}, tot_e[3] = {0, 0, 0}, var_s[3] = {0, 0, 0}, var_e[3] = {0, 0, 0};
  int failures = 0;
  for (int b = 0; b < kBins; ++b)
    for (int k = 0; k < 3; ++k) {
      const double ms = s_sum[b * 3 + k] / kN;
      const double vs = std::max(0.0, s_sq[b * 3 + k] / kN - ms * ms) / kN;
      const double me = e_mean[b * 3 + k], ve = e_var[b * 3 + k];
      tot_s[k] += ms, tot_e[k] += me, var_s[k] += vs, var_e[k] += ve;
      if (std::abs(ms - me) > 5 * std::sqrt(vs + ve) + 2e-3) {
        if (++failures <= 5)
          ADD_FAILURE() << "bin z " << b / kPhi << " phi " << b % kPhi << " channel " << k << ": sampled " << ms
                        << ", eval " << me << " (+- " << std::sqrt(vs + ve) << ")";
      }
    }
  for (int k = 0; k < 3; ++k) {
    std::printf("walk consistency channel %d: sampled albedo %.4f, eval %.4f (+- %.4f)\n", k, tot_s[k], tot_e[k],
                std::sqrt(var_s[k] + var_e[k]));
    EXPECT_NEAR(tot_s[k], tot_e[k], 5 * std::sqrt(var_s[k] + var_e[k]) + 2e-3) << "channel " << k;
  }
}

TEST(Multiscatter, SampleAndEvalAreOneBsdf) {
  Material metal = multi(MaterialType::Conductor, 0.64f, RGB(0.9f, 0.6f, 0.3f));
  metal.conductor_fresnel = ConductorFresnel::Principled;
  metal.ior = 1.5f;
  Material aniso = multi(MaterialType::Conductor, 0.5f, RGB(0.9f, 0.6f, 0.3f));
  aniso.anisotropy = 0.5f;
  Material principled = multi(MaterialType::Principled, 0.4f, RGB(0.5f, 0.3f, 0.2f));
  principled.ior = 1.5f;
  const Material glossy = multi(MaterialType::Conductor, 0.6f, RGB(0.9f, 0.6f, 0.3f));
  const Material white = multi(MaterialType::Conductor, 1.0f);
  const Material glass = multi(MaterialType::Dielectric, 0.5f, RGB(0.9f, 0.8f, 0.7f));
  // Cycles' Principled glass: refractions tinted red, reflections by cspec0's Fresnel blend.
  Material pglass = multi(MaterialType::Dielectric, 0.5f, RGB(0.8f, 0.15f, 0.05f));
  pglass.principled_glass = true;
  pglass.specular_tint = 0.6f;
  const struct {
    const char* name;
    Material m;
    float cos_o;
    TransportMode mode;
  } cases[] = {
      {"white glossy alpha 1", white, 0.5f, TransportMode::Radiance},
      {"coloured glossy alpha 0.6", glossy, 0.3f, TransportMode::Radiance},
      {"glossy from below", glossy, -0.7f, TransportMode::Radiance},
      {"principled metal alpha 0.64", metal, 0.6f, TransportMode::Radiance},
      {"anisotropic glossy", aniso, 0.5f, TransportMode::Radiance},
      {"principled alpha 0.4", principled, 0.5f, TransportMode::Radiance},
      {"mix of walk and diffuse", mix(glossy, make(MaterialType::Diffuse, 0, RGB(0.5f)), 0.4f), 0.5f,
       TransportMode::Radiance},
      {"glass outside, radiance", glass, 0.6f, TransportMode::Radiance},
      {"glass outside, importance", glass, 0.6f, TransportMode::Importance},
      {"glass inside, radiance", glass, -0.8f, TransportMode::Radiance},
      {"glass inside, importance", glass, -0.3f, TransportMode::Importance},
      {"principled glass outside, radiance", pglass, 0.6f, TransportMode::Radiance},
      {"principled glass inside, radiance", pglass, -0.8f, TransportMode::Radiance},
  };
  uint64_t seed = 700;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    std::printf("%s\n", c.name);
    check_walk_consistency(c.m, wo_at(c.cos_o), c.mode, seed++);
  }
}

TEST(Multiscatter, EvalIsAPureFunctionOfItsPointAndDirections) {
  // One walk per call, its stream keyed by the directions and the shading point: the same call
  // gives the same value; another point another estimate of the same f.
  const Material m = multi(MaterialType::Conductor, 0.8f);
  const Vec3 wo = wo_at(0.5f), wi = wo_at(0.4f, 2.5f);
  EXPECT_EQ(Bsdf(m).eval(wo, wi).r, Bsdf(m).eval(wo, wi).r);
  shading::ShadingContext a = shading::ShadingContext::at_uv(Vec2(0.1f, 0.2f)), b = a;
  b.P = Vec3(1, 2, 3);
  double sum = 0;
  int differ = 0;
  for (int i = 0; i < 64; ++i) {
    b.P.x = static_cast<float>(i);
    const float f = Bsdf(m, b).eval(wo, wi).r;
    differ += f != Bsdf(m, a).eval(wo, wi).r;
    sum += f;
  }
  EXPECT_GT(differ, 48);
  EXPECT_TRUE(std::isfinite(sum));
  // The walk lies behind what Bsdf tells the integrators: eval is stochastic, sample flags it.
  EXPECT_TRUE(Bsdf(m).is_stochastic());
  EXPECT_FALSE(Bsdf(make(MaterialType::Conductor, 0.8f)).is_stochastic());
  const auto s = Bsdf(m).sample(wo, 0.5f, Vec2(0.3f, 0.7f));
  ASSERT_TRUE(s);
  EXPECT_TRUE(s->stochastic);
}

TEST(BsdfFurnace, BeckmannGlassImportanceAlbedoAtMostOne) {
  // Importance mode: each sample weighs at most G1(wo) G1(wi) / (D cos-sampling's) ... the
  // albedo is at most 1 and close to GGX's single scattering for the same alpha.
  for (float alpha : {0.1f, 0.4f})
    for (float c : {0.9f, 0.5f, -0.5f}) {
      SCOPED_TRACE(fmt::format("alpha {} cos_o {}", alpha, c));
      Material m = make(MaterialType::Dielectric, alpha, RGB(1.0f), 1.5f);
      m.distribution = Microfacet::Beckmann;
      const auto [mean, max_weight] = albedo(Bsdf(m), wo_at(c), TransportMode::Importance, 100000, 47);
      (void)max_weight;
      EXPECT_LE(mean, 1.0 + 2e-3);
      EXPECT_GT(mean, 0.8);
    }
}

}  // namespace
}  // namespace gp
