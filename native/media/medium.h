// Participating media (issue 32, first landing): homogeneous media with absorption, scattering
// and emission coefficients per RGB channel, the Henyey-Greenstein phase function, and the stack
// of media a path is inside (Cycles' volume stack, kernel/integrator/volume_stack.h).
//
// Units and conventions follow Cycles 3.4's volume closures (kernel/closure/volume.h,
// kernel/svm/closure.h): sigma_a and sigma_s in m^-1; emission is the radiance emitted per metre
// of path (W sr^-1 m^-3), added as is (Cycles does not multiply it by absorption); the phase
// function's anisotropy g is clamped to |g| <= 1 - 1e-3 as Cycles' volume_henyey_greenstein_setup.
//
// Heterogeneous media (OpenVDB grids, the next landing) scale these coefficients by a density
// looked up at a point and bounded by a majorant over a segment: density() and
// majorant_density() are that interface, 1 everywhere for the homogeneous media of today.
#pragma once

#include <array>
#include <cmath>
#include <string>

#include "core/color.h"
#include "core/frame.h"
#include "core/math.h"
#include "core/spectrum.h"

namespace gp {

inline constexpr float kMaxAnisotropy = 1.0f - 1e-3f;  // Cycles: volume_henyey_greenstein_setup

struct Medium {
  std::string name;
  RGB sigma_a{0.0f}, sigma_s{0.0f};  // m^-1
  float g = 0.0f;                    // Henyey-Greenstein anisotropy, |g| <= kMaxAnisotropy
  RGB emission{0.0f};                // W sr^-1 m^-3

  RGB sigma_t() const { return sigma_a + sigma_s; }
  // The density the coefficients are scaled by at p, and its bound over the medium: the
  // interface a density grid fills (next landing). Homogeneous: 1.
  float density(const Vec3&) const { return 1.0f; }
  float majorant_density() const { return 1.0f; }
  bool is_homogeneous() const { return true; }
};

// ---- Henyey-Greenstein phase function ----
// cos_theta is the cosine between the direction the light travelled (the ray's d) and the
// direction it scatters to: g > 0 scatters forward (cos_theta near 1).
inline float henyey_greenstein(float cos_theta, float g) {
  const float denom = 1.0f + g * g - 2.0f * g * cos_theta;
  return kInv4Pi * (1.0f - g * g) / (denom * std::sqrt(std::max(denom, 1e-12f)));
}
// A direction drawn from the phase function exactly (its pdf is henyey_greenstein(cos, g)), by
// inverting its cdf in cos_theta (Henyey & Greenstein 1941; pbrt-v4 SampleHenyeyGreenstein).
inline Vec3 sample_henyey_greenstein(const Vec3& d, float g, Vec2 u) {
  float cos_theta;
  if (std::abs(g) < 1e-3f) {
    cos_theta = 1.0f - 2.0f * u.x;
  } else {
    const float sq = (1.0f - g * g) / (1.0f + g - 2.0f * g * u.x);
    cos_theta = (1.0f + g * g - sq * sq) / (2.0f * g);
  }
  cos_theta = std::clamp(cos_theta, -1.0f, 1.0f);
  const float sin_theta = std::sqrt(std::max(0.0f, 1.0f - cos_theta * cos_theta));
  const float phi = 2.0f * kPi * u.y;
  return Frame(d).to_world(Vec3(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta));
}

// ---- The media a path is in ----
// Cycles' rule (volume_stack.h): a ray that crosses a surface whose material has an interior
// medium enters it through the front face (against the geometric normal) and leaves it through
// the back; the World's medium is always at the bottom; the media of every entry are summed
// where they overlap (a glass of murky water in fog sees fog + water inside). An entry is a
// (mesh, medium) pair, so two objects of one medium nest correctly. Full: further entries are
// ignored, as Cycles ignores them past its stack size.
class MediumStack {
 public:
  static constexpr int kCapacity = 16;
  struct Entry {
    int mesh = -1;  // -1: the World
    int medium = -1;
  };

  MediumStack() = default;
  explicit MediumStack(int world_medium) {
    if (world_medium >= 0) entries_[n_++] = {-1, world_medium};
  }
  bool empty() const { return n_ == 0; }
  int size() const { return n_; }
  const Entry& operator[](int i) const { return entries_[i]; }
  // A crossing of a boundary of `mesh` whose interior is `medium`: entering when `front`.
  void cross(int mesh, int medium, bool front) {
    for (int i = 0; i < n_; ++i)
      if (entries_[i].mesh == mesh && entries_[i].medium == medium) {
        if (front) return;  // already inside
        for (int j = i; j + 1 < n_; ++j) entries_[j] = entries_[j + 1];
        --n_;
        return;
      }
    if (front && n_ < kCapacity) entries_[n_++] = {mesh, medium};
  }

