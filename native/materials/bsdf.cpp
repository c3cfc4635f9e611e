// BSDFs of the closed material set: Lambertian diffuse, conductor (smooth mirror or GGX
// microfacet with Schlick Fresnel) and dielectric (smooth or GGX rough glass after Walter et
// al. 2007, arranged as pbrt-v4's DielectricBxDF), plus the black BSDF of emission-only
// materials; and two layered ones: plastic (a GGX dielectric coat over a Fresnel-weighted
// diffuse base) and mix/add of two materials.
//
// Every BSDF is two-sided: wo may lie on either side of the shading frame. Diffuse and
// conductor mirror themselves into the hemisphere of wo; the dielectric treats +z as the
// outside (IOR 1) and -z as the inside (IOR material.ior), so wo.z < 0 inverts eta.
//
// References:
//   [Walter07] Walter, Marschner, Li, Torrance 2007, "Microfacet Models for Refraction
//              through Rough Surfaces" (EGSR).
//   [Heitz14]  Heitz 2014, "Understanding the Masking-Shadowing Function in
//              Microfacet-Based BRDFs" (JCGT 3(2)).
//   [Heitz18]  Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)).
//   [Veach97]  Veach 1997, thesis, ch. 5 (non-symmetric scattering at refraction).
//   [pbrt-v4]  Pharr, Jakob, Humphreys, "Physically Based Rendering", 4th ed., ch. 9.
//   [KC17]     Kulla, Conty 2017, "Revisiting Physically Based Shading at Imageworks" (SIGGRAPH
//              course), energy compensation: (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg)).
#include "materials/bsdf.h"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include "core/frame.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "shading/thread_registers.h"
#include "materials/spectral_material.h"

namespace gp {

namespace {

// ---- GGX (Trowbridge–Reitz) microfacet distribution, isotropic ----

// Anisotropic (alpha_y >= 0: alpha along local x, alpha_y along y) by [Heitz14] eq. 85 / 86 and
// [Heitz18]'s stretch by (alpha_x, alpha_y); isotropic (alpha_y < 0) by the forms below.
struct Ggx {
  static constexpr bool kVisibleNormals = true;  // sample_visible draws only normals facing w
  float alpha;
  float alpha_y = -1.0f;
  bool separable = false;  // isotropic G as G1(wo) G1(wi) (BsdfParams::separable_masking)

  // Normal distribution, [Walter07] eq. 33, written as alpha^2 / (pi (sin^2 + alpha^2 cos^2)^2)
  // with sin^2 = x^2 + y^2 so that it stays accurate near the pole (1 - z^2 would cancel).
  // wm must be unit length and face +z (the chi+ factor).
  float D(const Vec3& wm) const {
    if (wm.z <= 0) return 0;
    if (alpha_y >= 0) {  // [Heitz14] eq. 85: 1 / (pi ax ay (x^2 / ax^2 + y^2 / ay^2 + z^2)^2)
      const float d = sqr(wm.x / alpha) + sqr(wm.y / alpha_y) + wm.z * wm.z;
      return d > 0 ? 1.0f / (kPi * alpha * alpha_y * d * d) : 0.0f;
    }
    const float a2 = alpha * alpha;
    const float d = wm.x * wm.x + wm.y * wm.y + a2 * wm.z * wm.z;
    if (d <= 0) return 0;
    return a2 / (kPi * d * d);
  }

  // Smith auxiliary function Lambda, [Heitz14] eq. 86: (sqrt(1 + alpha^2 tan^2) - 1) / 2.
  float lambda(const Vec3& w) const {
    const float z2 = w.z * w.z;
    if (z2 == 0) return kInfinity;
    // Anisotropic: alpha^2 tan^2 becomes (ax^2 x^2 + ay^2 y^2) / z^2 ([Heitz14] eq. 86).
    const float a2_tan2 = alpha_y >= 0 ? (sqr(alpha * w.x) + sqr(alpha_y * w.y)) / z2
                                       : alpha * alpha * (w.x * w.x + w.y * w.y) / z2;
    // Rewritten as a2_tan2 / (2 (1 + sqrt(1 + a2_tan2))) to avoid cancellation for small alpha.
    return a2_tan2 / (2.0f * (1.0f + std::sqrt(1.0f + a2_tan2)));
  }

  // Smith masking, [Heitz14] eq. 43.
  float G1(const Vec3& w) const { return 1.0f / (1.0f + lambda(w)); }

  // Height-correlated masking-shadowing, [Heitz14] eq. 99; anisotropic, the separable
  // G1(wo) G1(wi) of Cycles 3.4's anisotropic branch (bsdf_microfacet.h eval_reflect), which a
  // strongly stretched lobe tells apart (alpha_y 0.8: 3.5 % brighter correlated). `separable`:
  // the isotropic case as Cycles 3.4 computes it too ("eq. 34" G1o G1i in the same function).
  float G(const Vec3& wo, const Vec3& wi) const {
    if (alpha_y >= 0 || separable) return G1(wo) * G1(wi);
    return 1.0f / (1.0f + lambda(wo) + lambda(wi));
  }

  // Distribution of normals visible from w, [Heitz14] eq. 38 / [Heitz18] eq. 2:
  // D_w(wm) = G1(w) max(0, w.wm) D(wm) / cos(w). Two-sided: w below the surface is mirrored.
  float D_visible(const Vec3& w, const Vec3& wm) const {
    const float cos_w = std::abs(w.z);
    if (cos_w == 0) return 0;
    return G1(w) / cos_w * D(wm) * absdot(w, wm);
  }

  // Samples D_visible, [Heitz18] listing 1, with the polar disk warp of its §4.2.
  Vec3 sample_visible(Vec3 w, Vec2 u) const {
    if (w.z < 0) w = -w;  // two-sided: sample the normals visible from the mirrored direction
    return sample_visible_from(w, u);
  }
  // The same for any w, below the horizon too (the normals of the upper hemisphere that face
  // w: the random walk's rays going up meet them). [Heitz18]'s warp holds for wh.z < 0 as
  // well: the squashed half disk then lies inside the upper one (s < 1/2).
  Vec3 sample_visible_from(const Vec3& w, Vec2 u) const {
    // §3.2: stretch the view direction into the hemisphere configuration.
    const float ay = alpha_y >= 0 ? alpha_y : alpha;
    const Vec3 wh = normalize(Vec3(alpha * w.x, ay * w.y, w.z));
    // §4.1: orthonormal basis around wh (any T1 when wh is the pole).
    const float len2 = wh.x * wh.x + wh.y * wh.y;
    const Vec3 t1 = len2 > 0 ? Vec3(-wh.y, wh.x, 0) / std::sqrt(len2) : Vec3(1, 0, 0);
    const Vec3 t2 = cross(wh, t1);
    // §4.2: uniform point on the projected area: a disk whose lower half is squashed.
    const float r = std::sqrt(u.x);
    const float phi = 2.0f * kPi * u.y;
    const float p1 = r * std::cos(phi);
    float p2 = r * std::sin(phi);
    const float s = 0.5f * (1.0f + wh.z);
    p2 = (1.0f - s) * safe_sqrt(1.0f - p1 * p1) + s * p2;
    // §4.3: reproject onto the hemisphere.
    const Vec3 nh = t1 * p1 + t2 * p2 + wh * safe_sqrt(1.0f - p1 * p1 - p2 * p2);
    // §3.4: unstretch. z is kept off 0 (as pbrt-v4) so wm never lies in the tangent plane.
    return normalize(Vec3(alpha * nh.x, ay * nh.y, std::max(1e-6f, nh.z)));
  }
};

// Cycles 3.4's Anisotropic BSDF roughness (svm_closure.h): alpha_x = alpha (1 - an), alpha_y =
// alpha / (1 - an) for an >= 0, alpha_x = alpha / (1 + an), alpha_y = alpha (1 + an) below, an
// clamped to [-0.99, 0.99]; alpha_x alpha_y = alpha^2 either way. Both saturated, as Cycles'
// setup does.
void anisotropic_alphas(float alpha, float an, float* ax, float* ay) {
  an = clamp(an, -0.99f, 0.99f);
  if (an < 0) *ax = alpha / (1.0f + an), *ay = alpha * (1.0f + an);
  else *ax = alpha * (1.0f - an), *ay = alpha / (1.0f - an);
  *ax = clamp(*ax, 0.0f, 1.0f), *ay = clamp(*ay, 0.0f, 1.0f);
}
// Cycles' isotropic case: |an| <= 1e-4 (or alpha 0: a mirror either way).
bool is_anisotropic(const BsdfParams& m) { return std::abs(m.anisotropy) > 1e-4f && m.roughness > 0.0f; }

// The GGX distribution of a conductor's or principled's lobe.
Ggx ggx_of(const BsdfParams& m) {
  Ggx g{m.roughness};
  g.separable = m.separable_masking;
  if (is_anisotropic(m)) anisotropic_alphas(m.roughness, m.anisotropy, &g.alpha, &g.alpha_y);
  return g;
}

// ---- Fresnel ----

// x^5 of x clamped to [0, 1] (Schlick's weight (1 - cos)^5).
float pow5(float x) {
  const float m = clamp(x, 0.0f, 1.0f);
  return (m * m) * (m * m) * m;
}

// Schlick 1994 approximation with per-channel normal-incidence reflectance f0.
RGB fresnel_schlick(const RGB& f0, float cos_i) { return f0 + (RGB(1.0f) - f0) * pow5(1.0f - cos_i); }

// Mirror direction about the shading normal.
Vec3 mirror_z(const Vec3& w) { return {-w.x, -w.y, w.z}; }

bool valid_sample(const RGB& f, float pdf) {
  return pdf > 0 && std::isfinite(pdf) && f.is_finite();
}

// ---- Bump shadowing (Cycles' diffuse closures under a normal or bump map) ----
//
// Chiang, Li, Burley 2019, "Taming the Shadow Terminator" (SIGGRAPH Talks), eq. 3-4: a diffuse
// lobe whose shading normal n a map has bent away from the surface's smooth normal n_s is
// scaled by G = min(1, (n_s.w) / ((n.w)(n_s.n))) for the light's direction w, smoothed as
// -G^3 + G^2 + G; 0 where w is below n_s. Cycles 3.4 applies it to every diffuse closure whose
// normal differs from the smooth one, in evaluation and sampling alike (kernel/closure/bsdf.h),
// so a normal-mapped diffuse surface reflects less light arriving at grazing angles to its
// geometry (the sky, a low sun) than the bare bent cosine would.
// `m.smooth_normal` (local frame) is zero where no map bent the normal: G = 1.
float bump_shadowing_term(const Vec3& n_smooth, const Vec3& w) {
  if (w.z == 0) return 0.0f;
  const Vec3 ns = w.z < 0 ? -n_smooth : n_smooth;  // the side w lies on (two-sided BSDFs)
  const float denom = w.z * ns.z;
  if (denom == 0) return 0.0f;
  const float g = dot(ns, w) / denom;
  if (g >= 1.0f) return 1.0f;
  if (g < 0.0f) return 0.0f;
  return g * (1.0f + g * (1.0f - g));  // -g^3 + g^2 + g
}

// The term for a pair: the light arrives along wi in radiance transport, along wo in importance
// transport (photons), where the BSDF is the adjoint.
float bump_shadowing(const BsdfParams& m, const Vec3& wo, const Vec3& wi, TransportMode mode) {
  if (m.smooth_normal.x == 0 && m.smooth_normal.y == 0 && m.smooth_normal.z == 0) return 1.0f;
  return bump_shadowing_term(m.smooth_normal, mode == TransportMode::Radiance ? wi : wo);
}

// ---- Diffuse ----

// Oren-Nayar as Cycles 3.4's Diffuse BSDF computes it for Roughness sigma > 0
// (kernel/closure/bsdf_oren_nayar.h, the "qualitative" model in Fujii's improved form):
//   f = A + B s / t,  s = wi.wo - cos_i cos_o,  t = max(cos_i, cos_o) where s > 0, else 1,
//   A = 1 / (pi + (3 pi - 4) / 6 sigma),  B = sigma A,
// sigma = Blender's Roughness clamped to [0, 1] (0: Lambert's 1 / pi exactly). Two-sided: the
// cosines are taken on wo's side. Sampled by the cosine (Cycles samples the hemisphere uniformly:
// the same estimate, less noise here).
float oren_nayar(float sigma, const Vec3& wo, const Vec3& wi) {
  sigma = clamp(sigma, 0.0f, 1.0f);
  const float a = 1.0f / (kPi + (3.0f * kPi - 4.0f) / 6.0f * sigma), b = sigma * a;
  const float nl = abs_cos_theta(wi), nv = abs_cos_theta(wo);
  float t = dot(wi, wo) - nl * nv;
  if (t > 0.0f) t /= std::max(nl, nv) + std::numeric_limits<float>::min();
  return a + b * t;
}

RGB diffuse_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (!same_hemisphere(wo, wi)) return RGB(0.0f);
  return m.roughness > 0.0f ? m.color * oren_nayar(m.roughness, wo, wi) : m.color * kInvPi;
}

float diffuse_pdf(const Vec3& wo, const Vec3& wi) {
  return same_hemisphere(wo, wi) ? cosine_hemisphere_pdf(abs_cos_theta(wi)) : 0.0f;
}

std::optional<BsdfSample> diffuse_sample(const BsdfParams& m, const Vec3& wo, Vec2 u) {
  if (wo.z == 0) return std::nullopt;
  Vec3 wi = sample_cosine_hemisphere(u);
  if (wo.z < 0) wi.z = -wi.z;
  const float pdf = cosine_hemisphere_pdf(abs_cos_theta(wi));
  if (pdf <= 0) return std::nullopt;  // wi in the tangent plane
  BsdfSample s;
  s.f = m.roughness > 0.0f ? m.color * oren_nayar(m.roughness, wo, wi) : m.color * kInvPi;
  s.wi = wi;
  s.pdf = pdf;
  return s;
}

// ---- Translucent: Cycles 3.4's Translucent BSDF (kernel/closure/bsdf_diffuse.h) ----
//
// Lambertian transmission: f = color / pi for wi on the side opposite wo, cosine-sampled there.

RGB translucent_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  return wo.z * wi.z < 0 ? m.color * kInvPi : RGB(0.0f);
}

float translucent_pdf(const Vec3& wo, const Vec3& wi) {
  return wo.z * wi.z < 0 ? cosine_hemisphere_pdf(abs_cos_theta(wi)) : 0.0f;
}

std::optional<BsdfSample> translucent_sample(const BsdfParams& m, const Vec3& wo, Vec2 u) {
  if (wo.z == 0) return std::nullopt;
  Vec3 wi = sample_cosine_hemisphere(u);
  if (wo.z > 0) wi.z = -wi.z;
  const float pdf = cosine_hemisphere_pdf(abs_cos_theta(wi));
  if (pdf <= 0) return std::nullopt;
  BsdfSample s;
  s.f = m.color * kInvPi;
  s.wi = wi;
  s.pdf = pdf;
  s.transmission = true;
  return s;
}

