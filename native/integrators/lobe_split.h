// Cycles' per-kind ray visibility of lights (Light::visible_lobes) for estimators that find
// emission by BSDF sampling: shared by the path tracer and gradient-domain path tracing (whose
// offset paths weigh their hits the same way, in the base path's measure), and multisampled PPM's
// camera paths (msppm.cpp, without the power heuristic).
//
// A BSDF ray's kind is the lobe that sampled it; a light hidden from some kinds is lit only
// through the lobes that see it. For an unbiased estimate of that restricted integral, int f_V Le,
// which next-event estimation (f and pdf restricted to the visible lobes V) and BSDF hits share
// under MIS, a hit counts only when the sampled lobe is in V, weighted f_V cos / p_V with p_V the
// density of reaching the direction through V's lobes (the restricted BSDF pdf): its expectation
// is then int f_V Le w_bsdf(p_V), and NEE's int f_V Le w_light(p_V), which sum to int f_V Le.
//
// The World follows another rule, Cycles 3.4's own: Cycles does not sample a constant World as
// a light (scene/light.cpp, test_enabled_lights: background MIS off without spatial variation,
// and gradphoton's World is constant), and a BSDF ray of a visible kind carries the whole
// f/pdf (shade_background.h: the World's SHADER_EXCLUDE_* flags only zero rays of a hidden
// kind). So a World hidden from some kinds lights a surface with
//   int f(wi) q_V(wi) Le cos dwi,  q_V = sum_{k in V} P_C(k | wi),
// P_C(k | wi) the probability that Cycles' BSDF sample in direction wi came through a closure
// of kind k (closures picked by sample weight: Bsdf::closure_pdf), which lets the other lobes'
// colour into what the sky lights. Next-event estimation skips such a World, and a BSDF hit of
// kind k in V counts beta Le P_C(k | wi) / P(k | wi), P this sampler's lobe choice (its
// expectation is then exactly the integral above, ray by ray of each kind as Cycles').
#pragma once

#include <cstdint>

#include "core/color.h"
#include "core/math.h"
#include "core/sampling.h"
#include "lights/light.h"
#include "materials/bsdf.h"

namespace gp {

struct LobeSplit {
  RGB f[3];        // f of the diffuse, glossy, transmission lobes for the sampled direction
  float pdf[3]{};  // their share of the BSDF's sampling density
  float cpdf[3]{}; // their share of Cycles' (Bsdf::closure_pdf), for the World
  RGB beta;        // throughput before the vertex (Russian roulette's factor included)
  float cos = 0;   // |cos| of the sampled direction
  uint8_t lobe = 0;