 private:
  std::array<Entry, kCapacity> entries_{};
  int n_ = 0;
};

// How far a shadow ray travelled in each medium (summed over the segments where it was inside
// it): what the path types turn into a transmittance per channel (exp(-sum sigma_t d), exact
// Beer-Lambert for homogeneous media).
struct MediumLengths {
  static constexpr int kCapacity = 16;
  std::array<int, kCapacity> medium{};
  std::array<float, kCapacity> length{};
  int n = 0;
  void add(int m, float d) {
    for (int i = 0; i < n; ++i)
      if (medium[i] == m) {
        length[i] += d;
        return;
      }
    if (n < kCapacity) {
      medium[n] = m;
      length[n++] = d;
    }
  }
};

// Per-channel values of a path: the RGB path's 3 channels or the spectral path's wavelengths.
inline constexpr int kMaxMediumChannels = kMaxWavelengths > 3 ? kMaxWavelengths : 3;
using ChannelValues = std::array<float, kMaxMediumChannels>;

// One medium's coefficients at a path's channels (RGB, or upsampled at its wavelengths).
struct MediumChannels {
  ChannelValues sigma_a{}, sigma_s{}, sigma_t{}, emission{};
  float g = 0.0f;
};
// Medium `m` at the three RGB channels.
MediumChannels rgb_channels(const Medium& m);

// The spectra of a medium's coefficients for spectral paths: unbounded RGB upsampling
// (RgbSpectrum::illuminant: scale * reflectance(rgb / scale)), as emission is upsampled.
struct MediumSpectra {
  RgbSpectrum sigma_a, sigma_s, emission;
  float g = 0.0f;
  explicit MediumSpectra(const Medium& m);
  MediumChannels at(const SampledWavelengths& wl) const;
};

// ---- A homogeneous segment: the media of a stack summed, along one ray ----
// Free-flight distances are sampled by picking a channel c with probability q_c proportional
// to the path's throughput in it (Cycles' volume_sample_channel weighs by throughput too) and
// sampling its exponential; the density of the distance is then sum_c q_c sigma_t,c T_c (the
// one-sample balance heuristic over channels, "spectral MIS", as pbrt-v4's volpath weighs
// wavelengths), so every channel stays unbiased and the throughput's sum cannot grow by
// scattering. Without scattering anywhere on the segment nothing is sampled: the throughput
// takes the transmittance itself (Beer-Lambert, exact).
struct MediumSegment {
  int n = 0;  // channels
  bool scatters = false;  // some channel has sigma_s > 0
  ChannelValues q{};      // channel selection probabilities (set_channel_weights)
  ChannelValues sigma_s{}, sigma_t{}, emission{};
  // The phase functions of the stack's media with their channel scattering: for the mixture.
  struct Lobe {
    float g = 0.0f;
    ChannelValues sigma_s{};
    float weight = 0.0f;  // sampling probability: its share of the mean scattering
  };
  std::array<Lobe, MediumStack::kCapacity> lobes{};
  int n_lobes = 0;

  // The stack's media at the channels `channels(m)` gives (a MediumChannels per medium).
  template <class F>
  MediumSegment(const MediumStack& stack, int channels, F&& channels_of) : n(channels) {
    float total = 0;
    for (int i = 0; i < stack.size(); ++i) {
      const MediumChannels& c = channels_of(stack[i].medium);
      Lobe& lobe = lobes[n_lobes++];
      lobe.g = c.g;
      for (int k = 0; k < n; ++k) {
        sigma_s[k] += c.sigma_s[k];
        sigma_t[k] += c.sigma_t[k];
        emission[k] += c.emission[k];
        lobe.sigma_s[k] = c.sigma_s[k];
        lobe.weight += c.sigma_s[k];
      }
      total += lobe.weight;
    }
    for (int l = 0; l < n_lobes; ++l) lobes[l].weight = total > 0 ? lobes[l].weight / total : 0.0f;
    scatters = total > 0;
    for (int k = 0; k < n; ++k) q[k] = 1.0f / n;
  }

  // Channel selection in proportion to w (the path's throughput; uniform where it is all 0).
  void set_channel_weights(const ChannelValues& w);
  // The emission reaching the ray's origin from [0, t): integral of exp(-sigma_t s) Le ds,
  // exactly; 0 for an unbounded segment without extinction (no NaN/Inf reaches the film).
  ChannelValues emission_integral(float t) const;
  // Samples a free-flight distance (u_channel picks the channel); returns it, or infinity
  // (always without scattering).
  float sample_distance(float u_channel, float u) const;
  // The throughput factor of scattering at distance t: sigma_s T(t) / pdf(t) per channel.
  ChannelValues scatter_weight(float t) const;
  // The factor of passing beyond distance t (no scattering before it): T(t) / P(t_s > t);
  // T(t) itself when nothing scatters.
  ChannelValues pass_weight(float t) const;
  // Transmittance per channel over distance t.
  ChannelValues transmittance(float t) const;

  // ---- The phase function of the mixture: sum_m sigma_s,m HG_m / sigma_s, per channel ----
  // Per channel value at the cosine between the travel direction d and wi.
  ChannelValues phase(float cos_theta) const;
  // The density of sample_phase: sum_m weight_m HG_m.
  float phase_pdf(float cos_theta) const;
  Vec3 sample_phase(const Vec3& d, float u_lobe, Vec2 u) const;
};

}  // namespace gp