// ---- Velvet: Cycles 3.4's Velvet BSDF (kernel/closure/bsdf_ashikhmin_velvet.h) ----
//
// Ashikhmin, Premoze, Shirley 2000's velvet distribution with Cycles' shadowing term:
//   f = D G / (4 cos_o cos_i),  h = normalize(wo + wi),
//   D = exp(-cot^2(theta_h) / sigma^2) / (pi sigma^2 sin^4(theta_h)),
//   G = min(1, 2 (cos_h / |wo.h|) cos_o, 2 (cos_h / |wo.h|) cos_i),
// sigma = Blender's Sigma clamped to [0.01, 1]; zero where cos_h or |wo.h| degenerate (as
// Cycles). Sampled uniformly over wo's hemisphere, as Cycles.

float velvet(float sigma, const Vec3& wo, const Vec3& wi) {
  const float cos_o = abs_cos_theta(wo), cos_i = abs_cos_theta(wi);
  if (cos_o == 0 || cos_i == 0) return 0.0f;
  Vec3 h = wi + wo;
  if (length_squared(h) == 0) return 0.0f;
  h = normalize(h);
  const float cos_h = abs_cos_theta(h), cos_ho = absdot(wo, h);
  if (!(cos_h < 1.0f - 1e-5f && cos_ho > 1e-5f)) return 0.0f;
  sigma = clamp(sigma, 0.01f, 1.0f);
  const float inv_sigma2 = 1.0f / (sigma * sigma);
  const float ratio = std::max(cos_h / cos_ho, 1e-5f);
  const float G = std::min(1.0f, std::min(2.0f * ratio * cos_o, 2.0f * ratio * cos_i));
  const float sin2_h = 1.0f - cos_h * cos_h;
  const float cot2_h = cos_h * cos_h / sin2_h;
  const float D = std::exp(-cot2_h * inv_sigma2) * inv_sigma2 * kInvPi / (sin2_h * sin2_h);
  return 0.25f * D * G / (cos_o * cos_i);
}

RGB velvet_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  return same_hemisphere(wo, wi) ? m.color * velvet(m.roughness, wo, wi) : RGB(0.0f);
}

float velvet_pdf(const Vec3& wo, const Vec3& wi) {
  return same_hemisphere(wo, wi) && wi.z != 0 ? uniform_hemisphere_pdf() : 0.0f;
}

std::optional<BsdfSample> velvet_sample(const BsdfParams& m, const Vec3& wo, Vec2 u) {
  if (wo.z == 0) return std::nullopt;
  Vec3 wi = sample_uniform_hemisphere(u);
  if (wo.z < 0) wi.z = -wi.z;
  if (wi.z == 0) return std::nullopt;
  BsdfSample s;
  s.wi = wi;
  s.pdf = uniform_hemisphere_pdf();
  s.f = m.color * velvet(m.roughness, wo, wi);
  return s;
}

// ---- Multiscatter GGX: the random walk of Heitz, Hanika, d'Eon, Dachsbacher 2016 ----
//
// [Heitz16] "Multiple-Scattering Microfacet BSDFs with the Smith Model" (SIGGRAPH 2016), in the
// form Cycles 3.4 renders Blender's Multiscatter GGX with (kernel/closure/bsdf_microfacet_multi.h
// and bsdf_microfacet_multi_impl.h). The microsurface is a random medium: heights uniform in
// [-1, 1] (C1(h) = (h + 1) / 2), GGX normals. A ray meets it at a height drawn from the masking
// C1(h)^Lambda(w) ([Heitz16] §3.2, with Lambda signed: -1 - Lambda(-w) for a ray going down),
// scatters on a normal visible from it ([Heitz18]) and goes on until it escapes, at most
// kWalkOrders times (Cycles' bound; the rest is lost, as in Cycles).
//   sample: one walk from wo; wi is where it escapes, its weight the walk's throughput (the
//     product of the microfacets' Fresnel factor or colour; a dielectric's walk picks reflection
//     or refraction by Fresnel and carries flux: the importance form, as this file's glass).
//   eval: f(wo, wi) |cos wi| estimated by one walk ([Heitz16] §5): the first scattering analytic
//     (the height-correlated single-scattering BSDF, [Heitz14] eq. 99 and its transmission
//     form B(1 + Lambda_o, 1 + Lambda_i)), each later one adding its next-event estimate toward
//     wi (phase function x shadowing from the walk's height). Unbiased, not deterministic;
//     reflection walks start from the shallower direction (f is reciprocal; less noise).
//   pdf: there is no closed form; Cycles' stand-in (mf_ggx_pdf, mf_glass_pdf): the single-
//     scattering density weighted by a fit of single scattering's albedo, plus a cosine lobe for
//     the rest. sample() reports it as pdf with f = weight x pdf / |cos wi|, so f |cos| / pdf is
//     the walk's weight and MIS weights are a function of the direction alone: unbiased.
// Unlike Cycles 3.4, where its walk is inconsistent (each measured in bsdf_test.cpp and
// docs/blender.md): heights by [Heitz16] eq. 13 whichever way the ray goes (Cycles' puts a ray
// going up that meets the surface at its top, C1 = 1, which makes its walk non-reciprocal: its
// eval, walked from the shallower direction, reflects 3 % less than its sampler at alpha 1); the
// conductor's eval weights the k-th later scattering by the Fresnel products of the walk and of
// its last microfacet, as sample does (Cycles' mf_eval multiplies the throughput in twice:
// colour^(2k+1) where its sample has colour^(k+1); the same for white), with Fresnel at the drawn
// microfacets from the first one on; the glass walk's C1 follows its height when it crosses the
// interface (Cycles' mf_sample keeps the old C1 there); the glass stand-in pdf has a floor
// (walk_pdf_dielectric).
// The walk's random numbers are a PCG stream keyed by what the call sees (the directions or the
// sample's numbers, and the shading point: BsdfParams::walk_salt), so eval and sample stay pure
// functions and images do not depend on the thread count. A fixed point, fixed directions (a PPM
// visible point under a point light) therefore sees one walk, every pass.

constexpr int kWalkOrders = 10;

uint64_t walk_key(uint64_t salt, const Vec3& a, const Vec3& b) {
  uint64_t k = salt;
  for (float v : {a.x, a.y, a.z, b.x, b.y, b.z}) {
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    k = mix_bits(k + bits + 0x9E3779B97F4A7C15ULL);
  }
  return k;
}
Rng walk_rng(uint64_t key) { return Rng(key, mix_bits(key ^ 0xD1B54A32D192ED03ULL)); }

// Cycles' mf_lambda: Smith's Lambda of the (possibly anisotropic) GGX, signed by w.z.
float walk_lambda(const Ggx& g, const Vec3& w) {
  if (w.z > 0.9999f) return 0.0f;
  if (w.z < -0.9999f) return -0.9999f;
  const float ay = g.alpha_y >= 0 ? g.alpha_y : g.alpha;
  const float inv_z2 = 1.0f / std::max(w.z * w.z, 1e-7f);
  float v = std::sqrt(1.0f + (sqr(g.alpha * w.x) + sqr(ay * w.y)) * inv_z2);
  if (w.z <= 0.0f) v = -v;
  return 0.5f * (v - 1.0f);
}
float walk_C1(float h) { return clamp(0.5f * (h + 1.0f), 0.0f, 1.0f); }
float walk_invC1(float c) { return 2.0f * clamp(c, 0.0f, 1.0f) - 1.0f; }
// The probability that w escapes from the height of C1 = c1 ([Heitz16] eq. 8: C1^Lambda).
float walk_G1(const Vec3& w, float c1, float lambda) {
  if (w.z > 0.9999f) return 1.0f;
  if (w.z < 1e-5f) return 0.0f;
  return std::pow(c1, lambda);
}

// A ray of the walk: its direction, height h, C1(h), escape probability g1 and Lambda.
struct WalkRay {
  Vec3 w;
  float lambda = 0, h = 1, c1 = 1, g1 = 0;
  void turn(const Ggx& g, const Vec3& to) {
    w = to;
    lambda = walk_lambda(g, w);
    c1 = walk_C1(h);
    g1 = walk_G1(w, c1, lambda);
  }
};

// The next height the ray meets the surface at ([Heitz16] §3.2, Cycles' mf_sample_height);
// false when it escapes.
bool walk_height(WalkRay& r, float u) {
  if (r.w.z > 0.9999f) return false;
  if (r.w.z < -0.9999f) {
    r.c1 *= u;
  } else if (std::abs(r.w.z) >= 1e-4f) {
    if (u > 1.0f - r.g1) return false;
    // [Heitz16] eq. 13 for either way the ray goes (Cycles 3.4 puts a ray going up that meets
    // the surface at its top, C1 = 1, which makes its walk non-reciprocal: its eval, walked from
    // the shallower direction, then reflects 3 % less than its sampler at alpha 1).
    r.c1 = std::min(1.0f, r.c1 * std::pow(1.0f - u, -1.0f / r.lambda));
    if (!(r.c1 >= 0.0f)) r.c1 = 0.0f;  // 0 x inf at the bottom
  } else {
    return true;  // grazing: it meets the surface where it is
  }
  r.h = walk_invC1(r.c1);
  r.g1 = walk_G1(r.w, r.c1, r.lambda);
  return true;
}

// The ray's projected area in the microsurface, (1 + Lambda(-w)) |w.z| ([Heitz16] eq. 3).
float walk_area(const Vec3& w, float lambda) { return w.z < -0.9999f ? 1.0f : lambda * w.z; }

// Phase function of a reflecting microsurface: the density of scattering the ray w into o
// ([Heitz16] eq. 22: D_w(wh) / (4 |o.wh|) with D_w = <-w, wh> D / area); *cos_h = <-w, wh>.
float walk_phase_reflect(const Ggx& g, const WalkRay& r, const Vec3& o, float* cos_h) {
  if (r.w.z > 0.9999f) return 0.0f;
  const Vec3 d = o - r.w;
  if (length_squared(d) == 0) return 0.0f;
  const Vec3 wh = normalize(d);
  const float c = -dot(r.w, wh);
  if (wh.z < 0.0f || c <= 0.0f) return 0.0f;
  *cos_h = c;
  return 0.25f * g.D(wh) / std::max(walk_area(r.w, r.lambda), 1e-7f);
}

// Phase function of a dielectric microsurface of relative IOR eta below it ([Heitz16] eq. 24):
// reflection F D_w / (4 |o.wh|), refraction (1 - F) D_w eta^2 |o.wh| / (<-w, wh> + eta <o, wh>)^2
// ([Walter07] eq. 17's Jacobian: the density of a flux-carrying walk; Cycles leaves out eta^2).
float walk_phase_dielectric(const Ggx& g, const WalkRay& r, const Vec3& o, bool o_outside, float eta) {
  if (r.w.z > 0.9999f) return 0.0f;
  const float area = std::max(walk_area(r.w, r.lambda), 1e-7f);
  if (o_outside) {
    const Vec3 d = o - r.w;
    if (length_squared(d) == 0) return 0.0f;
    const Vec3 wh = normalize(d);
    const float c = -dot(r.w, wh);
    if (wh.z < 0.0f || c <= 0.0f) return 0.0f;
    return fresnel_dielectric(c, eta) * 0.25f * g.D(wh) / area;
  }
  const Vec3 d = o * eta - r.w;
  if (length_squared(d) == 0) return 0.0f;
  Vec3 wh = normalize(d);
  if (wh.z < 0.0f) wh = -wh;
  const float c = -dot(r.w, wh), co = dot(o, wh);
  const float t = c + eta * co;
  if (c <= 0.0f || co >= 0.0f || t == 0.0f) return 0.0f;
  return (1.0f - fresnel_dielectric(c, eta)) * c * -co * g.D(wh) * eta * eta / (area * t * t);
}

// The ray arriving along -wi at microfacet wm (wi.wm > 0) of relative IOR eta: reflected with
// probability F, else refracted (Snell).
Vec3 walk_scatter_dielectric(const Vec3& wi, const Vec3& wm, float eta, float u, bool* refracted) {
  const float c = dot(wi, wm);
  *refracted = !(u < fresnel_dielectric(c, eta));
  if (!*refracted) return wm * (2.0f * c) - wi;
  const float inv = 1.0f / eta;
  const float cos_t = -safe_sqrt(1.0f - (1.0f - c * c) * inv * inv);
  return normalize(wm * (c * inv + cos_t) - wi * inv);
}

// Cycles' fits (bsdf_microfacet_multi.h mf_ggx_albedo, mf_ggx_transmission_albedo) of single
// scattering's albedo: the share of the stand-in pdf given to the single-scattering density.
float walk_albedo_fit(float r) {
  float albedo = 0.806495f * std::exp(-1.98712f * r * r) + 0.199531f;
  albedo -= ((((((1.76741f * r - 8.43891f) * r + 15.784f) * r - 14.398f) * r + 6.45221f) * r - 1.19722f) * r +
             0.027803f) * r + 0.00568739f;
  return clamp(albedo, 0.0f, 1.0f);
}
float walk_transmission_albedo_fit(float a, float ior) {
  if (ior < 1.0f) ior = 1.0f / ior;
  a = clamp(a, 0.0f, 1.0f);
  ior = clamp(ior, 1.0f, 3.0f);
  const float i1 = 0.0476898f * std::exp(-0.978352f * sqr(ior - 0.65657f)) - 0.033756f * ior + 0.993261f;
  const float r1 = (((0.116991f * a - 0.270369f) * a + 0.0501366f) * a - 0.00411511f) * a + 1.00008f;
  const float i2 = (((-2.08704f * ior + 26.3298f) * ior - 127.906f) * ior + 292.958f) * ior - 287.946f +
                   199.803f / (ior * ior) - 101.668f / (ior * ior * ior);
  const float r2 = ((((5.3725f * a - 24.9307f) * a + 22.7437f) * a - 3.40751f) * a + 0.0986325f) * a + 0.00493504f;
  return clamp(1.0f + i2 * r2 * 0.0019127f - (1.0f - i1) * (1.0f - r1) * 9.3205f, 0.0f, 1.0f);
}

// The stand-in pdf of a reflecting walk from a to b (both up; Cycles' mf_ggx_pdf / _aniso_pdf).
float walk_pdf_reflect(const Ggx& g, const Vec3& a, const Vec3& b) {
  const Vec3 h = a + b;
  const float single = length_squared(h) > 0
                           ? 0.25f * g.D(normalize(h)) / std::max((1.0f + walk_lambda(g, a)) * a.z, 1e-7f)
                           : 0.0f;
  const float albedo = walk_albedo_fit(g.alpha_y >= 0 ? std::sqrt(g.alpha * g.alpha_y) : g.alpha);
  return albedo * single + (1.0f - albedo) * std::abs(b.z) * kInvPi;
}

// The same for a dielectric walk from a (up) to b (either side; Cycles' mf_glass_pdf).
float walk_pdf_dielectric(const Ggx& g, const Vec3& a, const Vec3& b, float eta) {
  const bool reflective = a.z * b.z > 0.0f;
  const Vec3 h = a + (reflective ? b : b * eta);
  const float len2 = length_squared(h);
  if (len2 == 0) return 0.0f;
  Vec3 wh = h / std::sqrt(len2);
  if (wh.z < 0.0f) wh = -wh;
  const float lambda = walk_lambda(g, a), D = g.D(wh);
  const float F = fresnel_dielectric(dot(a, wh), eta);
  const float multi = std::abs(b.z) * kInvPi;
  if (reflective) {
    const float albedo = walk_albedo_fit(g.alpha);
    return F * (albedo * 0.25f * D / std::max((1.0f + lambda) * a.z, 1e-7f) + (1.0f - albedo) * multi);
  }
  const float single = std::abs(dot(a, wh) * dot(b, wh) * D * eta * eta / std::max((1.0f + lambda) * a.z * len2, 1e-7f));
  const float albedo = walk_transmission_albedo_fit(g.alpha, eta);
  // Cycles' stand-in is 0 where no single microfacet refracts a into b (F = 1 at the generalized
  // half vector), though walks leave there: its sampler then drops them (light lost). A floor of
  // a tenth of the cosine lobe keeps those samples; the stand-in only weighs MIS.
  return std::max((1.0f - F) * (albedo * single + (1.0f - albedo) * multi), 0.1f * multi);
}

