// MSPPM's multiple importance weights (thesis eq. 9.5-9.8; eq. 9.19 without the bias term): the
// full-path reference mis_weight() and the O(1) incremental weights of the photon gathering
// (msppm.h, "Incremental weights"). The estimator that uses them is msppm.cpp.
#include <algorithm>
#include <cmath>

#include "integrators/photon/msppm.h"
#include "integrators/photon/msppm_densities.h"
#include "materials/bsdf.h"

namespace gp {
using msppm_detail::densities;
using msppm_detail::light_lobes;

// ---- Path densities and the balance heuristic (thesis eq. 9.5-9.8, 9.19 without bias) ----
double Msppm::mis_weight(const std::vector<PathVertex>& y, int technique, double npm, double npt) const {
  const int k = static_cast<int>(y.size()) - 1;
  if (k < 1) return 0.0;
  const LightSet& lights = scene_.light_set();
  const PathVertex& lv = y[k];
  // Unit direction from vertex a towards vertex b (towards the light for a distant light vertex).
  auto towards = [&](int a, int b) -> Vec3 {
    if (y[b].distant) return -y[b].dir;
    return normalize(y[b].p - y[a].p);
  };
  // Solid-angle density of scattering at vertex v from direction towards `from` into `to`.
  auto dir_pdf = [&](int v, int from, int to) -> double {
    const PathVertex& a = y[v];
    if (a.delta) return 1.0;  // specular: the same delta on both sides, left out
    if (a.material < 0 || !a.frame) return 0.0;
    const Bsdf bsdf = scene_.bsdf(a.material, a.uv);
    const uint8_t lobes = v == k - 1 ? light_lobes(scene_, lv.light) : kAllLobes;  // (msppm_densities.h)
    return bsdf.pdf(a.frame->to_local(towards(v, from)), a.frame->to_local(towards(v, to)), lobes);
  };
  // Area density conversion at vertex b of a segment leaving a: |cos_b| / d^2.
  auto to_area = [&](int a, int b) -> double {
    if (y[b].distant) return 1.0;  // directions for a vertex at infinity
    const Vec3 d = y[b].p - y[a].p;
    const double d2 = length_squared(d);
    if (!(d2 > 0)) return 0.0;
    return std::abs(dot(y[b].ng, d)) / std::sqrt(d2) / d2;
  };
  // Light emission densities along the last segment.
  float e_pos = 0, e_dir = 0;
  {
    const Vec3 travel = lv.distant ? lv.dir : (k >= 2 ? normalize(y[k - 1].p - lv.p) : Vec3(0, 0, 1));
    if (lv.light >= 0 && k >= 2) lights.emission_pdf(lv.light, travel, e_pos, e_dir);
  }
  // E[i]: camera side samples y_i (i >= 2); E[1] = 1 (the pixel, common to all techniques).
  // Scratch per thread (this runs once per gathered photon: no allocations).
  thread_local std::vector<double> E, L, PE, SL;
  E.assign(k + 1, 1.0);
  L.assign(k + 1, 1.0);
  PE.assign(k + 1, 1.0);
  SL.assign(k + 2, 1.0);
  for (int i = 2; i <= k; ++i) E[i] = dir_pdf(i - 1, i - 2, i) * to_area(i - 1, i);
  // L[i]: light side samples y_i (i <= k).
  if (k >= 2) {
    L[k] = lv.distant ? e_dir : e_pos;
    L[k - 1] = lv.distant ? e_pos * std::abs(dot(y[k - 1].ng, lv.dir)) : e_dir * to_area(k, k - 1);
    for (int i = k - 2; i >= 1; --i) L[i] = dir_pdf(i + 1, i + 2, i) * to_area(i + 1, i);
  }
  // Next-event estimation's density of y_k from y_{k-1}.
  double p_nee = 0;
  if (k >= 2 && lv.light >= 0) {
    const Light& l = lights.lights()[lv.light];
    const float pmf = lights.selection_pmf(lv.light);
    if (l.type == LightType::Area) {
      const float c = dot(l.n, normalize(y[k - 1].p - lv.p));
      p_nee = (c > 0 || (l.two_sided && c < 0)) ? pmf / l.area : 0.0;
    } else if (l.type == LightType::Environment) {
      p_nee = lights.pdf_environment(-lv.dir);
    } else {
      // Delta lights: the selection probability (the delta left out). A point or spot light of
      // radius r is a disk here: next-event estimation draws a point of the disk facing y_{k-1}
      // and the photon one of the disk across its direction (light.cpp, emission_origin), both
      // at 1 / (pi r^2), which cancels as the delta does; the two disks differ by an angle of
      // order r / |y_{k-1} - centre|. The weights stay a partition of unity (every technique
      // computes them from the same path), so only their balance is off by that order.
      p_nee = pmf;
    }
  }
  const bool hit_ok = lv.light >= 0 && (lights.lights()[lv.light].type == LightType::Area ||
                                        lights.lights()[lv.light].type == LightType::Environment);
  // Prefix products of E, suffix products of L.
  for (int i = 2; i <= k; ++i) PE[i] = PE[i - 1] * E[i];
  for (int i = k; i >= 1; --i) SL[i] = SL[i + 1] * L[i];
  // n_i p_i of eq. 9.19 (bias ignored): n_pt samples each of hit and NEE, n_pm of each merge.
  const double q_hit = hit_ok ? npt * PE[k] : 0.0;
  const double q_nee = (k >= 2 && !y[k - 1].delta) ? npt * PE[k - 1] * p_nee : 0.0;
  double sum = q_hit + q_nee, mine = technique == 0 ? q_hit : technique == 1 ? q_nee : 0.0;
  for (int t = 1; t <= k - 1; ++t) {
    const double q = y[t].mergeable ? npm * PE[t] * SL[t] : 0.0;
    sum += q;
    if (technique == 2 + t) mine = q;
  }
  if (!(sum > 0) || !std::isfinite(sum)) return technique == 0 || technique == 1 ? 1.0 : 0.0;
  return mine / sum;
}

// ---- O(1) weight of density estimation (doc block "Incremental weights") ----

Msppm::PathVertex Msppm::photon_path_vertex(const PhotonPathVertex& pv, bool mergeable) const {
  PathVertex v;
  v.p = pv.p;
  v.ng = pv.ng;
  if (pv.start) {
    v.light = pv.light;
    v.distant = scene_.light_set().lights()[pv.light].is_infinite();
    v.dir = pv.wi;
    return v;
  }
  v.frame = &pv.frame;
  v.material = pv.material;
  v.uv = pv.uv;
  v.delta = pv.delta;
  v.mergeable = mergeable;
  return v;
}

void Msppm::photon_tails(const PhotonPathRecord& record, std::vector<PhotonTail>& tails) const {
  const size_t nv = record.vertices.size();
  tails.assign(record.deposit_vertex.size(), PhotonTail{});
  thread_local std::vector<PathVertex> z;
  thread_local std::vector<double> RP, RH;
  thread_local std::vector<int> before;
  size_t begin = 0, dep = 0;
  while (begin < nv) {
    size_t end = begin + 1;
    while (end < nv && !record.vertices[end].start) ++end;
    // The path z_0 (light) .. z_n: the record's vertices less the surfaces the photon crossed
    // (the segment goes straight on through them); before[a]: how many of them precede record
    // vertex begin + a, the depth of a deposit there (crossed or not). As a path ending on the
    // light, y_j = z_{k-j} with k = n + 1 (y_0 is never reached: R_j needs y_{j-1} = z_{a+1}).
    // Media: the path up to its first scattering point in a medium; a deposit after that point
    // closes paths with a medium vertex, which the beam radiance estimate's partition takes
    // (msppm.h, "Participating media"): its tail says so and has no densities.
    z.clear();
    before.clear();
    size_t first_medium = end;
    for (size_t a = begin; a < end; ++a) {
      const PhotonPathVertex& pv = record.vertices[a];
      if (pv.medium) {
        first_medium = a;
        break;
      }
      before.push_back(static_cast<int>(z.size()));
      if (pv.crossed) continue;
      const bool m = !pv.start && !pv.delta;  // mergeable: every non-delta vertex (§9.6)
      z.push_back(photon_path_vertex(pv, m));
    }
    const int n = static_cast<int>(z.size()) - 1;
    const int k = n + 1;
    auto y = [&](int j) -> const PathVertex& { return z[k - j]; };
    const auto d = densities(scene_, y, k);
    // R_j = P + H / n_pm at z_a (j = k - a) for 1 <= a <= n - 1 (eq. 9.5 summed from y_j to the
    // light, over q(y_j)), and L_j, the light-side density of z_a.
    RP.assign(n + 1, 0.0);
    RH.assign(n + 1, 0.0);
    // z_1's terminal parts, for depth-2 deposits (those on a surface crossed after z_1 too).
    double term_hit_over = 0, term_nee_over = 0;
    if (n >= 1) {
      d.light_end();
      term_hit_over = d.hit ? 1.0 / d.denom : 0.0 / d.denom;
      term_nee_over = d.nee / d.denom;
    }
    for (int a = 1; a <= n - 1; ++a) {
      const int j = k - a;
      if (a == 1) {
        d.terminal(RP[1], RH[1]);  // R_{k-1}
      } else {
        // R_j = m_j + (E_{j+1} / L_j) R_{j+1}
        const double u = d.E(j + 1) / d.L_inner(j);
        RP[a] = (z[a].mergeable ? 1.0 : 0.0) + u * RP[a - 1];
        RH[a] = u * RH[a - 1];
      }
    }
    // Deposits of this path (in order: their vertices increase).
    while (dep < record.deposit_vertex.size() && record.deposit_vertex[dep] < end) {
      PhotonTail& tl = tails[dep];
      if (record.deposit_vertex[dep] > first_medium) {
        tl.depth = 0;
        tl.through_medium = true;
        ++dep;
        continue;
      }
      const int dd = before[record.deposit_vertex[dep] - begin];  // depth of the deposit
      const PathVertex& v = z[dd - 1];  // y_{t+1}
      tl.p = v.p;
      tl.ng = v.ng;
      tl.depth = dd;
      tl.light = v.light;
      tl.distant = v.distant;
      if (dd == 1) {
        tl.to_next = v.dir;
      } else {
        tl.frame = *v.frame;
        tl.material = v.material;
        tl.uv = v.uv;
        tl.delta = v.delta;
        tl.mergeable = v.mergeable;
        // In the photon's own indexing y_{t+1} = z_{dd-1} is y_{j1}, j1 = k - (dd - 1).
        const int j1 = k - (dd - 1);
        tl.lobes = d.lobes_at(j1);
        tl.to_next = d.towards(j1, j1 + 1);
        const double g_next = d.to_area(j1, j1 + 1);  // area factor of y_{t+2} from y_{t+1}
        if (dd == 2) {
          // R_{t+1} is the terminal R_{k-1}: (E_k hit + nee) / (L_{k-1} L_k), E_k = p_rev g_next.
          tl.A_P = 0;
          tl.A_H = g_next * term_hit_over;
          tl.B_H = term_nee_over;
        } else {
          // R_{t+1} = m_{t+1} + (E_{t+2} / L_{t+1}) R_{t+2}, E_{t+2} = p_rev g_next.
          const double L1 = d.L_inner(j1);  // L_{t+1}, light side only
          tl.A_P = g_next * RP[dd - 2] / L1;
          tl.A_H = g_next * RH[dd - 2] / L1;
          tl.B_H = 0;
        }
      }
      ++dep;
    }
    begin = end;
  }
}

void Msppm::camera_prefix(const PathVertex* yc, int n, double* c) const {
  // B_j = m_j + (L_{j-1} / E_j) B_{j-1}, B_0 = 0; c_j = B_{j-1} / E_j. L_{j-1} needs y_{j+1}, so
  // B_j exists for j < n and c_j for j <= n.
  auto y = [&](int i) -> const PathVertex& { return yc[i]; };
  const auto d = densities(scene_, y, n + 3);  // k only has to exceed the indices used
  double B = 0;  // B_{j-1}
  for (int j = 1; j <= n; ++j) {
    c[j] = j == 1 ? 0.0 : B / d.E(j);
    if (j < n) B = (yc[j].mergeable ? 1.0 : 0.0) + (j == 1 ? 0.0 : d.L_inner(j - 1) * c[j]);
  }
}

double Msppm::merge_weight(const PathVertex* yc, int t, const double* c, const PhotonTail& tl, double npm) const {
  if (!(npm > 0) || !yc[t].mergeable || tl.depth < 1) return 0.0;
  // The full path: y_0 .. y_t from the camera, y_{t+1} = the tail's vertex, then the photon's
  // earlier vertices; k = t + depth. 1 / w_t = sum_s q(s) / q(t) = (L_{t-1} / E_t) B_{t-1} + R_t.
  const PathVertex& e = yc[t];
  const Bsdf bsdf = scene_.bsdf(e.material, e.uv);
  const Vec3 to_prev = normalize(yc[t - 1].p - e.p);  // towards(t, t - 1)
  double P, H;
  if (tl.depth == 1) {
    // Photon at its first hit: y_{t+1} is the light vertex, R_t the terminal R_{k-1}.
    PathVertex w[2];
    w[1].p = tl.p;
    w[1].ng = tl.ng;
    w[1].light = tl.light;
    w[1].distant = tl.distant;
    w[1].dir = tl.to_next;
    auto y = [&](int i) -> const PathVertex& { return i <= t ? yc[i] : w[1]; };
    const auto d = densities(scene_, y, t + 1);
    d.terminal(P, H);
  } else {
    const Vec3 dv = e.p - tl.p;  // from y_{t+1} to y_t
    const double d2 = length_squared(dv);
    if (!(d2 > 0)) return 0.0;  // to_area(t+1, t) = 0: q(t) = 0
    const Vec3 to_cam = normalize(dv);
    double p_fwd = 1.0, p_rev = 1.0;  // at y_{t+1}: towards y_t from y_{t+2}, and back
    if (!tl.delta) {
      const Bsdf b = scene_.bsdf(tl.material, tl.uv);
      const Vec3 lc = tl.frame.to_local(to_cam), ln = tl.frame.to_local(tl.to_next);
      p_fwd = b.pdf(ln, lc, tl.lobes);
      p_rev = b.pdf(lc, ln, tl.lobes);
    }
    const double L_t = p_fwd * (std::abs(dot(e.ng, dv)) / std::sqrt(d2) / d2);  // eq. 9.8
    const double P1 = (tl.mergeable ? 1.0 : 0.0) + p_rev * tl.A_P;            // R_{t+1}
    const double H1 = p_rev * tl.A_H + tl.B_H;
    const double E_t1 = (e.delta ? 1.0 : bsdf.pdf(e.frame->to_local(to_prev), e.frame->to_local(-to_cam))) *
                        (std::abs(dot(tl.ng, dv)) / std::sqrt(d2) / d2);  // eq. 9.7
    const double u = E_t1 / L_t;  // R_t = 1 + (E_{t+1} / L_t) R_{t+1}
    P = 1.0 + u * P1;
    H = u * H1;
  }
  double left = 0.0;
  if (t >= 2) {
    // L_{t-1} = p(y_t: y_{t+1} -> y_{t-1}) |cos| / d^2 at y_{t-1}.
    const Vec3 dp = yc[t - 1].p - e.p;
    const double dp2 = length_squared(dp);
    const Vec3 from = tl.depth == 1 && tl.distant ? -tl.to_next : normalize(tl.p - e.p);
    const uint8_t lobes = tl.depth == 1 ? light_lobes(scene_, tl.light) : kAllLobes;  // y_t before the light
    const double L_prev = dp2 > 0 ? (e.delta ? 1.0 : bsdf.pdf(e.frame->to_local(from), e.frame->to_local(to_prev), lobes)) *
                                        (std::abs(dot(yc[t - 1].ng, dp)) / std::sqrt(dp2) / dp2)
                                  : 0.0;
    left = L_prev * c[t];
  }
  const double inv = left + P + H / npm;
  if (!std::isfinite(inv) || !(inv > 0)) return 0.0;  // a zero factor of q(t), or overflow
  return 1.0 / inv;
}

double Msppm::light_weight(const std::vector<PathVertex>& y, int technique, double c_last, double npm) const {
  const int k = static_cast<int>(y.size()) - 1;
  if (k < 2) return 1.0;  // the camera sees the light: no other technique (as mis_weight)
  auto acc = [&](int i) -> const PathVertex& { return y[i]; };
  const auto d = densities(scene_, acc, k);
  double P, H;
  d.terminal(P, H);
  const double pm = npm * d.denom * ((y[k - 1].mergeable ? 1.0 : 0.0) + (k >= 3 ? d.L_inner(k - 2) * c_last : 0.0));
  const double sum = d.q_hit + d.nee + pm;
  if (!(sum > 0) || !std::isfinite(sum)) return 1.0;  // as mis_weight
  return (technique == 0 ? d.q_hit : d.nee) / sum;
}

}  // namespace gp
