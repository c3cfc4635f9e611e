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
#pragma once

#include <cstdint>

#include "core/color.h"
#include "core/math.h"
#include "core/sampling.h"
#include "materials/bsdf.h"

namespace gp {

struct LobeSplit {
  RGB f[3];        // f of the diffuse, glossy, transmission lobes for the sampled direction
  float pdf[3]{};  // their share of the BSDF's sampling density
  RGB beta;        // throughput before the vertex (Russian roulette's factor included)
  float cos = 0;   // |cos| of the sampled direction
  uint8_t lobe = 0;

  void fill(const Bsdf& bsdf, const Vec3& wo, const Vec3& wi) {
    for (int k = 0; k < 3; ++k) {
      const uint8_t bit = static_cast<uint8_t>(kRayDiffuse << k);
      f[k] = bsdf.eval(wo, wi, TransportMode::Radiance, bit);
      pdf[k] = bsdf.pdf(wo, wi, bit);
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
};

}  // namespace gp