// f(a, b) |b.z| of a reflecting microsurface (a, b up) whose microfacets reflect fresnel(cos),
// estimated by one walk.
template <class Fresnel>
RGB walk_eval_reflect(const Ggx& g, Vec3 a, Vec3 b, const Fresnel& fresnel, Rng& rng) {
  const bool swapped = b.z < a.z;
  if (swapped) std::swap(a, b);
  if (a.z < 1e-5f || b.z < 1e-5f) return RGB(0.0f);
  WalkRay r;
  r.turn(g, -a);
  const float lambda_b = walk_lambda(g, b);
  // Single scattering: D G2 F / (4 a.z) with G2 = 1 / (1 + Lambda(a) + Lambda(b)).
  const Vec3 wh = normalize(a + b);
  RGB f = fresnel(dot(a, wh)) * (0.25f * g.D(wh) / (a.z * (lambda_b - r.lambda)));
  RGB throughput(1.0f);
  for (int order = 0; order < kWalkOrders; ++order) {
    if (!walk_height(r, rng.uniform())) break;
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const Vec3 wm = g.sample_visible_from(-r.w, Vec2(u1, u2));
    if (order > 0) {  // next-event estimate toward b ([Heitz16] §5.2)
      float cos_h = 0.0f;
      const float phase = walk_phase_reflect(g, r, b, &cos_h);
      if (phase > 0.0f) f += throughput * fresnel(cos_h) * (phase * walk_G1(b, walk_C1(r.h), lambda_b));
    }
    if (order + 1 < kWalkOrders) {
      throughput *= fresnel(-dot(r.w, wm));
      r.turn(g, r.w - wm * (2.0f * dot(r.w, wm)));
    }
  }
  if (swapped) f *= a.z / b.z;  // f (a, b) |b.z| from f (b, a) |a.z|
  return f;
}

struct WalkExit {
  Vec3 w;
  RGB weight;
};

// One walk from a (up) on a reflecting microsurface: where it escapes and its throughput.
template <class Fresnel>
std::optional<WalkExit> walk_sample_reflect(const Ggx& g, const Vec3& a, const Fresnel& fresnel, Rng& rng) {
  WalkRay r;
  r.turn(g, -a);
  RGB throughput(1.0f);
  for (int order = 0; order < kWalkOrders; ++order) {
    if (!walk_height(r, rng.uniform())) return WalkExit{r.w, throughput};
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const Vec3 wm = g.sample_visible_from(-r.w, Vec2(u1, u2));
    throughput *= fresnel(-dot(r.w, wm));
    r.turn(g, r.w - wm * (2.0f * dot(r.w, wm)));
  }
  return std::nullopt;
}

// The colour of one scattering of a dielectric walk: the glass colour at every one (Blender's
// Glass BSDF), or for Cycles 3.4's Principled glass (BsdfParams::principled_glass) the colour at
// refractions and the reflection colour (dielectric_reflection_color) at reflections, as its
// multiscatter glass walk with use_fresnel tints them (bsdf_microfacet_multi_impl.h: `color` on
// a refraction, interpolate_fresnel_color on a reflection). `interior`: the walk's start (wo's
// side, `outside` true) is inside the glass.
struct DielectricWalkTint {
  const BsdfParams& m;
  bool interior;
  // A reflection on the walk's current side at |cos| c to its microfacet.
  RGB reflection(float c, bool outside) const {
    if (!m.principled_glass) return m.color;
    return dielectric_reflection_color(m, outside != interior ? c : -c);  // < 0: from inside
  }
  RGB refraction() const { return m.color; }
};

// One scattering of a dielectric walk at microfacet normal wm (u picks reflection or
// refraction): a refracted ray crosses to the other side, where the walk goes on in the mirrored
// frame (direction and height negated, `outside` flipped). Returns the scattering's colour.
RGB walk_step_dielectric(const Ggx& g, WalkRay& r, const Vec3& wm, float eta, float u, bool& outside,
                         const DielectricWalkTint& tint) {
  bool refracted;
  const float c = -dot(r.w, wm);
  Vec3 w = walk_scatter_dielectric(-r.w, wm, outside ? eta : 1.0f / eta, u, &refracted);
  const RGB color = refracted ? tint.refraction() : tint.reflection(c, outside);
  if (refracted) {
    outside = !outside;
    w = -w;
    r.h = -r.h;
  }
  r.turn(g, w);
  return color;
}

// The cosine of a walk ray arriving along r.w with the microfacet that reflects it into o.
float walk_reflection_cos(const WalkRay& r, const Vec3& o) {
  const Vec3 d = o - r.w;
  return length_squared(d) > 0 ? std::max(0.0f, -dot(r.w, normalize(d))) : 0.0f;
}

// f(a, b) |b.z| of a dielectric microsurface (a up, relative IOR eta below; the importance
// form, as dielectric_eval's) tinted at every scattering (DielectricWalkTint), estimated by one
// walk. The walk below the interface sees the microsurface mirrored (direction and height
// negated, IOR inverted), as [Heitz16] §6 and Cycles.
RGB walk_eval_dielectric(const Ggx& g, Vec3 a, Vec3 b, float eta, const DielectricWalkTint& tint, Rng& rng) {
  bool swapped = false;
  if (b.z > 0.0f && b.z < a.z) {  // reflection only: refraction is not symmetric in (a, b)
    std::swap(a, b);
    swapped = true;
  }
  const bool b_outside = b.z > 0.0f;
  if (a.z < 1e-5f || (b_outside && b.z < 1e-5f) || (!b_outside && b.z > -1e-5f)) return RGB(0.0f);
  const Vec3 b_up = b_outside ? b : -b;
  const float lambda_b = walk_lambda(g, b_up);
  WalkRay r;
  r.turn(g, -a);
  // Single scattering with the height-correlated G ([Heitz14] eq. 99; its transmission form).
  const float area = -r.lambda;  // 1 + Lambda(a)
  float single = walk_phase_dielectric(g, r, b, b_outside, eta);
  single *= b_outside ? area / (lambda_b + area)
                      : area * std::exp(std::lgamma(area) + std::lgamma(lambda_b + 1.0f) - std::lgamma(area + lambda_b + 1.0f));
  // The colour once per scattering: tc holds it for the walk's scatterings so far.
  RGB fc = (b_outside ? tint.reflection(walk_reflection_cos(r, b), true) : tint.refraction()) * single;
  RGB tc(1.0f);
  bool outside = true;
  for (int order = 0; order < kWalkOrders; ++order) {
    if (!walk_height(r, rng.uniform())) break;
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const Vec3 wm = g.sample_visible_from(-r.w, Vec2(u1, u2));
    if (order > 0) {
      const float phase = outside ? walk_phase_dielectric(g, r, b, b_outside, eta)
                                  : walk_phase_dielectric(g, r, -b, !b_outside, 1.0f / eta);
      // The last scattering toward b: a reflection where the walk is on b's side.
      const RGB last = outside == b_outside ? tint.reflection(walk_reflection_cos(r, outside ? b : -b), outside)
                                            : tint.refraction();
      fc += tc * last * (phase * walk_G1(b_up, walk_C1(outside == b_outside ? r.h : -r.h), lambda_b));
    }
    if (order + 1 < kWalkOrders) tc *= walk_step_dielectric(g, r, wm, eta, rng.uniform(), outside, tint);
  }
  if (swapped) fc *= a.z / b.z;
  return fc;
}

// One walk from a (up) on a dielectric microsurface: where it escapes (either side) and its
// throughput (a colour per scattering, DielectricWalkTint).
std::optional<WalkExit> walk_sample_dielectric(const Ggx& g, const Vec3& a, float eta, const DielectricWalkTint& tint,
                                               Rng& rng) {
  WalkRay r;
  r.turn(g, -a);
  RGB throughput(1.0f);
  bool outside = true;
  for (int order = 0; order < kWalkOrders; ++order) {
    if (!walk_height(r, rng.uniform())) return WalkExit{outside ? r.w : -r.w, throughput};
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const Vec3 wm = g.sample_visible_from(-r.w, Vec2(u1, u2));
    throughput *= walk_step_dielectric(g, r, wm, eta, rng.uniform(), outside, tint);
  }
  return std::nullopt;
}

// ---- Multiscatter GGX lobes: conductor (any ConductorFresnel), principled's specular lobe
// (its Fresnel) and dielectric. Two-sided as the single-scattering lobes: wo below is mirrored.

constexpr uint64_t kSampleSalt = 0x5851F42D4C957F2DULL;  // sample's streams apart from eval's

template <class Fresnel>
RGB multi_reflect_eval(const BsdfParams& m, Vec3 wo, Vec3 wi, const Fresnel& fresnel) {
  if (wo.z < 0) wo = -wo, wi = -wi;
  if (!(wo.z > 0 && wi.z > 0)) return RGB(0.0f);
  Rng rng = walk_rng(walk_key(m.walk_salt, wo, wi));
  return walk_eval_reflect(ggx_of(m), wo, wi, fresnel, rng) / wi.z;
}

float multi_reflect_pdf(const BsdfParams& m, Vec3 wo, Vec3 wi) {
  if (wo.z < 0) wo = -wo, wi = -wi;
  if (!(wo.z > 0 && wi.z > 0)) return 0.0f;
  return walk_pdf_reflect(ggx_of(m), wo, wi);
}

template <class Fresnel>
std::optional<BsdfSample> multi_reflect_sample(const BsdfParams& m, const Vec3& wo, Vec2 u, const Fresnel& fresnel) {
  if (wo.z == 0) return std::nullopt;
  const float side = wo.z < 0 ? -1.0f : 1.0f;
  const Vec3 a = wo * side;
  Rng rng = walk_rng(walk_key(m.walk_salt ^ kSampleSalt, a, Vec3(u.x, u.y, 0.0f)));
  const Ggx g = ggx_of(m);
  const auto exit = walk_sample_reflect(g, a, fresnel, rng);
  if (!exit || !(exit->w.z > 0)) return std::nullopt;
  BsdfSample s;
  s.wi = exit->w * side;
  s.pdf = walk_pdf_reflect(g, a, exit->w);
  s.f = exit->weight * (s.pdf / exit->w.z);
  s.stochastic = true;
  if (!valid_sample(s.f, s.pdf)) return std::nullopt;
  return s;
}

// The dielectric seen from wo's side: wo up, eta the IOR beyond the interface over wo's.
struct DielectricSide {
  Vec3 wo, wi;
  float eta, side;
};
DielectricSide dielectric_side(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (wo.z < 0) return {-wo, -wi, 1.0f / m.ior, -1.0f};
  return {wo, wi, m.ior, 1.0f};
}

RGB dielectric_multi_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi, TransportMode mode) {
  const DielectricSide d = dielectric_side(m, wo, wi);
  if (d.wo.z == 0 || d.wi.z == 0) return RGB(0.0f);
  Rng rng = walk_rng(walk_key(m.walk_salt, d.wo, d.wi));
  RGB f = walk_eval_dielectric(Ggx{m.roughness}, d.wo, d.wi, d.eta, DielectricWalkTint{m, d.side < 0}, rng) /
          std::abs(d.wi.z);
  // Radiance crossing into wo's medium scales by 1 / etap^2 ([Veach97] §5.2), etap = eta here.
  if (d.wi.z < 0 && mode == TransportMode::Radiance) f = f / sqr(d.eta);
  return f;
}

float dielectric_multi_pdf(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  const DielectricSide d = dielectric_side(m, wo, wi);
  if (d.wo.z == 0 || d.wi.z == 0) return 0.0f;
  return walk_pdf_dielectric(Ggx{m.roughness}, d.wo, d.wi, d.eta);
}

std::optional<BsdfSample> dielectric_multi_sample(const BsdfParams& m, const Vec3& wo, float uc, Vec2 u,
                                                  TransportMode mode) {
  if (wo.z == 0) return std::nullopt;
  const DielectricSide d = dielectric_side(m, wo, wo);
  Rng rng = walk_rng(walk_key(m.walk_salt ^ kSampleSalt, d.wo, Vec3(u.x, u.y, uc)));
  const Ggx g{m.roughness};
  const auto exit = walk_sample_dielectric(g, d.wo, d.eta, DielectricWalkTint{m, d.side < 0}, rng);
  if (!exit || exit->w.z == 0) return std::nullopt;
  BsdfSample s;
  s.transmission = exit->w.z < 0;
  s.wi = exit->w * d.side;
  s.pdf = walk_pdf_dielectric(g, d.wo, exit->w, d.eta);
  RGB weight = exit->weight;
  if (s.transmission) {
    s.eta = d.eta;
    if (mode == TransportMode::Radiance) weight = weight / sqr(d.eta);
  }
  s.f = weight * (s.pdf / std::abs(exit->w.z));
  s.stochastic = true;
  if (!valid_sample(s.f, s.pdf)) return std::nullopt;
  return s;
}

// ---- Conductor ----

// Cycles 3.4's Principled metal (kernel/closure/bsdf_util.h, interpolate_fresnel_color, as
// bsdf_microfacet.h's reflection_color calls it with cos_h = L.H): the colour blended toward
// white by the dielectric Fresnel of the lobe's IOR, renormalised to 0 at normal incidence,
//   FH = (F_d(cos_h) - F0) / (1 - F0),  F = color (1 - FH) + FH,  F0 = F_d(1).
// Unclamped, as in Cycles. An IOR of 1 (Specular 0) has F_d = 0: the colour at every angle.
RGB fresnel_principled_metal(const RGB& color, float ior, float cos_h) {
  const float f0 = fresnel_dielectric(1.0f, ior);
  if (!(f0 < 1.0f)) return RGB(1.0f);
  const float fh = (fresnel_dielectric(cos_h, ior) - f0) / (1.0f - f0);
  return color * (1.0f - fh) + RGB(fh);
}

// The conductor's Fresnel factor at |cos| to the microfacet normal (ConductorFresnel).
RGB conductor_fresnel(const BsdfParams& m, float cos_i) {
  switch (m.conductor_fresnel) {
    case ConductorFresnel::None: return m.color;  // Blender's Glossy BSDF
    case ConductorFresnel::Schlick: return fresnel_schlick(m.color, cos_i);
    case ConductorFresnel::Principled: return fresnel_principled_metal(m.color, m.ior, cos_i);
  }
  return m.color;
}

// The Cook–Torrance microfacet BRDF without its Fresnel factor, D G / (4 |cos_i| |cos_o|)
// ([Walter07] eq. 20), of a pair on one side; *cos_h gets |wo . wm| for the Fresnel factor.
// 0 where the pair has no half vector.
float microfacet_reflection(const Ggx& ggx, const Vec3& wo, const Vec3& wi, float* cos_h) {
  const float cos_o = abs_cos_theta(wo), cos_i = abs_cos_theta(wi);
  if (cos_o == 0 || cos_i == 0) return 0.0f;
  Vec3 wm = wi + wo;
  if (length_squared(wm) == 0) return 0.0f;
  wm = normalize(wm);
  if (wm.z < 0) wm = -wm;
  *cos_h = absdot(wo, wm);
  return ggx.D(wm) * ggx.G(wo, wi) / (4.0f * cos_i * cos_o);
}