  void fill(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi) {
    for (int k = 0; k < 3; ++k) {
      const uint8_t bit = static_cast<uint8_t>(kRayDiffuse << k);
      f[k] = bsdf.eval(wo, wi, TransportMode::Radiance, bit);
      pdf[k] = bsdf.pdf(wo, wi, bit);
      cpdf[k] = bsdf.closure_pdf(wo, wi, bit);
    }
    cos = std::abs(wi.z);
  }
  // The restricted density p_V of the lobes in `vis`.
  float pdf_of(uint8_t vis) const {
    float pv = 0;
    for (int k = 0; k < 3; ++k)
      if (vis & (kRayDiffuse << k)) pv += pdf[k];
    return pv;
  }
  // f_V: the lobes in `vis` for the sampled direction.
  RGB f_of(uint8_t vis) const {
    RGB fv(0.0f);
    for (int k = 0; k < 3; ++k)
      if (vis & (kRayDiffuse << k)) fv += f[k];
    return fv;
  }
  // The throughput after the vertex of a sample that reaches something visible to `vis`:
  // beta f_V |cos| / p_V (beta_now after a delta vertex), 0 when its lobe is not in `vis`. The
  // restricted integral's estimate before any MIS weight (multisampled PPM weighs it by its
  // own balance heuristic over whole paths, in which the vertex's density is p_V).
  RGB throughput(uint8_t vis, bool delta, const RGB& beta_now) const {
    if (!(vis & lobe)) return RGB(0.0f);
    if (delta) return beta_now;
    const float pv = pdf_of(vis);
    return pv > 0 ? beta * f_of(vis) * (cos / pv) : RGB(0.0f);
  }
  // The probability that the sampled direction came through lobe `lobe_bit`: this sampler's,
  // and Cycles' (closure sample weights).
  float lobe_share(uint8_t lobe_bit) const { return share(pdf, lobe_bit); }
  float cycles_lobe_share(uint8_t lobe_bit) const { return share(cpdf, lobe_bit); }
  // The contribution of radiance Le from a World visible to `vis` found by the BSDF ray (see
  // above: full weight, no MIS; a Dirac sample's kind is its lobe's). A shifted path (gradient
  // methods) passes the base's lobe_share: its sample's probability in the base path's measure.
  RGB weigh_world(const RGB& Le, uint8_t vis, bool delta, const RGB& beta_now, float base_share = -1.0f) const {
    if (!(vis & lobe)) return RGB(0.0f);
    if (delta) return beta_now * Le;
    const float p = base_share < 0 ? lobe_share(lobe) : base_share;
    if (!(p > 0)) return RGB(0.0f);
    return beta_now * Le * (cycles_lobe_share(lobe) / p);
  }
  // The contribution of emission Le found by the BSDF ray, from a light visible to `vis`
  // (a Dirac sample: full weight when its lobe sees the light). A shifted path (gradient
  // methods) passes the shift's Jacobian and the base's p_V, the density its sample has in
  // the base path's measure; the base passes 1 and its own.
  RGB weigh(const RGB& Le, uint8_t vis, bool delta, const RGB& beta_now, float pdf_light, float jacobian = 1.0f,
            float base_pdf_v = -1.0f) const {
    if (!(vis & lobe)) return RGB(0.0f);
    if (delta) return beta_now * Le;
    const float pv = pdf_of(vis);
    const float pb = base_pdf_v < 0 ? pv : base_pdf_v;
    if (!(pv > 0) || !(pb > 0)) return RGB(0.0f);
    return beta * f_of(vis) * (cos * jacobian / pb) * Le * power_heuristic(pv, pdf_light);
  }

 private:
  static float share(const float (&p)[3], uint8_t lobe_bit) {
    float sum = 0, mine = 0;
    for (int k = 0; k < 3; ++k) {
      sum += p[k];
      if (lobe_bit & (kRayDiffuse << k)) mine += p[k];
    }
    return sum > 0 ? mine / sum : 0.0f;
  }
};

// The BSDF that light `light` (null: none) lights by next-event estimation alone, with no BSDF
// hits to share it with (photon methods' measurement points): the lobes that see a light, and
// for a World hidden from some kinds f q_V of the rule above (the expectation of Cycles' BSDF
// rays). wo, wi: unit directions in the shading frame.
// q_V(wo, wi) of the rule above: the probability that Cycles' BSDF sample leaving towards wi
// from wo (the camera side) came through a closure of a kind in `vis` (0 where Cycles' BSDF
// reaches wi by no closure).
inline float closure_share(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi, uint8_t vis) {
  const float all = bsdf.closure_pdf(wo, wi);
  return all > 0 ? bsdf.closure_pdf(wo, wi, vis) / all : 0.0f;
}

inline RGB nee_only_f(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi, const Light* light) {
  if (!light) return bsdf.eval(wo, wi);
  if (!light->lit_by_bsdf_rays_only()) return bsdf.eval(wo, wi, TransportMode::Radiance, light->visible_lobes);
  const float q = closure_share(bsdf, wo, wi, light->visible_lobes);
  return q > 0 ? bsdf.eval(wo, wi) * q : RGB(0.0f);
}

// The BSDF a gathered photon lights a measurement point with (wo: towards the camera, wi: the
// photon's direction back where it came from, both local): the lobes in `lobes` (Photon::lobes,
// the lights' rule), or for a photon straight from a World hidden from some kinds
// (Photon::world_share) f q_V of the rule above: the measurement point's BSDF ray towards wi is
// the one that would find the sky, so the closure choice is the one there.
inline RGB gathered_f(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi, uint8_t lobes, bool world_share) {
  if (!world_share) return bsdf.eval(wo, wi, TransportMode::Radiance, lobes);
  const float q = closure_share(bsdf, wo, wi, lobes);
  return q > 0 ? bsdf.eval(wo, wi) * q : RGB(0.0f);
}

}  // namespace gp
