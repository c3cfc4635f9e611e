#include "media/medium.h"

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
  return c;
}

MediumSpectra::MediumSpectra(const Medium& m)
    : sigma_a(RgbSpectrum::illuminant(m.sigma_a)),
      sigma_s(RgbSpectrum::illuminant(m.sigma_s)),
      emission(RgbSpectrum::illuminant(m.emission)),
      g(m.g) {}

MediumChannels MediumSpectra::at(const SampledWavelengths& wl) const {
  MediumChannels c;
  for (int k = 0; k < wl.count; ++k) {
    c.sigma_a[k] = std::max(0.0f, sigma_a(wl.lambda[k]));
    c.sigma_s[k] = std::max(0.0f, sigma_s(wl.lambda[k]));
    c.sigma_t[k] = c.sigma_a[k] + c.sigma_s[k];
    c.emission[k] = std::max(0.0f, emission(wl.lambda[k]));
  }
  c.g = g;
  return c;
}

ChannelValues MediumSegment::emission_integral(float t) const {
  ChannelValues e{};
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

float MediumSegment::sample_distance(float u_channel, float u) const {
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
  return T;
}

ChannelValues MediumSegment::scatter_weight(float t) const {
  const ChannelValues T = transmittance(t);
  float pdf = 0;  // sum_c q_c sigma_t,c T_c(t): the density of the distance
  for (int k = 0; k < n; ++k) pdf += q[k] * sigma_t[k] * T[k];
  ChannelValues w{};
  if (pdf > 0)
    for (int k = 0; k < n; ++k) w[k] = sigma_s[k] * T[k] / pdf;
  return w;
}

ChannelValues MediumSegment::pass_weight(float t) const {
  ChannelValues T = transmittance(t);
  if (!scatters) return T;
  float p = 0;  // sum_c q_c T_c(t): the probability of no scattering before t
  for (int k = 0; k < n; ++k) p += q[k] * T[k];
  for (int k = 0; k < n; ++k) T[k] = p > 0 ? T[k] / p : 0.0f;
  return T;
}

ChannelValues MediumSegment::phase(float cos_theta) const {
  ChannelValues f{};
  if (n_lobes == 1) {
    const float v = henyey_greenstein(cos_theta, lobes[0].g);
    for (int k = 0; k < n; ++k) f[k] = v;
    return f;
  }
  for (int l = 0; l < n_lobes; ++l) {
    const float v = henyey_greenstein(cos_theta, lobes[l].g);
    for (int k = 0; k < n; ++k) f[k] += lobes[l].sigma_s[k] * v;
  }
  for (int k = 0; k < n; ++k) f[k] = sigma_s[k] > 0 ? f[k] / sigma_s[k] : 0.0f;
  return f;
}

float MediumSegment::phase_pdf(float cos_theta) const {
  if (n_lobes == 1) return henyey_greenstein(cos_theta, lobes[0].g);
  float p = 0;
  for (int l = 0; l < n_lobes; ++l) p += lobes[l].weight * henyey_greenstein(cos_theta, lobes[l].g);
  return p;
}

Vec3 MediumSegment::sample_phase(const Vec3& d, float u_lobe, Vec2 u) const {
  int l = 0;
  for (float acc = 0; l + 1 < n_lobes; ++l) {
    acc += lobes[l].weight;
    if (u_lobe < acc) break;
  }
  return sample_henyey_greenstein(d, lobes[l].g, u);
}

}  // namespace gp