// ---- Beckmann and Ashikhmin-Shirley conductors (Blender's Glossy BSDF distributions) ----
//
// f as Cycles 3.4 evaluates it; sampled by the half vector's own density (D(wm) cos(wm) for
// Beckmann, [Walter07] eq. 28-29; (n + 1) / (2 pi) cos^n for Ashikhmin-Shirley) rather than
// Cycles' visible normals: the same integral, an exact pdf.

// Cycles' bsdf_beckmann_G1: Smith's G1 for Beckmann by [Walter07] eq. 27's rational fit.
float beckmann_G1(float alpha, float cos_n) {
  const float c2 = cos_n * cos_n;
  if (!(c2 > 0)) return 0.0f;
  const float inv_a = alpha * std::sqrt(std::max(0.0f, (1.0f - c2) / c2));
  if (inv_a < 0.625f) return 1.0f;
  const float a = 1.0f / inv_a;
  return ((2.181f * a + 3.535f) * a) / ((2.577f * a + 2.276f) * a + 1.0f);
}
// Beckmann D, [Walter07] eq. 25; wm unit, +z.
float beckmann_D(float alpha, const Vec3& wm) {
  if (wm.z <= 0) return 0.0f;
  const float c2 = wm.z * wm.z, a2 = alpha * alpha;
  const float tan2 = (wm.x * wm.x + wm.y * wm.y) / c2;
  return std::exp(-tan2 / a2) / (kPi * a2 * c2 * c2);
}
// Cycles' bsdf_ashikhmin_shirley_roughness_to_exponent (alpha clamped to [1e-4, 1] at setup).
float ashikhmin_shirley_exponent(float alpha) {
  const float a = std::clamp(alpha, 1e-4f, 1.0f);
  return 2.0f / (a * a) - 2.0f;
}

// Anisotropic Beckmann as Cycles 3.4 (bsdf_microfacet.h): D = exp(-(sx^2 + sy^2)) / (pi ax ay
// cos^4), slopes s = -(x / (z ax), y / (z ay)); G1 by the same rational fit of the projected
// alpha^2 = (cos^2_phi ax^2 + sin^2_phi ay^2) / (cos^2_phi + sin^2_phi) (bsdf_beckmann_aniso_G1).
float beckmann_aniso_D(float ax, float ay, const Vec3& wm) {
  if (wm.z <= 0) return 0.0f;
  const float sx = wm.x / (wm.z * ax), sy = wm.y / (wm.z * ay), c2 = wm.z * wm.z;
  return std::exp(-sx * sx - sy * sy) / (kPi * ax * ay * c2 * c2);
}
float beckmann_aniso_G1(float ax, float ay, const Vec3& w) {
  const float c2 = w.z * w.z, r2 = w.x * w.x + w.y * w.y;
  if (!(c2 > 0)) return 0.0f;
  const float a2 = r2 > 0 ? (w.x * w.x * ax * ax + w.y * w.y * ay * ay) / r2 : ax * ay;
  const float inv_a = std::sqrt(std::max(0.0f, a2 * r2 / c2));
  if (inv_a < 0.625f) return 1.0f;
  const float a = 1.0f / inv_a;
  return ((2.181f * a + 3.535f) * a) / ((2.577f * a + 2.276f) * a + 1.0f);
}

// Isotropic Beckmann as the dielectric's templates read a distribution: D, Cycles' separable G
// (G1 by the rational fit; |cos| either side), and half vectors of density D(wm) cos(wm)
// ([Walter07] eq. 28-29, the pdf exact; Cycles draws visible normals: the same integral).
struct Beckmann {
  static constexpr bool kVisibleNormals = false;
  float alpha;
  float D(const Vec3& wm) const { return beckmann_D(alpha, wm); }
  float G(const Vec3& wo, const Vec3& wi) const { return beckmann_G1(alpha, wo.z) * beckmann_G1(alpha, wi.z); }
  // The density of the drawn half vector (named as Ggx's visible-normal density, which it replaces).
  float D_visible(const Vec3&, const Vec3& wm) const { return D(wm) * wm.z; }
  Vec3 sample_visible(const Vec3&, Vec2 u) const {
    const float tan2 = -alpha * alpha * std::log(std::max(1.0f - u.x, 1e-30f));  // [Walter07] eq. 28
    const float cos_t = 1.0f / std::sqrt(1.0f + tan2), sin_t = safe_sqrt(1.0f - cos_t * cos_t);
    const float phi = 2.0f * kPi * u.y;
    return Vec3(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
  }
};

// The BRDF (no Fresnel) of a pair in the upper hemisphere and the half vector's density p_h.
float other_microfacet_f(const BsdfParams& m, const Vec3& wo, const Vec3& wi, const Vec3& wm, float* p_h) {
  const float cos_o = wo.z, cos_i = wi.z;
  if (m.distribution == Microfacet::Beckmann && is_anisotropic(m)) {
    float ax, ay;
    anisotropic_alphas(m.roughness, m.anisotropy, &ax, &ay);
    const float d = beckmann_aniso_D(ax, ay, wm);
    *p_h = d * wm.z;
    return d * beckmann_aniso_G1(ax, ay, wo) * beckmann_aniso_G1(ax, ay, wi) / (4.0f * cos_i * cos_o);
  }
  if (m.distribution == Microfacet::Beckmann) {
    const float d = beckmann_D(m.roughness, wm);
    *p_h = d * wm.z;
    return d * beckmann_G1(m.roughness, cos_o) * beckmann_G1(m.roughness, cos_i) / (4.0f * cos_i * cos_o);
  }
  // Ashikhmin-Shirley, isotropic (bsdf_ashikhmin_shirley.h eval_reflect): norm (n + 1) / (8 pi),
  // lobe (N.H)^n and the pump 1 / (H.I max(N.I, N.O)).
  const float n = ashikhmin_shirley_exponent(m.roughness);
  const float h_dot_i = std::max(std::abs(dot(wm, wo)), 1e-6f), h_dot_n = std::max(wm.z, 1e-6f);
  const float lobe = std::pow(h_dot_n, n);
  *p_h = (n + 1.0f) / (2.0f * kPi) * lobe;
  return (n + 1.0f) / (8.0f * kPi) * lobe / std::max(1e-6f, h_dot_i * std::max(cos_o, cos_i));
}

// Upper-hemisphere pair (wo.z > 0, as Cycles' cosNI > 0): the BRDF and, in *pdf, the sampling
// density of wi (p_h / (4 |wo.wm|)).
RGB other_conductor(const BsdfParams& m, Vec3 wo, Vec3 wi, float* pdf) {
  *pdf = 0.0f;
  if (wo.z < 0) wo = -wo, wi = -wi;  // two-sided, as the GGX conductor
  if (!(wo.z > 0 && wi.z > 0)) return RGB(0.0f);
  const Vec3 h = wo + wi;
  if (length_squared(h) == 0) return RGB(0.0f);
  const Vec3 wm = normalize(h);
  float p_h = 0.0f;
  const float f = other_microfacet_f(m, wo, wi, wm, &p_h);
  const float wo_dot_wm = absdot(wo, wm);
  if (wo_dot_wm > 0) *pdf = p_h / (4.0f * wo_dot_wm);
  if (!(f > 0) || !std::isfinite(f)) return RGB(0.0f);
  return conductor_fresnel(m, wo_dot_wm) * f;
}

// A half vector from p_h.
Vec3 other_half_vector(const BsdfParams& m, Vec2 u) {
  if (m.distribution == Microfacet::Beckmann && is_anisotropic(m)) {
    // The slopes of anisotropic Beckmann are Gaussian of deviations ax / sqrt 2, ay / sqrt 2:
    // half vectors of density D(wm) cos(wm) (the isotropic draw below with the slope stretched).
    float ax, ay;
    anisotropic_alphas(m.roughness, m.anisotropy, &ax, &ay);
    const float r = std::sqrt(-std::log(std::max(1.0f - u.x, 1e-30f))), phi = 2.0f * kPi * u.y;
    return normalize(Vec3(ax * r * std::cos(phi), ay * r * std::sin(phi), 1.0f));
  }
  float cos_t;
  if (m.distribution == Microfacet::Beckmann) {
    const float tan2 = -m.roughness * m.roughness * std::log(std::max(1.0f - u.x, 1e-30f));  // [Walter07] eq. 28
    cos_t = 1.0f / std::sqrt(1.0f + tan2);
  } else {
    cos_t = std::pow(u.x, 1.0f / (ashikhmin_shirley_exponent(m.roughness) + 1.0f));
  }
  const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t)), phi = 2.0f * kPi * u.y;
  return Vec3(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
}

// The conductor's Fresnel factor as the random walk reads it, per microfacet.
struct ConductorWalkFresnel {
  const BsdfParams& m;
  RGB operator()(float cos_h) const { return conductor_fresnel(m, std::abs(cos_h)); }
};

RGB conductor_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (!same_hemisphere(wo, wi)) return RGB(0.0f);
  if (m.distribution == Microfacet::MultiGGX) return multi_reflect_eval(m, wo, wi, ConductorWalkFresnel{m});
  if (m.distribution != Microfacet::GGX) {
    float pdf;
    return other_conductor(m, wo, wi, &pdf);
  }
  float cos_h = 0;
  const float f = microfacet_reflection(ggx_of(m), wo, wi, &cos_h);
  if (f == 0) return RGB(0.0f);
  return conductor_fresnel(m, cos_h) * f;
}

float conductor_pdf(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (!same_hemisphere(wo, wi)) return 0.0f;
  if (m.distribution == Microfacet::MultiGGX) return multi_reflect_pdf(m, wo, wi);
  if (m.distribution != Microfacet::GGX) {
    float pdf;
    other_conductor(m, wo, wi, &pdf);
    return pdf;
  }
  Vec3 wm = wi + wo;
  if (length_squared(wm) == 0) return 0.0f;
  wm = normalize(wm);
  if (wm.z < 0) wm = -wm;
  const float wo_dot_wm = absdot(wo, wm);
  if (wo_dot_wm == 0) return 0.0f;
  // Visible-normal density times the reflection Jacobian dwm/dwi = 1 / (4 |wo.wm|),
  // [Walter07] eq. 14.
  return ggx_of(m).D_visible(wo, wm) / (4.0f * wo_dot_wm);
}

std::optional<BsdfSample> conductor_sample(const BsdfParams& m, const Vec3& wo, Vec2 u) {
  if (wo.z == 0) return std::nullopt;
  if (m.roughness < kSmoothAlpha) {
    // Perfect mirror: f = F / |cos| so that f |cos| / pdf = F with a unit Dirac pdf.
    BsdfSample s;
    s.wi = mirror_z(wo);
    s.f = conductor_fresnel(m, abs_cos_theta(wo)) / abs_cos_theta(wo);
    s.pdf = 1.0f;
    s.delta = true;
    return s;
  }
  if (m.distribution == Microfacet::MultiGGX) return multi_reflect_sample(m, wo, u, ConductorWalkFresnel{m});
  if (m.distribution != Microfacet::GGX) {
    Vec3 wm = other_half_vector(m, u);
    if (wo.z < 0) wm = -wm;  // the lower side's mirror image
    const Vec3 wi = reflect(wo, wm);
    if (!same_hemisphere(wo, wi)) return std::nullopt;
    BsdfSample s;
    s.wi = wi;
    s.f = other_conductor(m, wo, wi, &s.pdf);
    if (!valid_sample(s.f, s.pdf)) return std::nullopt;
    return s;
  }
  const Ggx ggx = ggx_of(m);
  const Vec3 wm = ggx.sample_visible(wo, u);
  const Vec3 wi = reflect(wo, wm);
  if (!same_hemisphere(wo, wi)) return std::nullopt;  // reflected below the horizon
  const float cos_o = abs_cos_theta(wo), cos_i = abs_cos_theta(wi);
  const float wo_dot_wm = absdot(wo, wm);
  if (cos_i == 0 || wo_dot_wm == 0) return std::nullopt;
  BsdfSample s;
  s.wi = wi;
  s.pdf = ggx.D_visible(wo, wm) / (4.0f * wo_dot_wm);  // [Walter07] eq. 14
  s.f = conductor_fresnel(m, wo_dot_wm) *
        (ggx.D(wm) * ggx.G(wo, wi) / (4.0f * cos_i * cos_o));  // [Walter07] eq. 20
  if (!valid_sample(s.f, s.pdf)) return std::nullopt;
  return s;
}

// ---- Dielectric ----

bool dielectric_is_smooth(const BsdfParams& m) { return m.roughness < kSmoothAlpha || m.ior == 1.0f; }

// The reflection and refraction lobes' weights (and selection probabilities) for the Fresnel
// reflectance F: R = F, T = 1 - F for glass; Cycles 3.4's Refraction BSDF (svm/closure.h,
// CLOSURE_BSDF_REFRACTION_ID and the microfacet refraction closures, weighted by the closure
// weight alone) has no reflection and a refraction lobe without Fresnel, T = 1, except that
// total internal reflection (F = 1) absorbs.
//
// With fresnel_at_normal (Cycles 3.4's Glass BSDF of GGX / Beckmann / Sharp, svm/closure.h: a
// reflection closure weighted by Fn and a refraction-only closure weighted by 1 - Fn, Fn =
// fresnel_dielectric_cos(dot(N, I), eta) at the shading normal for the camera-side direction I)
// R = Fn, T = 1 - Fn, and a microfacet in total internal reflection (F = 1) still refracts
// nothing (Cycles' refraction sampler returns no direction there). Fn < 0 means "not given".
float lobe_R(const BsdfParams& m, float F, float Fn = -1.0f) {
  if (m.refraction_only) return 0.0f;
  return m.fresnel_at_normal && Fn >= 0.0f ? Fn : F;
}
float lobe_T(const BsdfParams& m, float F, float Fn = -1.0f) {
  if (m.refraction_only) return F < 1.0f ? 1.0f : 0.0f;
  if (m.fresnel_at_normal && Fn >= 0.0f) return F < 1.0f ? 1.0f - Fn : 0.0f;
  return 1.0f - F;
}

// Fn of the glass split for direction w (the local z is the shading normal; a w inside the
// surface sees the inverse IOR, as Cycles' eta on a backfacing hit). Eval weights the lobes by
// Fn of the camera-side direction (wo for radiance, wi for importance: Cycles' I is the camera
// path's); lobe selection in sample and pdf uses Fn of the given wo, which f / pdf corrects.
float normal_fresnel(const BsdfParams& m, const Vec3& w) {
  return m.fresnel_at_normal ? fresnel_dielectric(cos_theta(w), m.ior) : -1.0f;
}
const Vec3& camera_side(const Vec3& wo, const Vec3& wi, TransportMode mode) {
  return mode == TransportMode::Radiance ? wo : wi;
}

