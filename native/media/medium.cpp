#include "media/medium.h"

#include <algorithm>
#include <cstring>
#include <vector>

#include "core/rng.h"

namespace gp {

namespace {
// exp(-sigma t) that is 1 for sigma = 0 at any t (0 * inf is NaN).
inline float beer_lambert(float sigma_t, float t) { return sigma_t > 0 ? std::exp(-sigma_t * t) : 1.0f; }
}  // namespace

MediumChannels rgb_channels(const Medium& m) {
  MediumChannels c;
  for (int k = 0; k < 3; ++k) {
    c.sigma_a[k] = m.sigma_a[k];
    c.sigma_s[k] = m.sigma_s[k];
    c.sigma_t[k] = m.sigma_a[k] + m.sigma_s[k];
    c.emission[k] = m.emission[k];
  }
  c.g = m.g;
  c.grid = m.grid.get();
  for (int k = 0; k < 3; ++k) c.rgb_basis[k][k] = 1.0f;
  return c;
}

MediumSpectra::MediumSpectra(const Medium& m)
    : sigma_a(RgbSpectrum::illuminant(m.sigma_a)),
      sigma_s(RgbSpectrum::illuminant(m.sigma_s)),
      emission(RgbSpectrum::illuminant(m.emission)),
      g(m.g),
      grid(m.grid.get()) {
  // A point's RGB (colour grid, blackbody) at wavelengths: the sum of the primaries' unbounded
  // upsamplings, linear in the RGB so that it can be applied per point (an approximation of
  // upsampling each point's colour; without a colour grid the scattering is exact).
  if (grid)
    for (int k = 0; k < 3; ++k) {
      RGB e(0.0f);
      e[k] = 1.0f;
      primaries[k] = RgbSpectrum::illuminant(e);
    }
}

MediumChannels MediumSpectra::at(const SampledWavelengths& wl) const {
  MediumChannels c;
  for (int k = 0; k < wl.count; ++k) {
    c.sigma_a[k] = std::max(0.0f, sigma_a(wl.lambda[k]));
    c.sigma_s[k] = std::max(0.0f, sigma_s(wl.lambda[k]));
    c.sigma_t[k] = c.sigma_a[k] + c.sigma_s[k];
    c.emission[k] = std::max(0.0f, emission(wl.lambda[k]));
    if (grid)
      for (int p = 0; p < 3; ++p) c.rgb_basis[p][k] = primaries[p](wl.lambda[k]);
  }
  c.g = g;
  c.grid = grid;
  return c;
}

// ---- Grid media at a point ----

namespace {
// RGB at a path's channels through the primaries' basis (>= 0).
inline float to_channel(const MediumChannels& c, const RGB& v, int k) {
  return std::max(0.0f, v.r * c.rgb_basis[0][k] + v.g * c.rgb_basis[1][k] + v.b * c.rgb_basis[2][k]);
}
// Principled Volume's extinction per unit density of colour C: C + max(1 - C, 0) x A', A' =
// max(1 - sqrt(absorption colour), 0); increasing in C >= 0 (so the block's max colour bounds it).
inline RGB extinction_of(const RGB& C, const RGB& absorption) {
  RGB t;
  for (int k = 0; k < 3; ++k)
    t[k] = C[k] + std::max(1.0f - C[k], 0.0f) * std::max(1.0f - std::sqrt(std::max(absorption[k], 0.0f)), 0.0f);
  return t;
}
}  // namespace

void add_grid_point(const MediumChannels& c, int n, const Vec3& p, bool emission, PointCoefficients& out) {
  const GridMedium& g = *c.grid;
  const Vec3 idx = g.world_to_index().point(p);
  const float d = g.density_at(idx);
  if (d > 0) {
    if (g.has_color_grid()) {
      const RGB C = g.color_at(idx);
      const float D = d * g.params().density;
      const RGB s = C * D, t = extinction_of(C, g.params().absorption_color) * D;
      for (int k = 0; k < n; ++k) {
        const float tk = to_channel(c, t, k);
        out.sigma_t[k] += tk;
        out.sigma_s[k] += std::min(to_channel(c, s, k), tk);
      }
    } else {
      for (int k = 0; k < n; ++k) {
        out.sigma_s[k] += d * c.sigma_s[k];
        out.sigma_t[k] += d * c.sigma_t[k];
      }
    }
  }
  if (emission) {
    for (int k = 0; k < n; ++k) out.emission[k] += c.emission[k];  // not weighted by density (Cycles)
    if (g.emits_blackbody()) {
      const RGB bb = g.blackbody_at(idx);
      for (int k = 0; k < n; ++k) out.emission[k] += to_channel(c, bb, k);
    }
  }
}

float grid_majorant(const MediumChannels& c, int n, const GridMedium::Bound& b) {
  const GridMedium& g = *c.grid;
  if (!(b.density > 0)) return 0.0f;
  float m = 0;
  if (g.has_color_grid()) {
    const RGB t = extinction_of(b.color, g.params().absorption_color) * (b.density * g.params().density);
    for (int k = 0; k < n; ++k)
      m = std::max(m, t.r * std::max(c.rgb_basis[0][k], 0.0f) + t.g * std::max(c.rgb_basis[1][k], 0.0f) +
                          t.b * std::max(c.rgb_basis[2][k], 0.0f));
  } else {
    for (int k = 0; k < n; ++k) m = std::max(m, b.density * c.sigma_t[k]);
  }
  return m * 1.0001f;  // round-off of the lookups' lerps stays under it
}

bool grid_emits(const MediumChannels& c, int n, const GridMedium::Bound& b) {
  for (int k = 0; k < n; ++k)
    if (c.emission[k] > 0) return true;
  return c.grid->emits_blackbody() && b.temperature > 0;
}

uint64_t ray_seed(const Vec3& o, const Vec3& d, uint64_t salt) {
  auto bits = [](float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return uint64_t(u);
  };
  uint64_t h = mix_bits(salt + 0x9E3779B97F4A7C15ULL);
  for (float f : {o.x, o.y, o.z, d.x, d.y, d.z}) h = mix_bits(h ^ (bits(f) + 0x632BE59BD9B4E019ULL));
  return h;
}

namespace {
constexpr int kMaxCollisions = 1 << 16;  // per tracking: beyond, the walk counts as absorbed (no hang)
}

namespace {
// Ratio tracking (Novak et al. 2014) of grid medium `c` along o + t d over [t0, t1): at every
// tentative collision s the running product T *= 1 - sigma_t(s) / majorant, then
// at_collision(s, T). Returns T at t1 (0 when a channel-wide zero or too many collisions ended it).
template <class F>
ChannelValues ratio_track(const MediumChannels& c, int n, const Vec3& o, const Vec3& d, float t0, float t1,
                          uint64_t seed, F&& at_collision) {
  ChannelValues T{};
  for (int k = 0; k < n; ++k) T[k] = 1.0f;
  const GridMedium& g = *c.grid;
  const Affine& w2i = g.world_to_index();
  Rng rng(seed, seed >> 17);
  float tau = -std::log1p(-rng.uniform());  // optical depth to the next tentative collision
  int events = 0;
  bool alive = true;
  g.walk(w2i.point(o), w2i.vector(d), t0, t1, [&](float a, float b, const GridMedium::Bound& bound) {
    const float maj = grid_majorant(c, n, bound);
    if (!(maj > 0)) return true;
    float t = a;
    while (alive) {
      const float step = tau / maj;
      if (!(t + step < b)) {
        tau -= maj * (b - t);
        return true;
      }
      t += step;
      tau = -std::log1p(-rng.uniform());
      PointCoefficients pc;
      add_grid_point(c, n, o + d * t, false, pc);
      float sum = 0;
      for (int k = 0; k < n; ++k) {
        T[k] *= std::max(0.0f, 1.0f - pc.sigma_t[k] / maj);
        sum += T[k];
      }
      if (!(sum > 0) || ++events > kMaxCollisions) {
        alive = false;
        if (events > kMaxCollisions)
          for (int k = 0; k < n; ++k) T[k] = 0.0f;
      }
      at_collision(t, T);
    }
    return false;
  });
  return T;
}
}  // namespace

ChannelValues grid_transmittance(const MediumChannels& c, int n, const Vec3& o, const Vec3& d, float t0, float t1,
                                 uint64_t seed) {
  return ratio_track(c, n, o, d, t0, t1, seed, [](float, const ChannelValues&) {});
}

void TransmittanceSteps::track(const MediumChannels& c, int n, const Vec3& o, const Vec3& d, float t1, uint64_t seed) {
  t_.clear();
  T_.clear();
  n_ = n;
  ratio_track(c, n, o, d, 0.0f, t1, seed, [&](float t, const ChannelValues& T) {
    t_.push_back(t);
    T_.push_back(T);
  });
}

ChannelValues TransmittanceSteps::at(float t) const {
  // The last collision before t (the product over collisions in [0, t)).
  const size_t i = static_cast<size_t>(std::lower_bound(t_.begin(), t_.end(), t) - t_.begin());
  if (i > 0) return T_[i - 1];
  ChannelValues one{};
  for (int k = 0; k < n_; ++k) one[k] = 1.0f;
  return one;
}

// ---- Heterogeneous segments ----

template <class F>
void MediumSegment::walk_majorant(float t_max, F&& f) const {
  float hom = 0;
  bool hom_emits = false;
  for (int k = 0; k < n; ++k) {
    hom = std::max(hom, sigma_t[k]);
    hom_emits = hom_emits || emission[k] > 0;
  }
  // The first grid medium by its blocks; any further one (overlapping grid media) by its
  // global bound: correct, only slower.
  float rest = 0;
  bool rest_emits = false;
  for (int i = 1; i < n_grids; ++i) {
    const GridMedium::Bound& b = grids[i].c->grid->global_bound();
    rest += grid_majorant(*grids[i].c, n, b);
    rest_emits = rest_emits || grid_emits(*grids[i].c, n, b);
  }
  const MediumChannels& c0 = *grids[0].c;
  const Affine& w2i = c0.grid->world_to_index();
  c0.grid->walk(w2i.point(ray.o), w2i.vector(ray.d), 0.0f, t_max, [&](float a, float b, const GridMedium::Bound& bound) {
    return f(a, b, hom + rest + grid_majorant(c0, n, bound), hom_emits || rest_emits || grid_emits(c0, n, bound));
  });
}

void MediumSegment::at_point(const Vec3& p, bool with_emission, PointCoefficients& out, bool set_lobes) const {
  for (int k = 0; k < n; ++k) {
    out.sigma_s[k] = sigma_s[k];
    out.sigma_t[k] = sigma_t[k];
    out.emission[k] = with_emission ? emission[k] : 0.0f;
  }
  if (!set_lobes) {
    for (int i = 0; i < n_grids; ++i) add_grid_point(*grids[i].c, n, p, with_emission, out);
    return;
  }
  // The phase mixture at p: each medium's share of the scattering there.
  for (int l = 0; l < n_lobes; ++l) point_lobes_[l] = lobes[l];
  for (int i = 0; i < n_grids; ++i) {
    PointCoefficients own;
    add_grid_point(*grids[i].c, n, p, with_emission, own);
    for (int k = 0; k < n; ++k) {
      out.sigma_s[k] += own.sigma_s[k];
      out.sigma_t[k] += own.sigma_t[k];
      out.emission[k] += own.emission[k];
    }
    point_lobes_[grids[i].lobe].sigma_s = own.sigma_s;
  }
  float total = 0;
  for (int l = 0; l < n_lobes; ++l) {
    float w = 0;
    for (int k = 0; k < n; ++k) w += point_lobes_[l].sigma_s[k];
    point_lobes_[l].weight = w;
    total += w;
  }
  for (int l = 0; l < n_lobes; ++l) point_lobes_[l].weight = total > 0 ? point_lobes_[l].weight / total : 0.0f;
}

namespace {
inline float exponential(Rng& rng) { return -std::log1p(-rng.uniform()); }
}  // namespace

float MediumSegment::track(uint64_t seed, float t_max, bool scatter, ChannelValues& w) const {
  Rng rng(seed, seed >> 17);
  for (int k = 0; k < n; ++k) w[k] = 1.0f;
  float tau = exponential(rng), found = kInfinity;
  int events = 0;
  walk_majorant(t_max, [&](float a, float b, float maj, bool) {
    if (!(maj > 0)) return true;
    float t = a;
    for (;;) {
      const float step = tau / maj;
      if (!(t + step < b)) {
        tau -= maj * (b - t);
        return true;
      }
      t += step;
      tau = exponential(rng);
      PointCoefficients pc;
      at_point(ray.at(t), false, pc, false);
      // Spectral tracking's probabilities, weighted by the path's channels (q) and this walk's
      // weights so far (w).
      float Ps = 0, Pn = 0;
      for (int k = 0; k < n; ++k) {
        const float a_k = q[k] * w[k];
        Ps += a_k * pc.sigma_s[k];
        Pn += a_k * std::max(maj - pc.sigma_t[k], 0.0f);
      }
      if (!(Ps + Pn > 0) || ++events > kMaxCollisions) {
        for (int k = 0; k < n; ++k) w[k] = 0.0f;  // absorbed
        return false;
      }
      const float ps = scatter ? Ps / (Ps + Pn) : 0.0f;
      if (rng.uniform() < ps) {
        for (int k = 0; k < n; ++k) w[k] *= pc.sigma_s[k] / (maj * ps);
        found = t;
        at_point(ray.at(t), false, pc, true);  // the phase mixture there
        return false;
      }
      for (int k = 0; k < n; ++k) w[k] *= std::max(maj - pc.sigma_t[k], 0.0f) / (maj * (1 - ps));
    }
  });
  return found;
}

ChannelValues MediumSegment::emission_integral(float t) const {
  ChannelValues e{};
  if (heterogeneous()) {
    if (!emits_) return e;
    // Ratio tracking with emission collected at every tentative collision:
    // E = sum_i T_i Le(s_i) / majorant (T_i: the product of the earlier null factors). Where
    // something emits, the majorant is raised to a rate of two collisions per voxel, so that
    // emission without density is sampled too.
    float rate = 0;
    for (int i = 0; i < n_grids; ++i) rate = std::max(rate, 0.5f / grids[i].c->grid->voxel_size());
    Rng rng(ray_seed(ray.o, ray.d, 0xe3155), 0xe3155);
    ChannelValues T{};
    for (int k = 0; k < n; ++k) T[k] = 1.0f;
    float tau = exponential(rng);
    int events = 0;
    walk_majorant(t, [&](float a, float b, float maj, bool emits) {
      const float m = emits ? std::max(maj, rate) : maj;
      if (!(m > 0)) return true;
      float s = a;
      for (;;) {
        const float step = tau / m;
        if (!(s + step < b)) {
          tau -= m * (b - s);
          return true;
        }
        s += step;
        tau = exponential(rng);
        PointCoefficients pc;
        at_point(ray.at(s), true, pc, false);
        float alive = 0;
        for (int k = 0; k < n; ++k) {
          e[k] += T[k] * pc.emission[k] / m;
          T[k] *= std::max(0.0f, 1.0f - pc.sigma_t[k] / m);
          alive += T[k];
        }
        if (!(alive > 0) || ++events > kMaxCollisions) return false;
      }
    });
    return e;
  }
  for (int k = 0; k < n; ++k) {
    if (emission[k] <= 0) continue;
    if (sigma_t[k] > 0) e[k] = emission[k] * -std::expm1(-sigma_t[k] * t) / sigma_t[k];
    else if (std::isfinite(t)) e[k] = emission[k] * t;  // an unbounded emitter without extinction: nothing
  }
  return e;
}

void MediumSegment::set_channel_weights(const ChannelValues& w) {
  float sum = 0;
  for (int k = 0; k < n; ++k) sum += std::max(0.0f, w[k]);
  if (!(sum > 0) || !std::isfinite(sum)) return;  // keeps uniform
  for (int k = 0; k < n; ++k) q[k] = std::max(0.0f, w[k]) / sum;
}

float MediumSegment::sample_distance(float u_channel, float u, float t_max) const {
  if (heterogeneous()) {
    uint32_t a, b;
    std::memcpy(&a, &u_channel, 4);
    std::memcpy(&b, &u, 4);
    seed_ = mix_bits((uint64_t(a) << 32 | b) + 0xD1B54A32D192ED03ULL);
    t_max_ = t_max;
    t_found_ = track(seed_, t_max, scatters, w_found_);
    return t_found_;
  }
  if (!scatters) return kInfinity;
  int c = 0;
  for (float acc = 0; c + 1 < n; ++c) {
    acc += q[c];
    if (u_channel < acc) break;
  }
  if (!(sigma_t[c] > 0)) return kInfinity;
  return -std::log1p(-u) / sigma_t[c];
}

ChannelValues MediumSegment::transmittance(float t) const {
  ChannelValues T{};
  for (int k = 0; k < n; ++k) T[k] = beer_lambert(sigma_t[k], t);
  for (int i = 0; i < n_grids; ++i) {  // (sigma_t above: the homogeneous media's sum only)
    const ChannelValues Tg = grid_transmittance(*grids[i].c, n, ray.o, ray.d, 0.0f, t, ray_seed(ray.o, ray.d, 0x7a11 + i));
    for (int k = 0; k < n; ++k) T[k] *= Tg[k];
  }
  return T;
}

float MediumSegment::distance_pdf(float t) const {
  const ChannelValues T = transmittance(t);
  float pdf = 0;
  for (int k = 0; k < n; ++k) pdf += q[k] * sigma_t[k] * T[k];
  return pdf;
}

ChannelValues MediumSegment::scatter_weight(float t) const {
  if (heterogeneous()) return w_found_;  // the tracking's, at t_found_ == t
  const ChannelValues T = transmittance(t);
  float pdf = 0;  // sum_c q_c sigma_t,c T_c(t): the density of the distance
  for (int k = 0; k < n; ++k) pdf += q[k] * sigma_t[k] * T[k];
  ChannelValues w{};
  if (pdf > 0)
    for (int k = 0; k < n; ++k) w[k] = sigma_s[k] * T[k] / pdf;
  return w;
}

ChannelValues MediumSegment::pass_weight(float t) const {
  if (heterogeneous()) {
    if (t >= t_max_ && t_found_ == kInfinity) return w_found_;
    // Before the end of the walk (a disk light before the scattering point): the same walk,
    // replayed to t (the same random numbers: the same null collisions before t).
    ChannelValues w{};
    track(seed_, t, scatters, w);
    return w;
  }
  ChannelValues T = transmittance(t);
  if (!scatters) return T;
  float p = 0;  // sum_c q_c T_c(t): the probability of no scattering before t
  for (int k = 0; k < n; ++k) p += q[k] * T[k];
  for (int k = 0; k < n; ++k) T[k] = p > 0 ? T[k] / p : 0.0f;
  return T;
}

ChannelValues MediumSegment::phase(float cos_theta) const {
  const Lobe* lobes = heterogeneous() ? point_lobes_.data() : this->lobes.data();
  ChannelValues f{};
  if (n_lobes == 1) {  // (this->lobes: one medium's g holds at any point, tracked or not)
    const float v = henyey_greenstein(cos_theta, this->lobes[0].g);
    for (int k = 0; k < n; ++k) f[k] = v;
    return f;
  }
  ChannelValues s{};
  for (int l = 0; l < n_lobes; ++l) {
    const float v = henyey_greenstein(cos_theta, lobes[l].g);
    for (int k = 0; k < n; ++k) {
      f[k] += lobes[l].sigma_s[k] * v;
      s[k] += lobes[l].sigma_s[k];
    }
  }
  for (int k = 0; k < n; ++k) {
    const float sk = heterogeneous() ? s[k] : sigma_s[k];
    f[k] = sk > 0 ? f[k] / sk : 0.0f;
  }
  return f;
}

float MediumSegment::phase_pdf(float cos_theta) const {
  const Lobe* lobes = heterogeneous() ? point_lobes_.data() : this->lobes.data();
  if (n_lobes == 1) return henyey_greenstein(cos_theta, this->lobes[0].g);
  float p = 0;
  for (int l = 0; l < n_lobes; ++l) p += lobes[l].weight * henyey_greenstein(cos_theta, lobes[l].g);
  return p;
}

Vec3 MediumSegment::sample_phase(const Vec3& d, float u_lobe, Vec2 u) const {
  const Lobe* lobes = heterogeneous() ? point_lobes_.data() : this->lobes.data();
  int l = 0;
  for (float acc = 0; l + 1 < n_lobes; ++l) {
    acc += lobes[l].weight;
    if (u_lobe < acc) break;
  }
  return sample_henyey_greenstein(d, lobes[l].g, u);
}

// ---- Equiangular sampling ----

Equiangular::Equiangular(const Vec3& o, const Vec3& d, const Vec3& c, float t_max_) : t_max(t_max_) {
  // In double: theta near pi/2 on an unbounded ray, and D small against |c - o|.
  const double ox = c.x - o.x, oy = c.y - o.y, oz = c.z - o.z;
  delta = ox * d.x + oy * d.y + oz * d.z;
  const double px = ox - delta * d.x, py = oy - delta * d.y, pz = oz - delta * d.z;
  D = std::sqrt(px * px + py * py + pz * pz);
  const double dist = std::sqrt(ox * ox + oy * oy + oz * oz);
  if (!(D > 1e-6 * dist) || !(t_max > 0) || !std::isfinite(D)) return;
  theta_a = std::atan2(-delta, D);
  theta_b = std::isinf(t_max) ? 0.5 * 3.14159265358979323846 : std::atan2(double(t_max) - delta, D);
  valid = theta_b > theta_a;
}

float Equiangular::sample(float u) const {
  const double theta = theta_a + double(u) * (theta_b - theta_a);
  double t = delta + D * std::tan(theta);
  // Round-off at the ends: kept inside [0, t_max).
  t = std::max(t, 0.0);
  if (!(t < double(t_max))) t = std::nextafter(t_max, 0.0f);
  return std::min(float(t), std::nextafter(t_max, 0.0f));
}

float Equiangular::pdf(float t) const {
  if (!valid || !(t >= 0) || !(t < t_max)) return 0.0f;
  const double x = double(t) - delta;
  return float(D / ((theta_b - theta_a) * (D * D + x * x)));
}

}  // namespace gp
