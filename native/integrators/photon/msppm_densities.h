// The per-vertex area densities of MSPPM's path densities (thesis eq. 9.6-9.8), shared by the
// weights (msppm_weights.cpp) and the camera pass (msppm.cpp). Internal to MSPPM.
#pragma once

#include <cmath>

#include "integrators/photon/msppm.h"
#include "materials/bsdf.h"

namespace gp::msppm_detail {

// The lobes through which the vertex before a light vertex of light `light` scatters, in both
// directions: those of the kinds of bounce ray that see the light (Light::visible_lobes, Cycles'
// switches), all for any other vertex. The techniques sample that vertex with them: the camera
// path's hits count when the sampled lobe sees the light (weighted f_V / p_V, lobe_split.h),
// next-event estimation and the gather evaluate f_V, and a photon scatters on from its first hit
// only through them (photon_tracer.cpp); so its direction densities there are p_V.
inline uint8_t light_lobes(const Scene& scene, int light) {
  return light >= 0 ? scene.light_set().lights()[light].visible_lobes : kAllLobes;
}

// The per-vertex area densities E_i, L_i of eq. 9.6-9.8 for a path reached through an accessor
// y(i) (i = 0 camera .. k light), with exactly the formulas of Msppm::mis_weight.
template <class Y>
struct PathDensities {
  const Scene& scene;
  const Y& y;
  int k;
  Vec3 towards(int a, int b) const {
    const Msppm::PathVertex& vb = y(b);
    if (vb.distant) return -vb.dir;
    return normalize(vb.p - y(a).p);
  }
  // The lobes of y_v (light_lobes for y_{k-1}; y(k) is read only then: callers whose k merely
  // exceeds the indices they use never reach it).
  uint8_t lobes_at(int v) const { return v == k - 1 ? light_lobes(scene, y(k).light) : kAllLobes; }
  double dir_pdf(int v, int from, int to) const {
    const Msppm::PathVertex& a = y(v);
    if (a.delta) return 1.0;
    if (a.material < 0 || !a.frame) return 0.0;
    const Bsdf bsdf = scene.bsdf(a.material, a.uv);
    return bsdf.pdf(a.frame->to_local(towards(v, from)), a.frame->to_local(towards(v, to)), lobes_at(v));
  }
  double to_area(int a, int b) const {
    const Msppm::PathVertex& vb = y(b);
    if (vb.distant) return 1.0;
    const Vec3 d = vb.p - y(a).p;
    const double d2 = length_squared(d);
    if (!(d2 > 0)) return 0.0;
    return std::abs(dot(vb.ng, d)) / std::sqrt(d2) / d2;
  }
  // Camera side density of y_i (eq. 9.7); E_1 = 1 (the pixel, common to all techniques).
  double E(int i) const { return i <= 1 ? 1.0 : dir_pdf(i - 1, i - 2, i) * to_area(i - 1, i); }
  // Light side density of y_i for i <= k - 2 (eq. 9.8).
  double L_inner(int i) const { return dir_pdf(i + 1, i + 2, i) * to_area(i + 1, i); }
  // The end of the light-side recursion: R_{k-1} = P + H / n_pm with
  //   P = m_{k-1},  H = (E_k [hit possible] + p_nee(y_k) [y_{k-1} not delta]) / (L_{k-1} L_k).
  void terminal(double& P, double& H) const {  // (also sets hit, nee, denom, q_hit)
    light_end();
    q_hit = hit ? E(k) : 0.0;
    P = y(k - 1).mergeable ? 1.0 : 0.0;
    H = (q_hit + nee) / denom;
  }
  // The parts of terminal() that do not read y_{k-2} (a photon deposited on a surface it then
  // crossed may have no such vertex of its own): hit, nee and denom.
  void light_end() const {
    const LightSet& lights = scene.light_set();
    const Msppm::PathVertex& lv = y(k);
    const Msppm::PathVertex& prev = y(k - 1);
    float e_pos = 0, e_dir = 0;
    const Vec3 travel = lv.distant ? lv.dir : normalize(prev.p - lv.p);
    if (lv.light >= 0) lights.emission_pdf(lv.light, travel, e_pos, e_dir);
    const double Lk = lv.distant ? e_dir : e_pos;
    const double Lk1 = lv.distant ? e_pos * std::abs(dot(prev.ng, lv.dir)) : e_dir * to_area(k, k - 1);
    double p_nee = 0;
    bool hit_ok = false;
    if (lv.light >= 0) {
      const Light& l = lights.lights()[lv.light];
      const float pmf = lights.selection_pmf(lv.light);
      if (l.type == LightType::Area) {
        const float c = dot(l.n, normalize(prev.p - lv.p));
        p_nee = (c > 0 || (l.two_sided && c < 0)) ? pmf / l.area : 0.0;
      } else if (l.type == LightType::Environment) {
        p_nee = lights.pdf_environment(-lv.dir);
      } else {
        p_nee = pmf;
      }
      hit_ok = l.type == LightType::Area || l.type == LightType::Environment;
    }
    hit = hit_ok;
    nee = prev.delta ? 0.0 : p_nee;
    denom = Lk1 * Lk;
  }
  // Set by light_end(): H = (E_k hit + nee) / denom.
  mutable bool hit = false;
  mutable double nee = 0, denom = 0, q_hit = 0;
};
template <class Y>
PathDensities<Y> densities(const Scene& scene, const Y& y, int k) {
  return PathDensities<Y>{scene, y, k};
}
}  // namespace gp::msppm_detail