// Generalized half vector of a reflection or refraction pair, [Walter07] eq. 16 in pbrt-v4's
// form wm = wo + etap wi, faced to +z. Returns false for degenerate pairs (grazing directions,
// zero-length half vector) and for pairs whose microfacet is back-facing to wo or wi, which no
// microfacet can produce. etap is the IOR on wi's side over the IOR on wo's side.
bool dielectric_half_vector(const BsdfParams& m, const Vec3& wo, const Vec3& wi, Vec3* wm,
                            float* etap, bool* reflect_pair) {
  const float cos_o = cos_theta(wo), cos_i = cos_theta(wi);
  if (cos_o == 0 || cos_i == 0) return false;
  *reflect_pair = cos_i * cos_o > 0;
  *etap = *reflect_pair ? 1.0f : (cos_o > 0 ? m.ior : 1.0f / m.ior);
  Vec3 h = wi * *etap + wo;
  if (length_squared(h) == 0) return false;
  h = normalize(h);
  if (h.z < 0) h = -h;
  if (dot(h, wi) * cos_i < 0 || dot(h, wo) * cos_o < 0) return false;
  *wm = h;
  return true;
}

// Fresnel reflectance at microfacet wm for the pair (wo, wi). A refraction pair has the same F
// seen from either side, but from the dense side near the critical angle cos_t = sqrt(1 -
// sin^2_t) cancels and float round-off in wm.w becomes a large error in 1 - F; evaluated from
// the outside direction F is well conditioned (and eval stays reciprocal to float precision).
float dielectric_fresnel(const BsdfParams& m, const Vec3& wo, const Vec3& wi, const Vec3& wm,
                         bool reflect_pair) {
  const Vec3& w = (reflect_pair || wo.z > 0) ? wo : wi;
  return fresnel_dielectric(dot(w, wm), m.ior);
}

}  // namespace

// The colour of a glass's reflection at the signed cosine cos_h of the reflecting direction to
// the microfacet (or shading) normal: the glass colour (Blender's Glass BSDF tints reflection
// and refraction alike), or, with principled_glass, Cycles 3.4's Principled glass (svm/closure.h:
// its reflection closure's cspec0 = Base Color * Specular Tint + (1 - Specular Tint), blended
// toward white by bsdf_util.h's interpolate_fresnel_color at L.H with the glass's IOR, while the
// Base Color weights the refraction closure alone): white at Specular Tint 0.
RGB dielectric_reflection_color(const BsdfParams& m, float cos_h) {
  if (!m.principled_glass) return m.color;
  const RGB cspec0 = m.color * m.specular_tint + RGB(1.0f - m.specular_tint);
  return fresnel_principled_metal(cspec0, m.ior, cos_h);  // inside (cos_h < 0): the inverse IOR
}

namespace {

std::optional<BsdfSample> dielectric_sample_smooth(const BsdfParams& m, const Vec3& wo, float uc,
                                                   TransportMode mode) {
  if (wo.z == 0) return std::nullopt;
  const float F = fresnel_dielectric(cos_theta(wo), m.ior);
  const float R = lobe_R(m, F), T = lobe_T(m, F);
  BsdfSample s;
  s.delta = true;
  if (uc < R / (R + T)) {
    // Specular reflection: f = R / |cos| chosen with probability R.
    s.wi = mirror_z(wo);
    s.f = dielectric_reflection_color(m, cos_theta(wo)) * (R / abs_cos_theta(s.wi));
    s.pdf = R / (R + T);
    return s;
  }
  Vec3 wi;
  float etap = 1.0f;
  if (!refract(wo, Vec3(0, 0, 1), m.ior, &etap, &wi) || wi.z == 0) return std::nullopt;
  float ft = T / abs_cos_theta(wi);
  // Radiance crossing into wo's medium scales by (eta_o / eta_i)^2 = 1 / etap^2, [Veach97] §5.2.
  if (mode == TransportMode::Radiance) ft /= sqr(etap);
  s.wi = wi;
  s.f = m.color * ft;
  s.pdf = T / (R + T);
  s.transmission = true;
  s.eta = etap;
  return s;
}

// Masking-shadowing of a rough glass: Cycles 3.4's microfacet closures (bsdf_microfacet.h
// eval_reflect / eval_transmit, isotropic and anisotropic alike) take the separable G1(wo) G1(wi),
// which the glass split (fresnel_at_normal) follows; the core's own GGX glass the height-correlated
// G ([Heitz14] eq. 99). Beckmann's G is separable either way.
template <class Dist>
float glass_G(const BsdfParams& m, const Dist& d, const Vec3& wo, const Vec3& wi) {
  if constexpr (std::is_same_v<Dist, Ggx>) {
    if (m.fresnel_at_normal) return d.G1(wo) * d.G1(wi);
  }
  return d.G(wo, wi);
}

template <class Dist>
RGB dielectric_eval_rough(const BsdfParams& m, const Dist& ggx, const Vec3& wo, const Vec3& wi, TransportMode mode) {
  Vec3 wm;
  float etap;
  bool reflect_pair;
  if (!dielectric_half_vector(m, wo, wi, &wm, &etap, &reflect_pair)) return RGB(0.0f);
  const float F = dielectric_fresnel(m, wo, wi, wm, reflect_pair);
  const float Fn = normal_fresnel(m, camera_side(wo, wi, mode));
  const float cos_o = cos_theta(wo), cos_i = cos_theta(wi);
  if (reflect_pair) {
    // [Walter07] eq. 20.
    return dielectric_reflection_color(m, dot(wo, wm)) *
           (ggx.D(wm) * glass_G(m, ggx, wo, wi) * lobe_R(m, F, Fn) / std::abs(4.0f * cos_i * cos_o));
  }
  // [Walter07] eq. 21 divided through by eta_o^2 (pbrt-v4's form). This is the importance
  // (adjoint) BTDF; radiance reaching wo's medium scales by 1/etap^2 ([Veach97] §5.2).
  const float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap) * cos_i * cos_o;
  if (denom == 0) return RGB(0.0f);
  float ft = ggx.D(wm) * lobe_T(m, F, Fn) * glass_G(m, ggx, wo, wi) * std::abs(dot(wi, wm) * dot(wo, wm) / denom);
  if (mode == TransportMode::Radiance) ft /= sqr(etap);
  return m.color * ft;
}

template <class Dist>
float dielectric_pdf_rough(const BsdfParams& m, const Dist& ggx, const Vec3& wo, const Vec3& wi) {
  Vec3 wm;
  float etap;
  bool reflect_pair;
  if (!dielectric_half_vector(m, wo, wi, &wm, &etap, &reflect_pair)) return 0.0f;
  // Lobe selection probability: Fresnel at the microfacet.
  const float F = dielectric_fresnel(m, wo, wi, wm, reflect_pair);
  const float Fn = normal_fresnel(m, wo);
  float R = lobe_R(m, F, Fn), T = lobe_T(m, F, Fn);
  if (m.fresnel_at_normal) {
    // The split's R + T is Fn, not 1, on a microfacet in total internal
    // reflection (T = 0): the sampler then picks reflection for sure.
    const float sum = R + T;
    if (sum <= 0) return 0.0f;
    R /= sum;
    T /= sum;
  }
  if (reflect_pair) {
    const float wo_dot_wm = absdot(wo, wm);
    if (wo_dot_wm == 0) return 0.0f;
    return ggx.D_visible(wo, wm) / (4.0f * wo_dot_wm) * R;  // [Walter07] eq. 14
  }
  // Refraction Jacobian dwm/dwi, [Walter07] eq. 17 divided through by eta_o^2.
  const float denom = sqr(dot(wi, wm) + dot(wo, wm) / etap);
  if (denom == 0) return 0.0f;
  const float dwm_dwi = absdot(wi, wm) / denom;
  return ggx.D_visible(wo, wm) * dwm_dwi * T;
}

template <class Dist>
std::optional<BsdfSample> dielectric_sample_rough(const BsdfParams& m, const Dist& ggx, const Vec3& wo, float uc,
                                                  Vec2 u, TransportMode mode) {
  if (wo.z == 0) return std::nullopt;
  const Vec3 wm = ggx.sample_visible(wo, u);
  const float wo_dot_wm = dot(wo, wm);
  if (wo_dot_wm == 0) return std::nullopt;
  // A distribution sampled by D cos alone (Beckmann) may draw a microfacet facing away from wo,
  // which scatters nothing (eval and pdf are 0 there too); visible normals never do.
  if (!Dist::kVisibleNormals && wo_dot_wm * wo.z < 0) return std::nullopt;
  const float F = fresnel_dielectric(wo_dot_wm, m.ior);
  const float Fn = normal_fresnel(m, wo);
  const float R = lobe_R(m, F, Fn), T = lobe_T(m, F, Fn);
  if (R + T == 0) return std::nullopt;
  const float cos_o = cos_theta(wo);
  BsdfSample s;
  if (uc < R / (R + T)) {
    const Vec3 wi = reflect(wo, wm);
    if (!same_hemisphere(wo, wi)) return std::nullopt;
    const float cos_i = cos_theta(wi);
    // The value's weight is Fn of the camera side (eval), the selection's R of wo's.
    const float R_f = lobe_R(m, F, normal_fresnel(m, camera_side(wo, wi, mode)));
    s.wi = wi;
    s.pdf = ggx.D_visible(wo, wm) / (4.0f * std::abs(wo_dot_wm)) * R / (R + T);          // eq. 14
    s.f = dielectric_reflection_color(m, dot(wo, wm)) *
          (ggx.D(wm) * glass_G(m, ggx, wo, wi) * R_f / std::abs(4.0f * cos_i * cos_o));  // eq. 20
  } else {
    Vec3 wi;
    float etap = 1.0f;
    if (!refract(wo, wm, m.ior, &etap, &wi)) return std::nullopt;  // TIR has T = 0 anyway
    if (same_hemisphere(wo, wi) || wi.z == 0) return std::nullopt;
    // T as eval() computes it (from the outside direction); it differs from the selection
    // probability above only by round-off near the critical angle, and cancels in f / pdf.
    const float F_pair = dielectric_fresnel(m, wo, wi, wm, false);
    const float T_pair = lobe_T(m, F_pair, Fn);
    const float T_f = lobe_T(m, F_pair, normal_fresnel(m, camera_side(wo, wi, mode)));  // eval's weight
    const float cos_i = cos_theta(wi);
    const float wi_dot_wm = dot(wi, wm);
    const float denom = sqr(wi_dot_wm + wo_dot_wm / etap);
    if (denom == 0) return std::nullopt;
    const float dwm_dwi = std::abs(wi_dot_wm) / denom;  // [Walter07] eq. 17
    s.pdf = ggx.D_visible(wo, wm) * dwm_dwi * T_pair;
    float ft = T_f * ggx.D(wm) * glass_G(m, ggx, wo, wi) *  // [Walter07] eq. 21
               std::abs(wi_dot_wm * wo_dot_wm / (cos_i * cos_o * denom));
    if (mode == TransportMode::Radiance) ft /= sqr(etap);
    s.wi = wi;
    s.f = m.color * ft;
    s.transmission = true;
    s.eta = etap;
  }
  if (!valid_sample(s.f, s.pdf)) return std::nullopt;
  return s;
}


// Glass and Refraction BSDF microfacet distributions: GGX (visible normals) and Beckmann (Cycles
// 3.4's bsdf_microfacet_beckmann_eval_transmit / _reflect: exact D, separable G of its rational
// Smith G1), both by [Walter07]'s eq. 14-21 above; Multiscatter GGX by the random walk
// (dielectric_multi_*).
RGB dielectric_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi, TransportMode mode) {
  if (dielectric_is_smooth(m)) return RGB(0.0f);
  if (m.distribution == Microfacet::MultiGGX) return dielectric_multi_eval(m, wo, wi, mode);
  if (m.distribution == Microfacet::Beckmann) return dielectric_eval_rough(m, Beckmann{m.roughness}, wo, wi, mode);
  return dielectric_eval_rough(m, Ggx{m.roughness}, wo, wi, mode);
}

float dielectric_pdf(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (dielectric_is_smooth(m)) return 0.0f;
  if (m.distribution == Microfacet::MultiGGX) return dielectric_multi_pdf(m, wo, wi);
  if (m.distribution == Microfacet::Beckmann) return dielectric_pdf_rough(m, Beckmann{m.roughness}, wo, wi);
  return dielectric_pdf_rough(m, Ggx{m.roughness}, wo, wi);
}

std::optional<BsdfSample> dielectric_sample(const BsdfParams& m, const Vec3& wo, float uc, Vec2 u,
                                            TransportMode mode) {
  if (dielectric_is_smooth(m)) return dielectric_sample_smooth(m, wo, uc, mode);
  if (m.distribution == Microfacet::MultiGGX) return dielectric_multi_sample(m, wo, uc, u, mode);
  if (m.distribution == Microfacet::Beckmann) return dielectric_sample_rough(m, Beckmann{m.roughness}, wo, uc, u, mode);
  return dielectric_sample_rough(m, Ggx{m.roughness}, wo, uc, u, mode);
}

// ---- Plastic: GGX dielectric coat over a diffuse base ----
//
// f = f_coat + f_base. The coat is the GGX microfacet reflection of a dielectric with Schlick's
// Fresnel of F0 = ((ior - 1) / (ior + 1))^2 (the conductor lobe with a grey F0; a Dirac mirror
// when smooth). The base is Lambertian, weighted by what the coat lets through both ways
// ([KC17]'s energy-compensation form, with the coat's own albedo E instead of a Fresnel term):
//   f_base = Rd / pi (1 - E(cos_i)) (1 - E(cos_o)) / (1 - E_avg),  E_avg = 2 int E(mu) mu dmu,
// so the base's albedo is Rd (1 - E(cos_o)) and coat + base reflect E + (1 - E) Rd <= 1: all of
// the light for a white base (the white furnace test checks it). E is tabulated per material
// (prepare_material). Sampling picks the coat with probability coat_probability(), then that
// lobe's own sampler, and returns the whole BSDF's f and pdf (one-sample MIS).

float plastic_f0(const BsdfParams& m) { return sqr((m.ior - 1.0f) / (m.ior + 1.0f)); }

BsdfParams plastic_coat(const BsdfParams& m) {
  BsdfParams coat;
  coat.type = MaterialType::Conductor;
  coat.color = RGB(plastic_f0(m));
  coat.roughness = m.roughness;
  return coat;
}

// The coat's directional albedo at |cos| = mu (table lookup; Schlick without a table).
float coat_albedo(const BsdfParams& m, float mu) {
  mu = clamp(mu, 0.0f, 1.0f);
  if (!m.coat_albedo) return fresnel_schlick(RGB(plastic_f0(m)), mu).r;
  const std::vector<float>& e = *m.coat_albedo;
  const float x = mu * kCoatAlbedoBins;
  const int i = std::min(static_cast<int>(x), kCoatAlbedoBins - 1);
  return e[i] + (e[i + 1] - e[i]) * (x - static_cast<float>(i));
}
float coat_albedo_average(const BsdfParams& m) {
  const float f0 = plastic_f0(m);
  return m.coat_albedo ? m.coat_albedo->back() : f0 + (1.0f - f0) / 21.0f;  // 2 int Schlick mu
}

float coat_probability(const BsdfParams& m, const Vec3& wo) {
  const float E = coat_albedo(m, abs_cos_theta(wo));
  const float base = (1.0f - E) * std::max(0.0f, m.color.average());
  return clamp(E / (E + base + 1e-6f), 0.1f, 0.9f);
}

RGB plastic_base_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (!same_hemisphere(wo, wi)) return RGB(0.0f);
  const float k = (1.0f - coat_albedo(m, abs_cos_theta(wi))) * (1.0f - coat_albedo(m, abs_cos_theta(wo))) /
                  (1.0f - coat_albedo_average(m));
  return m.color * (k * kInvPi);
}

RGB plastic_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi, float g = 1.0f, uint8_t lobes = kAllLobes) {
  RGB f(0.0f);
  if (lobes & kRayDiffuse) f += plastic_base_eval(m, wo, wi) * g;
  if ((lobes & kRayGlossy) && m.roughness >= kSmoothAlpha) f += conductor_eval(plastic_coat(m), wo, wi);
  return f;
}

float plastic_pdf(const BsdfParams& m, const Vec3& wo, const Vec3& wi, uint8_t lobes = kAllLobes) {
  const float pc = coat_probability(m, wo);
  float pdf = 0;
  if (lobes & kRayDiffuse) pdf += (1.0f - pc) * diffuse_pdf(wo, wi);
  if ((lobes & kRayGlossy) && m.roughness >= kSmoothAlpha) pdf += pc * conductor_pdf(plastic_coat(m), wo, wi);
  return pdf;
}

std::optional<BsdfSample> plastic_sample(const BsdfParams& m, const Vec3& wo, float uc, Vec2 u, TransportMode mode) {
  if (wo.z == 0) return std::nullopt;
  const float pc = coat_probability(m, wo);
  auto lobe = uc < pc ? conductor_sample(plastic_coat(m), wo, u) : diffuse_sample(m, wo, u);
  if (!lobe) return std::nullopt;
  lobe->lobe = uc < pc ? kRayGlossy : kRayDiffuse;
  if (lobe->delta) {  // the smooth coat's Dirac weight, chosen with probability pc
    lobe->pdf *= pc;
    return lobe;
  }
  // A non-Dirac direction: f and pdf of the whole BSDF (one-sample MIS over the lobes).
  lobe->f = plastic_eval(m, wo, lobe->wi, bump_shadowing(m, wo, lobe->wi, mode));
  lobe->pdf = plastic_pdf(m, wo, lobe->wi);
  if (!valid_sample(lobe->f, lobe->pdf)) return std::nullopt;
  return lobe;
}

// ---- Principled: Cycles 3.4's Principled BSDF (v1), its non-metal part ----
//
// Two closures added, as Cycles' svm_closure.h builds them for Metallic 0, Transmission 0:
//   f = Rd / pi * f_burley(wo, wi) + f_spec(wo, wi).
// f_burley is Burley's diffuse ("Physically Based Shading at Disney", 2012, §5.3) in the split
// form of "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering" (2015,
// §3.1): a Lambertian part (1 - F_L / 2)(1 - F_V / 2) plus the retro-reflection
// R_R (F_L + F_V + F_L F_V (R_R - 1)), F = (1 - cos)^5, R_R = 2 r cos^2 theta_d = r (1 + wi.wo),
// r Blender's roughness (sqrt of the GGX alpha). f_spec is the GGX microfacet reflection with
// the exact dielectric Fresnel at the microfacet, F(wi.wm, ior): Cycles' "principled v1"
// Fresnel, lerp(cspec0, 1, (F - F0) / (1 - F0)), is exactly that when cspec0 = F0 = 0.08
// Specular (Specular Tint 0). Neither lobe is weighted by the other (Cycles adds them), so the
// albedo may exceed one by a few per cent; that is Cycles' look, which this type reproduces
// (the energy-conserving layer is `plastic`). Sampling picks the specular lobe with
// probability ~ F(cos_o) against the diffuse colour, then returns the whole BSDF's f and pdf.

float burley_diffuse(float r, const Vec3& wo, const Vec3& wi) {
  const float fl = pow5(1.0f - abs_cos_theta(wi)), fv = pow5(1.0f - abs_cos_theta(wo));
  const float rr = r * (1.0f + dot(wi, wo));
  return (1.0f - 0.5f * fl) * (1.0f - 0.5f * fv) + rr * (fl + fv + fl * fv * (rr - 1.0f));
}

// Cycles' hue-only colour of a tint t (svm_closure.h): mix(1, color / lum, t), 1 for a black
// colour. `lum` is the RGB colour's luminance (BsdfParams::*_tint_lum).
RGB tint_color(const RGB& color, float lum, float t) {
  const RGB hue = lum > 0.0f ? color / lum : RGB(1.0f);
  return RGB(1.0f - t) + hue * t;
}

// The specular lobe's Fresnel factor at cos_h. With Specular Tint t, Cycles' principled v1
// Fresnel (bsdf_util.h interpolate_fresnel_color) with cspec0 = saturate(F0 mix(1, hue, t)),
// F0 = F_d(1, ior) = 0.08 Specular: F = cspec0 (1 - FH) + FH, FH = (F_d(cos_h) - F0) / (1 - F0);
// untinted that is F_d(cos_h) itself.
RGB principled_spec_fresnel(const BsdfParams& m, float cos_h) {
  const float fd = fresnel_dielectric(cos_h, m.ior);
  if (m.specular_tint <= 0.0f) return RGB(fd);
  const float f0 = fresnel_dielectric(1.0f, m.ior);
  if (!(f0 < 1.0f)) return RGB(1.0f);
  const RGB c = tint_color(m.color, m.specular_tint_lum, m.specular_tint) * f0;
  const RGB cspec0(clamp(c.r, 0.0f, 1.0f), clamp(c.g, 0.0f, 1.0f), clamp(c.b, 0.0f, 1.0f));
  const float fh = (fd - f0) / (1.0f - f0);
  return cspec0 * (1.0f - fh) + RGB(fh);
}

// Principled's specular Fresnel as the random walk reads it (Multiscatter GGX), per microfacet.
struct PrincipledWalkFresnel {
  const BsdfParams& m;
  RGB operator()(float cos_h) const { return principled_spec_fresnel(m, std::abs(cos_h)); }
};

RGB principled_spec_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (m.roughness < kSmoothAlpha || !same_hemisphere(wo, wi)) return RGB(0.0f);
  if (m.distribution == Microfacet::MultiGGX) return multi_reflect_eval(m, wo, wi, PrincipledWalkFresnel{m});
  float cos_h = 0;
  const float f = microfacet_reflection(ggx_of(m), wo, wi, &cos_h);
  return principled_spec_fresnel(m, cos_h) * f;
}

// Cycles 3.4's Principled sheen (bsdf_principled_sheen.h, after Burley 2012 §5.4): f = Sheen x
// mix(1, hue, Sheen Tint) x (1 - wi.h)^5, no 1 / pi (Burley's Fsheen is added to the diffuse
// term outside its 1 / pi), h = normalize(wi + wo); a diffuse closure, cosine-sampled, so the
// diffuse lobe's sampler covers it.
RGB principled_sheen_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi) {
  if (!(m.sheen > 0.0f)) return RGB(0.0f);
  const Vec3 h = wo + wi;
  if (length_squared(h) == 0) return RGB(0.0f);
  return tint_color(m.color, m.sheen_tint_lum, m.sheen_tint) * (m.sheen * pow5(1.0f - absdot(wi, normalize(h))));
}

RGB principled_eval(const BsdfParams& m, const Vec3& wo, const Vec3& wi, float g = 1.0f, uint8_t lobes = kAllLobes) {
  if (!same_hemisphere(wo, wi)) return RGB(0.0f);
  RGB f(0.0f);
  if (lobes & kRayDiffuse) {
    const float r = m.diffuse_roughness >= 0.0f ? m.diffuse_roughness : m.roughness;  // unblurred (filter_closures)
    f += m.color * (kInvPi * burley_diffuse(std::sqrt(std::max(0.0f, r)), wo, wi) * g);
    if (m.sheen > 0.0f) f += principled_sheen_eval(m, wo, wi) * g;
  }
  if (lobes & kRayGlossy) f += principled_spec_eval(m, wo, wi);
  return f;
}

float principled_spec_probability(const BsdfParams& m, const Vec3& wo) {
  const float F = m.specular_tint > 0.0f ? principled_spec_fresnel(m, abs_cos_theta(wo)).average()
                                         : fresnel_dielectric(abs_cos_theta(wo), m.ior);
  float diffuse = std::max(0.0f, m.color.average());
  // The sheen's share of the diffuse side: Cycles' sample weight of it, Sheen x colour x
  // (1 - cos_o)^5 (calculate_avg_principled_sheen_brdf without its cosine).
  if (m.sheen > 0.0f)
    diffuse += m.sheen * std::max(0.0f, tint_color(m.color, m.sheen_tint_lum, m.sheen_tint).average()) *
               pow5(1.0f - abs_cos_theta(wo));
  return clamp(F / (F + diffuse + 1e-6f), 0.1f, 0.9f);
}

float principled_pdf(const BsdfParams& m, const Vec3& wo, const Vec3& wi, uint8_t lobes = kAllLobes) {
  const float ps = principled_spec_probability(m, wo);
  float pdf = 0;
  if (lobes & kRayDiffuse) pdf += (1.0f - ps) * diffuse_pdf(wo, wi);
  if ((lobes & kRayGlossy) && m.roughness >= kSmoothAlpha) pdf += ps * conductor_pdf(m, wo, wi);
  return pdf;
}

// Principled with a Multiscatter GGX specular lobe: the picked lobe's own weight over its
// probability (the walk's density is unknown, so the one-sample MIS over both lobes below would
// be biased), reported with the whole BSDF's (stand-in) pdf for MIS with lights.
std::optional<BsdfSample> principled_multi_sample(const BsdfParams& m, const Vec3& wo, float uc, Vec2 u,
                                                  TransportMode mode) {
  // The lobe is picked as for a grey base (any probability is unbiased here), so that every
  // wavelength of a spectral path picks the same one with the same numbers.
  BsdfParams grey = m;
  grey.color = RGB(0.5f);
  const float ps = principled_spec_probability(grey, wo);
  std::optional<BsdfSample> lobe;
  RGB weight;
  if (uc < ps) {
    lobe = multi_reflect_sample(m, wo, u, PrincipledWalkFresnel{m});
    if (!lobe) return std::nullopt;
    weight = lobe->f * (abs_cos_theta(lobe->wi) / (lobe->pdf * ps));
    lobe->lobe = kRayGlossy;
  } else {
    lobe = diffuse_sample(m, wo, u);
    if (!lobe) return std::nullopt;
    const RGB f = principled_eval(m, wo, lobe->wi, bump_shadowing(m, wo, lobe->wi, mode), kRayDiffuse);
    weight = f * (abs_cos_theta(lobe->wi) / (lobe->pdf * (1.0f - ps)));
    lobe->lobe = kRayDiffuse;
  }
  lobe->pdf = principled_pdf(m, wo, lobe->wi);
  lobe->f = weight * (lobe->pdf / abs_cos_theta(lobe->wi));
  lobe->stochastic = true;
  if (!valid_sample(lobe->f, lobe->pdf)) return std::nullopt;
  return lobe;
}

std::optional<BsdfSample> principled_sample(const BsdfParams& m, const Vec3& wo, float uc, Vec2 u, TransportMode mode) {
  if (wo.z == 0) return std::nullopt;
  if (m.distribution == Microfacet::MultiGGX && m.roughness >= kSmoothAlpha) return principled_multi_sample(m, wo, uc, u, mode);
  const float ps = principled_spec_probability(m, wo);
  // The conductor sampler of the same alpha draws the specular lobe's direction (its Fresnel
  // plays no part in the direction); f is recomputed below.
  auto lobe = uc < ps ? conductor_sample(m, wo, u) : diffuse_sample(m, wo, u);
  if (!lobe) return std::nullopt;
  lobe->lobe = uc < ps ? kRayGlossy : kRayDiffuse;
  if (lobe->delta) {  // a smooth specular lobe: its Dirac weight F / |cos|, chosen with probability ps
    lobe->f = principled_spec_fresnel(m, abs_cos_theta(wo)) / abs_cos_theta(wo);
    lobe->pdf *= ps;
    return lobe;
  }
  lobe->f = principled_eval(m, wo, lobe->wi, bump_shadowing(m, wo, lobe->wi, mode));
  lobe->pdf = principled_pdf(m, wo, lobe->wi);
  if (!valid_sample(lobe->f, lobe->pdf)) return std::nullopt;
  return lobe;
}

// ---- Clearcoat: Cycles 3.4's Principled clearcoat closure ----
//
// kernel/closure/bsdf_microfacet.h, CLOSURE_BSDF_MICROFACET_GGX_CLEARCOAT_ID, as svm_closure.h
// sets it up (IOR 1.5, cspec0 0.04, alpha = Clearcoat Roughness^2 saturated):
//   f = 0.25 clearcoat F(wo.h) D(h) G1(wo) G1(wi) / (4 cos_o cos_i),
// D Burley's GTR1 (Burley 2012, appendix B.2: (a^2 - 1) / (pi ln(a^2) (1 + (a^2 - 1) cos^2_h)),
// 1 / pi for a >= 1), G1 the separable Smith GGX masking of a fixed alpha 0.25 ([Walter07]
// eq. 34), F the dielectric Fresnel of IOR 1.5 (Cycles' interpolated Fresnel with cspec0 = F0
// is exactly that). Sampled by GTR1's own half-vector density D cos_h (Burley 2012, B.2:
// cos^2_h = (1 - a^2^(1 - u)) / (1 - a^2)), an exact pdf; Cycles draws GGX visible normals of
// the same alpha but reports GTR1's density, which only its BSDF-sampled estimates see.
// A Dirac mirror below Cycles' own smoothness test, alpha^2 <= 1e-7 (Clearcoat Roughness below
// about 0.018), not kSmoothAlpha: GTR1's long tails keep a third of its microfacets beyond
// 6 degrees even at Blender's default alpha 0.0009.

constexpr float kClearcoatIor = 1.5f, kClearcoatG1Alpha = 0.25f;

bool clearcoat_is_smooth(const BsdfParams& m) { return m.roughness * m.roughness <= 1e-7f; }

float gtr1_D(float alpha, float cos_h) {
  const float a2 = alpha * alpha;
  if (a2 >= 1.0f) return kInvPi;
  const float t = 1.0f + (a2 - 1.0f) * cos_h * cos_h;
  return (a2 - 1.0f) / (kPi * std::log(a2) * t);
}

float clearcoat_G1(const Vec3& w) { return Ggx{kClearcoatG1Alpha}.G1(w); }

float clearcoat_weight(const BsdfParams& m) { return 0.25f * std::max(0.0f, m.clearcoat); }

// f and the sampling density of wi for a pair on one side (0 otherwise).
float clearcoat_f(const BsdfParams& m, const Vec3& wo, const Vec3& wi, float* pdf) {
  *pdf = 0.0f;
  if (clearcoat_is_smooth(m) || !same_hemisphere(wo, wi)) return 0.0f;
  const float cos_o = abs_cos_theta(wo), cos_i = abs_cos_theta(wi);
  if (cos_o == 0 || cos_i == 0) return 0.0f;
  Vec3 h = wo + wi;
  if (length_squared(h) == 0) return 0.0f;
  h = normalize(h);
  const float cos_h = abs_cos_theta(h), wo_dot_h = absdot(wo, h);
  if (wo_dot_h == 0) return 0.0f;
  const float D = gtr1_D(m.roughness, cos_h);
  *pdf = D * cos_h / (4.0f * wo_dot_h);  // [Walter07] eq. 14
  return clearcoat_weight(m) * fresnel_dielectric(wo_dot_h, kClearcoatIor) * D * clearcoat_G1(wo) *
         clearcoat_G1(wi) / (4.0f * cos_o * cos_i);
}

std::optional<BsdfSample> clearcoat_sample(const BsdfParams& m, const Vec3& wo, Vec2 u) {
  if (wo.z == 0) return std::nullopt;
  BsdfSample s;
  if (clearcoat_is_smooth(m)) {  // Cycles' singular branch: weight F(cos_o) x 0.25 clearcoat
    s.wi = mirror_z(wo);
    s.f = RGB(clearcoat_weight(m) * fresnel_dielectric(abs_cos_theta(wo), kClearcoatIor) / abs_cos_theta(wo));
    s.pdf = 1.0f;
    s.delta = true;
    return s;
  }
  const float a2 = m.roughness * m.roughness;
  const float cos2 = a2 >= 1.0f ? u.x : (1.0f - std::pow(a2, 1.0f - u.x)) / (1.0f - a2);
  const float cos_t = std::sqrt(clamp(cos2, 0.0f, 1.0f)), sin_t = safe_sqrt(1.0f - cos_t * cos_t);
  const float phi = 2.0f * kPi * u.y;
  Vec3 h(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t);
  if (wo.z < 0) h = -h;
  const Vec3 wi = reflect(wo, h);
  if (!same_hemisphere(wo, wi)) return std::nullopt;
  s.wi = wi;
  s.f = RGB(clearcoat_f(m, wo, wi, &s.pdf));
  if (!valid_sample(s.f, s.pdf)) return std::nullopt;
  return s;
}

}  // namespace

// ---- Mix and Add of two materials ----
//
// Mix: f = (1 - t) f_a + t f_b; Add: f = f_a + f_b. Sampling picks a component with probability
// (1 - t, t) (Add: 1/2 each), samples it, and for a non-Dirac direction returns the whole
// mixture's f and pdf (one-sample MIS); a Dirac sample keeps its lobe's weight times the
// component's scale, and its pdf times the selection probability.

namespace {
struct MixParts {
  float scale_a, scale_b, prob_b;
};
MixParts mix_parts(const BsdfParams& m) {
  const float t = clamp(m.mix_factor, 0.0f, 1.0f);
  if (m.mix_add) return {1.0f, 1.0f, 0.5f};
  return {1.0f - t, t, t};
}
}  // namespace

void prepare_material(Material& m) {
  if (m.type != MaterialType::Plastic) return;
  // Scenes have many plastics of few (roughness, IOR) pairs (every Principled non-metal): one
  // table per pair, shared.
  static std::mutex cache_mutex;
  static std::map<std::pair<float, float>, std::shared_ptr<const std::vector<float>>> cache;
  const std::pair<float, float> key{m.roughness, m.ior};
  {
    std::lock_guard lock(cache_mutex);
    if (auto it = cache.find(key); it != cache.end()) {
      m.coat_albedo = it->second;
      return;
    }
  }
  // E(mu) = int f_coat |cos_i| dwi, by the coat's own sampler on a fixed 64 x 64 stratified
  // grid (deterministic); a smooth coat reflects exactly Schlick's F(mu).
  auto table = std::make_shared<std::vector<float>>(kCoatAlbedoBins + 2, 0.0f);
  const BsdfParams coat = plastic_coat(bsdf_params(m, Vec2()));
  constexpr int kGrid = 64;
  for (int b = 0; b <= kCoatAlbedoBins; ++b) {
    const float mu = std::max(1e-3f, static_cast<float>(b) / kCoatAlbedoBins);
    const Vec3 wo(safe_sqrt(1.0f - mu * mu), 0.0f, mu);
    double sum = 0;
    if (m.roughness < kSmoothAlpha) {
      sum = fresnel_schlick(coat.color, mu).r;
    } else {
      for (int i = 0; i < kGrid; ++i)
        for (int j = 0; j < kGrid; ++j) {
          const auto s = conductor_sample(coat, wo, Vec2((i + 0.5f) / kGrid, (j + 0.5f) / kGrid));
          if (s) sum += s->f.r * abs_cos_theta(s->wi) / s->pdf;
        }
      sum /= kGrid * kGrid;
    }
    (*table)[b] = static_cast<float>(std::min(1.0, sum));
  }
  double avg = 0;  // E_avg = 2 int_0^1 E(mu) mu dmu, trapezoid rule
  for (int b = 0; b < kCoatAlbedoBins; ++b) {
    const double mu0 = double(b) / kCoatAlbedoBins, mu1 = double(b + 1) / kCoatAlbedoBins;
    avg += ((*table)[b] * mu0 + (*table)[b + 1] * mu1) * (mu1 - mu0);
  }
  table->back() = static_cast<float>(std::min(avg, 0.999));
  m.coat_albedo = table;
  std::lock_guard lock(cache_mutex);
  cache.emplace(key, std::move(table));
}

// Exact unpolarized Fresnel reflectance (average of the s and p Fresnel equations).
float fresnel_dielectric(float cos_i, float eta) {
  cos_i = clamp(cos_i, -1.0f, 1.0f);
  if (cos_i < 0) {  // from the inside: swap the media
    eta = 1.0f / eta;
    cos_i = -cos_i;
  }
  const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);  // Snell's law
  if (sin2_t >= 1.0f) return 1.0f;                            // total internal reflection
  const float cos_t = safe_sqrt(1.0f - sin2_t);
  const float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_parl * r_parl + r_perp * r_perp);
}

// A mix whose components are missing (parameters made by hand) scatters as a diffuse surface
// of its own colour, which the loader sets to the components' weighted colour.
MaterialType Bsdf::kind() const {
  if (p_.type == MaterialType::Mix && (!p_.mix_a || !p_.mix_b)) return MaterialType::Diffuse;
  return p_.type;
}

Bsdf Bsdf::component(const Material* m) const {
  const MixComponents* parts = p_.parts.get();
  const bool cached = parts && (m == p_.mix_a || m == p_.mix_b) && (p_.lambda <= 0 || parts->spectral);
  BsdfParams params;
  if (cached) {  // evaluated once with the mix (bsdf_params)
    const bool a = m == p_.mix_a;
    const BsdfParams& rgb = a ? parts->a : parts->b;
    params = p_.lambda > 0 ? at_wavelength(*m, rgb, a ? parts->spectrum_a : parts->spectrum_b, p_.lambda) : rgb;
  } else {
    // Seen at the mix's wavelength when spectral: its colour upsampled at this point.
    params = p_.lambda > 0 ? SpectralSurface(*m, ctx_, nullptr).at(p_.lambda) : bsdf_params(*m, ctx_);
  }
  Bsdf b(params, ctx_);
  b.ng_ = ng_;
  b.p_.smooth_normal = p_.smooth_normal;
  return b;
}

namespace {
float finite_or(float v, float fallback) { return std::isfinite(v) ? v : fallback; }
}  // namespace

BsdfParams bsdf_params(const Material& m, const shading::ShadingContext& ctx, bool spectral) {
  const Vec2 uv = ctx.uv;
  BsdfParams p;
  p.type = m.type;
  p.color = m.color_tex ? m.color_tex.rgb(uv) : m.color;
  p.roughness = m.roughness_tex ? clamp(m.roughness_tex.value(uv), 0.0f, 1.0f) : m.roughness;
  p.conductor_fresnel = m.conductor_fresnel;
  p.distribution = m.distribution;
  p.sharp = m.sharp;
  p.ior = m.ior;
  p.specular_tint = m.specular_tint;
  p.sheen = m.sheen;
  p.sheen_tint = m.sheen_tint;
  p.clearcoat = m.clearcoat;
  p.anisotropy = m.anisotropy;
  p.refraction_only = m.refraction_only;
  p.fresnel_at_normal = m.fresnel_at_normal;
  p.principled_glass = m.principled_glass;
  p.separable_masking = m.separable_masking;
  p.coat_albedo = m.coat_albedo.get();
  p.mix_factor = m.factor_tex ? m.factor_tex.value(uv) : m.mix_factor;
  p.mix_add = m.mix_add;
  p.mix_a = m.mix_a.get();
  p.mix_b = m.mix_b.get();
  if (m.graph) {
    // One run of the material's node graph gives every linked input (Cycles' SVM per shader),
    // in the thread's register file for this program, which keeps its constants from the last
    // run (no copy per hit). Read before a mix's components run theirs (below).
    const Vec3* regs = shading::run_in_thread_registers(m.graph, ctx);
    auto value = [&](const GraphInput& g) { return shading::as_float(regs[g.source.reg], g.source.conv); };
    if (m.color_in) {
      const Vec3& c = regs[m.color_in.source.reg];
      p.color = RGB(std::max(finite_or(c.x, 0.0f), 0.0f), std::max(finite_or(c.y, 0.0f), 0.0f),
                    std::max(finite_or(c.z, 0.0f), 0.0f));
    }
    if (m.roughness_in) p.roughness = clamp(finite_or(value(m.roughness_in), 0.0f), 0.0f, 1.0f);
    if (m.factor_in) p.mix_factor = clamp(finite_or(value(m.factor_in), 0.0f), 0.0f, 1.0f);
    if (m.ior_in) p.ior = std::max(finite_or(value(m.ior_in), 1.0f), 1e-3f);
    if (m.specular_tint_in) p.specular_tint = clamp(finite_or(value(m.specular_tint_in), 0.0f), 0.0f, 1.0f);
    if (m.sheen_in) p.sheen = std::max(finite_or(value(m.sheen_in), 0.0f), 0.0f);
    if (m.sheen_tint_in) p.sheen_tint = clamp(finite_or(value(m.sheen_tint_in), 0.0f), 0.0f, 1.0f);
    if (m.clearcoat_in) p.clearcoat = std::max(finite_or(value(m.clearcoat_in), 0.0f), 0.0f);
    if (m.anisotropy_in) p.anisotropy = clamp(finite_or(value(m.anisotropy_in), 0.0f), -0.99f, 0.99f);
  }
  if (p.type == MaterialType::Principled && (p.specular_tint > 0.0f || p.sheen > 0.0f)) {
    // svm_closure.h: "luminance approx." for the specular tint, linear_rgb_to_gray (the scene's
    // linear Rec. 709 Y) for the sheen's.
    p.specular_tint_lum = 0.3f * p.color.r + 0.6f * p.color.g + 0.1f * p.color.b;
    p.sheen_tint_lum = 0.2126729f * p.color.r + 0.7151522f * p.color.g + 0.0721750f * p.color.b;
  }
  if (p.type == MaterialType::Mix && p.mix_a && p.mix_b) {
    // After this material's own graph is read: the components' runs reuse the thread's registers.
    auto parts = std::make_shared<MixComponents>();
    parts->a = bsdf_params(*p.mix_a, ctx, spectral);
    parts->b = bsdf_params(*p.mix_b, ctx, spectral);
    if (spectral) {
      parts->spectral = true;
      parts->spectrum_a = RgbSpectrum::reflectance_interpolated(parts->a.color);
      parts->spectrum_b = RgbSpectrum::reflectance_interpolated(parts->b.color);
    }
    p.parts = std::move(parts);
  }
  return p;
}

namespace {
// Cycles' bsdf_blur of one microfacet closure (bsdf_microfacet_ggx_blur and its kin): each axis's
// alpha raised to at least `alpha`; an anisotropic lobe's two axes written back in the
// Anisotropic BSDF convention (anisotropic_alphas: alpha = sqrt(ax ay), 1 - an = sqrt(ax / ay)).
void blur_closure(BsdfParams& p, float alpha) {
  if (!is_anisotropic(p)) {
    p.roughness = std::max(p.roughness, alpha);
    return;
  }
  float ax, ay;
  anisotropic_alphas(p.roughness, p.anisotropy, &ax, &ay);
  ax = std::max(ax, alpha);
  ay = std::max(ay, alpha);
  p.roughness = std::sqrt(ax * ay);
  p.anisotropy = ax <= ay ? 1.0f - std::sqrt(ax / ay) : std::sqrt(ay / ax) - 1.0f;
}
// Blender's Transparent BSDF (the loader's "transparent": a smooth dielectric of IOR 1): Cycles'
// caustics switches and Filter Glossy leave it as it is.
bool is_transparent_closure(const BsdfParams& p) {
  return p.type == MaterialType::Dielectric && p.ior == 1.0f && p.roughness == 0.0f && !p.refraction_only;
}
}  // namespace

// Cycles 3.4 (integrator/surface_shader.h surface_shader_prepare_closures, closure/bsdf.h
// bsdf_blur, svm/svm_closure.h). Material::sharp is Cycles' singular closure, which bsdf_blur
// leaves alone; Blender's Sharp node is one only with its Roughness linked to a varying value:
// unlinked, Cycles compiles it to GGX at 0 while Filter Glossy is on (scene/shader_nodes.cpp
// simplify_settings), which is blurred (the exporter writes "sharp" for the linked case only;
// Blender 3.4.1 renders Sharp and GGX at 0 bit for bit alike under Filter Glossy 1).
void filter_closures(BsdfParams& p, const ClosureFilter& f) {
  if (!f.active()) return;
  if (p.type == MaterialType::Mix) {
    // Each closure of the mix on its own, as Cycles filters closures (hand-made parameters
    // without parts look their components up per call, unfiltered: not a shading point's).
    if (!p.parts) return;
    auto parts = std::make_shared<MixComponents>(*p.parts);
    filter_closures(parts->a, f);
    filter_closures(parts->b, f);
    p.parts = std::move(parts);
    return;
  }
  if (is_transparent_closure(p)) return;
  p.lobes = f.lobes;
  // A Multiscatter GGX glass is one closure, reflection and refraction together: Cycles drops it
  // only where both switches drop (svm_closure.h, CLOSURE_BSDF_MICROFACET_MULTI_GGX_GLASS_ID).
  if (p.type == MaterialType::Dielectric && p.distribution == Microfacet::MultiGGX && !p.refraction_only &&
      (f.lobes & (kRayGlossy | kRayTransmission)))
    p.lobes |= kRayGlossy | kRayTransmission;
  if (!(f.blur_alpha > 0.0f) || p.sharp) return;
  switch (p.type) {
    case MaterialType::Conductor:
    case MaterialType::Dielectric:
    case MaterialType::Clearcoat: blur_closure(p, f.blur_alpha); break;
    case MaterialType::Principled:  // the specular lobe's alpha; the Burley diffuse keeps its roughness
      if (p.diffuse_roughness < 0.0f) p.diffuse_roughness = p.roughness;
      blur_closure(p, f.blur_alpha);
      break;
    default: break;  // diffuse, translucent, velvet (no microfacets); plastic (bsdf.h ClosureFilter)
  }
}

RGB Bsdf::eval(const Vec3& wo, const Vec3& wi, TransportMode mode, uint8_t lobes) const {
  return wrong_side(wo, wi) ? RGB(0.0f) : eval_lobes(wo, wi, mode, lobes & p_.lobes);
}

namespace {
// The kind of a dielectric's lobe for the pair: reflection is glossy, refraction transmission.
uint8_t dielectric_lobe(const Vec3& wo, const Vec3& wi) { return wo.z * wi.z > 0 ? kRayGlossy : kRayTransmission; }
}  // namespace

std::optional<BsdfSample> Bsdf::sample(const Vec3& wo, float uc, Vec2 u, TransportMode mode) const {
  auto s = sample_lobes(wo, uc, u, mode);
  if (s && wrong_side(wo, s->wi)) return std::nullopt;
  // A lobe the caustics switches dropped (filter_closures): no sample, so that the surviving
  // samples have pdf()'s density restricted to the lobes kept.
  if (s && p_.lobes != kAllLobes) {
    if (!(s->lobe & p_.lobes)) return std::nullopt;
    // A lobe kept: a non-Dirac direction's f and pdf are those of the lobes kept (a principled or
    // plastic sample returns its whole mixture's). A random walk's sample keeps its weight
    // (the picked lobe's own, over its probability) with the kept lobes' stand-in pdf, the one
    // next-event estimation's MIS reads (pdf()).
    if (!s->delta) {
      if (s->stochastic) {
        const float cos_i = abs_cos_theta(s->wi);
        const RGB weight = s->f * (cos_i / s->pdf);
        s->pdf = pdf(wo, s->wi);
        s->f = weight * (s->pdf / cos_i);
      } else {
        s->f = eval(wo, s->wi, mode);
        s->pdf = pdf(wo, s->wi);
      }
      if (!valid_sample(s->f, s->pdf)) return std::nullopt;
    }
  }
  return s;
}

RGB Bsdf::eval_lobes(const Vec3& wo, const Vec3& wi, TransportMode mode, uint8_t lobes) const {
  switch (kind()) {
    case MaterialType::Diffuse:
      return (lobes & kRayDiffuse) ? diffuse_eval(p_, wo, wi) * bump_shadowing(p_, wo, wi, mode) : RGB(0.0f);
    case MaterialType::Conductor:
      return p_.roughness < kSmoothAlpha || !(lobes & kRayGlossy) ? RGB(0.0f) : conductor_eval(p_, wo, wi);
    case MaterialType::Dielectric:
      return (lobes & dielectric_lobe(wo, wi)) ? dielectric_eval(p_, wo, wi, mode) : RGB(0.0f);
    case MaterialType::Emission: return RGB(0.0f);
    // Translucent is among Cycles' diffuse closures (svm/types.h CLOSURE_IS_BSDF_DIFFUSE) and
    // takes the bump shadowing term; velvet is not, though it samples with a diffuse label.
    // (Velvet's kind here is its sampling label, diffuse; Cycles' light-exclusion counts it
    // glossy: a light hidden from only one of the two kinds treats it differently.)
    case MaterialType::Translucent:
      return (lobes & kRayDiffuse) ? translucent_eval(p_, wo, wi) * bump_shadowing(p_, wo, wi, mode) : RGB(0.0f);
    case MaterialType::Velvet: return (lobes & kRayDiffuse) ? velvet_eval(p_, wo, wi) : RGB(0.0f);
    case MaterialType::Plastic: return plastic_eval(p_, wo, wi, bump_shadowing(p_, wo, wi, mode), lobes);
    case MaterialType::Principled: return principled_eval(p_, wo, wi, bump_shadowing(p_, wo, wi, mode), lobes);
    case MaterialType::Clearcoat: {
      float pdf;
      return (lobes & kRayGlossy) ? RGB(clearcoat_f(p_, wo, wi, &pdf)) : RGB(0.0f);
    }
    case MaterialType::Mix: {
      const MixParts p = mix_parts(p_);
      RGB f(0.0f);
      if (p.scale_a > 0) f += component(p_.mix_a).eval(wo, wi, mode, lobes) * p.scale_a;
      if (p.scale_b > 0) f += component(p_.mix_b).eval(wo, wi, mode, lobes) * p.scale_b;
      return f;
    }
  }
  return RGB(0.0f);
}

float Bsdf::pdf(const Vec3& wo, const Vec3& wi, uint8_t lobes) const {
  lobes &= p_.lobes;  // the caustics switches' (filter_closures)
  switch (kind()) {
    case MaterialType::Diffuse: return (lobes & kRayDiffuse) ? diffuse_pdf(wo, wi) : 0.0f;
    case MaterialType::Conductor:
      return p_.roughness < kSmoothAlpha || !(lobes & kRayGlossy) ? 0.0f : conductor_pdf(p_, wo, wi);
    case MaterialType::Dielectric: return (lobes & dielectric_lobe(wo, wi)) ? dielectric_pdf(p_, wo, wi) : 0.0f;
    case MaterialType::Emission: return 0.0f;
    case MaterialType::Translucent: return (lobes & kRayDiffuse) ? translucent_pdf(wo, wi) : 0.0f;
    case MaterialType::Velvet: return (lobes & kRayDiffuse) ? velvet_pdf(wo, wi) : 0.0f;
    case MaterialType::Plastic: return plastic_pdf(p_, wo, wi, lobes);
    case MaterialType::Principled: return principled_pdf(p_, wo, wi, lobes);
    case MaterialType::Clearcoat: {
      float pdf;
      clearcoat_f(p_, wo, wi, &pdf);
      return (lobes & kRayGlossy) ? pdf : 0.0f;
    }
    case MaterialType::Mix: {
      const MixParts p = mix_parts(p_);
      float pdf = 0;
      if (p.prob_b < 1) pdf += (1.0f - p.prob_b) * component(p_.mix_a).pdf(wo, wi, lobes);
      if (p.prob_b > 0) pdf += p.prob_b * component(p_.mix_b).pdf(wo, wi, lobes);
      return pdf;
    }
  }
  return 0.0f;
}

namespace {
// Cycles' sample weight of a material's closures at uv: each closure's mean weight colour
// (kernel/closure/alloc.h: sample_weight = |average(weight)|), a Mix's scaled by its factor
// and summed. RGB at every wavelength, as Cycles'. Principled and plastic count their colour
// once (Cycles splits them into closures weighted by Fresnel: not modelled).
// `p`: the material's RGB parameters at the point (a mix's cached parts; else looked up at ctx).
float closure_weight(const BsdfParams& p, const shading::ShadingContext& ctx) {
  if (p.type == MaterialType::Emission) return 0.0f;
  // Cycles' clearcoat sample weight is 0.25 clearcoat x its Fresnel at wo (unknown here): at
  // normal incidence, 0.04.
  if (p.type == MaterialType::Clearcoat) return 0.04f * clearcoat_weight(p);
  if (p.type != MaterialType::Mix || !p.mix_a || !p.mix_b) return std::abs(p.color.average());
  const MixParts s = mix_parts(p);
  if (p.parts) return s.scale_a * closure_weight(p.parts->a, ctx) + s.scale_b * closure_weight(p.parts->b, ctx);
  return s.scale_a * closure_weight(bsdf_params(*p.mix_a, ctx), ctx) +
         s.scale_b * closure_weight(bsdf_params(*p.mix_b, ctx), ctx);
}
}  // namespace

float Bsdf::closure_pdf(const Vec3& wo, const Vec3& wi, uint8_t lobes) const {
  if (kind() != MaterialType::Mix) return pdf(wo, wi, lobes);
  const MixParts p = mix_parts(p_);
  // The components' RGB parameters (a spectral mix's parts hold them too).
  const bool cached = p_.parts != nullptr;
  const float wa = p.scale_a * closure_weight(cached ? p_.parts->a : bsdf_params(*p_.mix_a, ctx_), ctx_),
              wb = p.scale_b * closure_weight(cached ? p_.parts->b : bsdf_params(*p_.mix_b, ctx_), ctx_);
  if (!(wa + wb > 0)) return pdf(wo, wi, lobes);
  float sum = 0;
  if (wa > 0) sum += wa * component(p_.mix_a).closure_pdf(wo, wi, lobes);
  if (wb > 0) sum += wb * component(p_.mix_b).closure_pdf(wo, wi, lobes);
  return sum / (wa + wb);
}

std::optional<BsdfSample> Bsdf::sample_lobes(const Vec3& wo, float uc, Vec2 u, TransportMode mode) const {
  switch (kind()) {
    case MaterialType::Diffuse: {
      auto s = diffuse_sample(p_, wo, u);
      if (s) s->f *= bump_shadowing(p_, wo, s->wi, mode);
      if (s) s->lobe = kRayDiffuse;
      return s;
    }
    case MaterialType::Conductor: {
      auto s = conductor_sample(p_, wo, u);
      if (s) s->lobe = kRayGlossy;
      return s;
    }
    case MaterialType::Dielectric: {
      auto s = dielectric_sample(p_, wo, uc, u, mode);
      if (s) s->lobe = s->transmission ? kRayTransmission : kRayGlossy;
      return s;
    }
    case MaterialType::Emission: return std::nullopt;
    case MaterialType::Translucent:
    case MaterialType::Velvet: {
      const bool translucent = kind() == MaterialType::Translucent;
      auto s = translucent ? translucent_sample(p_, wo, u) : velvet_sample(p_, wo, u);
      if (s && translucent) s->f *= bump_shadowing(p_, wo, s->wi, mode);
      if (s) s->lobe = kRayDiffuse;  // Cycles labels both diffuse (LABEL_DIFFUSE)
      return s;
    }
    case MaterialType::Plastic: return plastic_sample(p_, wo, uc, u, mode);
    case MaterialType::Principled: return principled_sample(p_, wo, uc, u, mode);
    case MaterialType::Clearcoat: {
      auto s = clearcoat_sample(p_, wo, u);
      if (s) s->lobe = kRayGlossy;
      return s;
    }
    case MaterialType::Mix: {
      const MixParts p = mix_parts(p_);
      const bool pick_b = uc < p.prob_b;
      // Reuse uc for the component's own lobe choice, rescaled to [0, 1).
      const float uc2 = pick_b ? uc / p.prob_b : (uc - p.prob_b) / (1.0f - p.prob_b);
      const float prob = pick_b ? p.prob_b : 1.0f - p.prob_b;
      auto s = component(pick_b ? p_.mix_b : p_.mix_a).sample(wo, std::min(uc2, 0x1.fffffep-1f), u, mode);
      if (!s) return std::nullopt;
      if (s->delta) {
        s->f *= pick_b ? p.scale_b : p.scale_a;
        s->pdf *= prob;
        return s;
      }
      if (is_stochastic()) {
        // A random-walk lobe's density is unknown, so one-sample MIS over the components would
        // be biased: the picked component's weight over its probability, reported with the
        // mixture's (stand-in) pdf for MIS with lights.
        const float cos_i = abs_cos_theta(s->wi);
        const RGB weight = s->f * (cos_i * (pick_b ? p.scale_b : p.scale_a) / (s->pdf * prob));
        s->pdf = pdf(wo, s->wi);
        s->f = weight * (s->pdf / cos_i);
        s->stochastic = true;
        if (!valid_sample(s->f, s->pdf)) return std::nullopt;
        return s;
      }
      s->f = eval(wo, s->wi, mode);
      s->pdf = pdf(wo, s->wi);
      if (!valid_sample(s->f, s->pdf)) return std::nullopt;
      return s;
    }
  }
  return std::nullopt;
}

bool Bsdf::is_delta() const {
  switch (kind()) {
    case MaterialType::Conductor: return p_.roughness < kSmoothAlpha;
    case MaterialType::Dielectric: return dielectric_is_smooth(p_);
    case MaterialType::Clearcoat: return clearcoat_is_smooth(p_);
    case MaterialType::Mix: return component(p_.mix_a).is_delta() && component(p_.mix_b).is_delta();
    default: return false;
  }
}

bool Bsdf::transmits() const {
  switch (kind()) {
    case MaterialType::Dielectric: return !dielectric_is_smooth(p_);
    case MaterialType::Translucent: return true;
    case MaterialType::Mix: {
      const MixParts p = mix_parts(p_);
      return (p.scale_a > 0 && component(p_.mix_a).transmits()) || (p.scale_b > 0 && component(p_.mix_b).transmits());
    }
    default: return false;
  }
}

bool Bsdf::is_stochastic() const {
  switch (kind()) {
    case MaterialType::Conductor:
    case MaterialType::Principled: return p_.distribution == Microfacet::MultiGGX && p_.roughness >= kSmoothAlpha;
    case MaterialType::Dielectric: return p_.distribution == Microfacet::MultiGGX && !dielectric_is_smooth(p_);
    case MaterialType::Mix: return walks(*p_.mix_a) || walks(*p_.mix_b);
    default: return false;
  }
}

namespace {
// Whether a material has a Multiscatter GGX lobe (its roughness aside): read from the material
// tree, not by building the components' BSDFs at every sample.
bool material_walks(const Material& m) {
  if (m.type == MaterialType::Mix) return (m.mix_a && material_walks(*m.mix_a)) || (m.mix_b && material_walks(*m.mix_b));
  return m.distribution == Microfacet::MultiGGX &&
         (m.type == MaterialType::Conductor || m.type == MaterialType::Principled || m.type == MaterialType::Dielectric);
}
}  // namespace

bool Bsdf::walks(const Material& m) { return material_walks(m); }

void Bsdf::salt_walks() {
  // Only where a walk may run (a mix's components salt their own).
  if (p_.distribution != Microfacet::MultiGGX) return;
  p_.walk_salt = walk_key(static_cast<uint64_t>(ctx_.prim) + 0x2545F4914F6CDD1DULL, ctx_.P, Vec3(ctx_.uv.x, ctx_.uv.y, 0.0f));
}

bool Bsdf::is_black() const {
  switch (kind()) {
    case MaterialType::Emission: return true;
    // A black conductor still reflects at grazing angles (Schlick), so only these two qualify.
    case MaterialType::Diffuse:
    case MaterialType::Translucent:
    case MaterialType::Velvet:
    case MaterialType::Dielectric: return p_.color.is_black();
    case MaterialType::Clearcoat: return !(p_.clearcoat > 0.0f);
    case MaterialType::Mix: {
      const MixParts p = mix_parts(p_);
      return (p.scale_a == 0 || component(p_.mix_a).is_black()) && (p.scale_b == 0 || component(p_.mix_b).is_black());
    }
    default: return false;
  }
}

RGB Bsdf::transparency() const {
  switch (kind()) {
    case MaterialType::Dielectric:  // the Transparent BSDF: smooth, IOR 1, its colour the weight
      return p_.ior == 1.0f && p_.roughness == 0.0f && !p_.refraction_only ? p_.color : RGB(0.0f);
    case MaterialType::Mix: {  // svm_node_mix_closure's weights: (1 - f) a + f b; Add: a + b
      const MixParts p = mix_parts(p_);
      const RGB a = p.scale_a > 0 ? component(p_.mix_a).transparency() : RGB(0.0f);
      const RGB b = p.scale_b > 0 ? component(p_.mix_b).transparency() : RGB(0.0f);
      return a * p.scale_a + b * p.scale_b;
    }
    default: return RGB(0.0f);
  }
}

bool Bsdf::is_diffuse_for_photons(float threshold) const {
  switch (kind()) {
    case MaterialType::Diffuse:
    case MaterialType::Translucent:
    case MaterialType::Velvet: return true;
    case MaterialType::Conductor:
    case MaterialType::Dielectric:
    case MaterialType::Clearcoat: return p_.roughness > threshold;
    case MaterialType::Emission: return false;
    case MaterialType::Plastic:
    case MaterialType::Principled: return true;  // its diffuse lobe stores photons
    case MaterialType::Mix:
      return component(p_.mix_a).is_diffuse_for_photons(threshold) || component(p_.mix_b).is_diffuse_for_photons(threshold);
  }
  return false;
}

}  // namespace gp
