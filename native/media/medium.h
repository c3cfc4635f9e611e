// Participating media (issue 32, first landing): homogeneous media with absorption, scattering
// and emission coefficients per RGB channel, the Henyey-Greenstein phase function, and the stack
// of media a path is inside (Cycles' volume stack, kernel/integrator/volume_stack.h).
//
// Units and conventions follow Cycles 3.4's volume closures (kernel/closure/volume.h,
// kernel/svm/closure.h): sigma_a and sigma_s in m^-1; emission is the radiance emitted per metre
// of path (W sr^-1 m^-3), added as is (Cycles does not multiply it by absorption); the phase
// function's anisotropy g is clamped to |g| <= 1 - 1e-3 as Cycles' volume_henyey_greenstein_setup.
//
// Heterogeneous media (a Medium with a grid: media/grid.h, Principled Volume over OpenVDB grids)
// vary per point. A MediumSegment over a stack that holds one is followed by delta tracking
// against the majorant grid (free flights) and a shadow ray through one by ratio tracking
// (transmittance): the same interface as for homogeneous media, which keep their exact
// closed forms (bit for bit as before).
#pragma once

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/frame.h"
#include "core/math.h"
#include "core/spectrum.h"
#include "media/grid.h"

namespace gp {

inline constexpr float kMaxAnisotropy = 1.0f - 1e-3f;  // Cycles: volume_henyey_greenstein_setup

struct Medium {
  std::string name;
  RGB sigma_a{0.0f}, sigma_s{0.0f};  // m^-1
  float g = 0.0f;                    // Henyey-Greenstein anisotropy, |g| <= kMaxAnisotropy
  RGB emission{0.0f};                // W sr^-1 m^-3

  // A heterogeneous medium: Principled Volume over grids. Without a colour grid its
  // coefficients at a point are sigma_a, sigma_s above times the density grid there; emission
  // adds the grid's blackbody emission to the constant one (media/grid.h).
  std::shared_ptr<const GridMedium> grid;

  RGB sigma_t() const { return sigma_a + sigma_s; }
  bool is_homogeneous() const { return !grid; }
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

// ---- Equiangular sampling (Kulla & Fajardo 2012, "Importance sampling techniques for path
// tracing in participating media", §3) ----
// Distances t in [0, t_max) along a ray o + t d (unit d) with density proportional to the
// inverse square distance to a point c (a light): with delta = (c - o) . d the foot of c's
// perpendicular on the ray and D its length, t = delta + D tan(theta), theta uniform between
// the angles theta_a, theta_b under which c sees the ray's ends, so that
// pdf(t) = D / ((theta_b - theta_a) (D^2 + (t - delta)^2)) (their eqs. 6-8; Cycles 3.4:
// kernel/integrator/shade_volume.h volume_equiangular_sample/pdf). t_max may be infinite
// (theta_b = pi/2). A centre on the ray's line (D = 0) is not valid: pdf 0 everywhere.
struct Equiangular {
  double delta = 0, D = 0, theta_a = 0, theta_b = 0;
  float t_max = 0;
  bool valid = false;
  Equiangular() = default;
  Equiangular(const Vec3& o, const Vec3& d, const Vec3& c, float t_max);
  float sample(float u) const;  // in [0, t_max)
  float pdf(float t) const;
};

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
// Beer-Lambert for homogeneous media). A grid medium's stretches are kept as pieces of ray
// instead, for ratio tracking (paths/medium_walk.h, transmittance()).
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
  struct Piece {
    int medium = -1;
    Vec3 o, d;
    float t = 0;  // [0, t) along o + s d
  };
  static constexpr int kPieces = 32;
  std::array<Piece, kPieces> pieces{};
  int n_pieces = 0;
  bool overflow = false;  // more grid stretches than kPieces: the shadow test calls it blocked
  // Nothing crossed: the transmittance is 1 (test this, not n: grid stretches are pieces).
  bool empty() const { return n == 0 && n_pieces == 0; }
  void add_piece(int m, const Vec3& o, const Vec3& d, float t) {
    if (n_pieces < kPieces) pieces[n_pieces++] = {m, o, d, t};
    else overflow = true;
  }
};

// Per-channel values of a path: the RGB path's 3 channels or the spectral path's wavelengths.
inline constexpr int kMaxMediumChannels = kMaxWavelengths > 3 ? kMaxWavelengths : 3;
using ChannelValues = std::array<float, kMaxMediumChannels>;

// One medium's coefficients at a path's channels (RGB, or upsampled at its wavelengths).
struct MediumChannels {
  ChannelValues sigma_a{}, sigma_s{}, sigma_t{}, emission{};
  float g = 0.0f;
  // Heterogeneous: the grid (sigma_* above are then those at density 1), and the path's channels
  // of the three RGB primaries (identity in RGB; upsampled at the wavelengths), which turn a
  // point's RGB coefficients (colour grid, blackbody) into the path's channels.
  const GridMedium* grid = nullptr;
  std::array<ChannelValues, 3> rgb_basis{};
};

// ---- A grid medium at a point, at a path's channels ----
struct PointCoefficients {
  ChannelValues sigma_s{}, sigma_t{}, emission{};
};
// Medium `c` (c.grid set) at world point p: adds its coefficients to `out` (emission only when
// `emission`).
void add_grid_point(const MediumChannels& c, int n, const Vec3& p, bool emission, PointCoefficients& out);
// A bound of max_k sigma_t,k of `c` over a majorant block.
float grid_majorant(const MediumChannels& c, int n, const GridMedium::Bound& b);
// Whether `c` may emit in a block (constant emission, or blackbody with T > 0 there).
bool grid_emits(const MediumChannels& c, int n, const GridMedium::Bound& b);
// Ratio tracking (Novak et al. 2014) of the transmittance of grid medium `c` along o + t d over
// [t0, t1), per channel; its random numbers are drawn from `seed` (a hash of the ray: the
// shadow test has no random numbers of its own).
ChannelValues grid_transmittance(const MediumChannels& c, int n, const Vec3& o, const Vec3& d, float t0, float t1,
                                 uint64_t seed);
// Ratio tracking's transmittance along one ray as a step function of the distance: the running
// product of one walk (grid_transmittance's) is, at every distance s, an unbiased estimate of
// T(0, s), so the transmittance to many points along one ray (the beam radiance estimate's
// photons) costs one walk. The scratch is kept between tracks (capacity).
class TransmittanceSteps {
 public:
  // Grid medium `c` (c.grid set) along o + t d over [0, t1).
  void track(const MediumChannels& c, int n, const Vec3& o, const Vec3& d, float t1, uint64_t seed);
  // The estimate of T(0, t), t <= t1.
  ChannelValues at(float t) const;

 private:
  std::vector<float> t_;  // the tentative collisions, increasing
  std::vector<ChannelValues> T_;  // the product after each
  int n_ = 0;
};
// A seed from a ray's bits (and a salt).
uint64_t ray_seed(const Vec3& o, const Vec3& d, uint64_t salt);
// Medium `m` at the three RGB channels.
MediumChannels rgb_channels(const Medium& m);

// The spectra of a medium's coefficients for spectral paths: unbounded RGB upsampling
// (RgbSpectrum::illuminant: scale * reflectance(rgb / scale)), as emission is upsampled.
struct MediumSpectra {
  RgbSpectrum sigma_a, sigma_s, emission;
  float g = 0.0f;
  const GridMedium* grid = nullptr;
  std::array<RgbSpectrum, 3> primaries;  // of a grid medium: for rgb_basis
  explicit MediumSpectra(const Medium& m);
  MediumChannels at(const SampledWavelengths& wl) const;
};

// ---- A segment: the media of a stack summed, along one ray ----
// Homogeneous media: free-flight distances are sampled by picking a channel c with probability
// q_c proportional to the path's throughput in it (Cycles' volume_sample_channel weighs by
// throughput too) and sampling its exponential; the density of the distance is then
// sum_c q_c sigma_t,c T_c (the one-sample balance heuristic over channels, "spectral MIS", as
// pbrt-v4's volpath weighs wavelengths), so every channel stays unbiased and the throughput's sum
// cannot grow by scattering. Without scattering anywhere on the segment nothing is sampled: the
// throughput takes the transmittance itself (Beer-Lambert, exact).
//
// With a grid medium in the stack the segment is heterogeneous: sample_distance runs delta
// tracking (Woodcock; Novak et al. 2018 §3, "spectral tracking" of Kutz et al. 2017 for the
// channels) under one majorant per block, the max over the channels ("hero-style": one
// distance for all channels, the channels weighted): at each tentative collision at s, with
// a_c = q_c W_c (W the weight so far), it scatters with probability
// P_s = sum a_c sigma_s,c / sum a_c (sigma_s,c + sigma_n,c), sigma_n = majorant - sigma_t, and
// otherwise goes on (a null collision); the channels take sigma_s,c / (majorant P_s), or
// sigma_n,c / (majorant (1 - P_s)). Absorption is a weight, not an event. Without scattering it
// is ratio tracking. Its random numbers come from a stream seeded by the two uniforms given;
// pass_weight before the end replays the same stream. Emission is estimated along the segment
// by ratio tracking (emission_integral).
struct MediumSegment {
  int n = 0;  // channels
  bool scatters = false;  // some channel has sigma_s > 0
  ChannelValues q{};      // channel selection probabilities (set_channel_weights)
  ChannelValues sigma_s{}, sigma_t{}, emission{};  // homogeneous media's sums
  // The phase functions of the stack's media with their channel scattering: for the mixture.
  struct Lobe {
    float g = 0.0f;
    ChannelValues sigma_s{};
    float weight = 0.0f;  // sampling probability: its share of the mean scattering
  };
  std::array<Lobe, MediumStack::kCapacity> lobes{};
  int n_lobes = 0;
  // Heterogeneous: the stack's grid media (their channels and lobe) and the ray.
  struct GridPart {
    const MediumChannels* c = nullptr;
    int lobe = 0;
  };
  std::array<GridPart, MediumStack::kCapacity> grids{};
  int n_grids = 0;
  Ray ray;

  // The stack's media along `ray` at the channels `channels_of(m)` gives (a MediumChannels per
  // medium; references that live as long as the segment).
  template <class F>
  MediumSegment(const MediumStack& stack, const Ray& r, int channels, F&& channels_of) : n(channels), ray(r) {
    float total = 0;
    bool emits = false;
    for (int i = 0; i < stack.size(); ++i) {
      const MediumChannels& c = channels_of(stack[i].medium);
      Lobe& lobe = lobes[n_lobes++];
      lobe.g = c.g;
      if (c.grid) {
        grids[n_grids++] = {&c, n_lobes - 1};
        for (int k = 0; k < n; ++k) emits = emits || c.emission[k] > 0;
        emits = emits || c.grid->emits_blackbody();
        // Its scattering somewhere: at density 1 (a colour grid's bound: params' colour).
        const float s = c.grid->has_color_grid() ? c.grid->params().color.luminance() : c.sigma_s[0] + c.sigma_s[n - 1];
        scatters = scatters || s > 0;
        continue;
      }
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
    scatters = scatters || total > 0;
    for (int k = 0; k < n; ++k) emits_ = emits_ || emission[k] > 0;
    emits_ = emits_ || emits;
    for (int k = 0; k < n; ++k) q[k] = 1.0f / n;
  }

  bool heterogeneous() const { return n_grids > 0; }
  // Channel selection in proportion to w (the path's throughput; uniform where it is all 0).
  void set_channel_weights(const ChannelValues& w);
  // The emission reaching the ray's origin from [0, t): integral of T(s) Le(s) ds, exactly
  // (homogeneous; 0 for an unbounded segment without extinction: no NaN/Inf reaches the film)
  // or by ratio tracking (heterogeneous).
  ChannelValues emission_integral(float t) const;
  // Samples a free-flight distance (u_channel picks the channel; heterogeneous: the two seed
  // the tracking, which stops at t_max); returns it, or infinity (always without scattering).
  float sample_distance(float u_channel, float u, float t_max = kInfinity) const;
  // The throughput factor of scattering at distance t: sigma_s T(t) / pdf(t) per channel
  // (heterogeneous: the tracking's weight at the distance it returned).
  ChannelValues scatter_weight(float t) const;
  // The factor of passing beyond distance t (no scattering before it): T(t) / P(t_s > t);
  // T(t) itself when nothing scatters (heterogeneous: the tracking's weight at t).
  ChannelValues pass_weight(float t) const;
  // Transmittance per channel over distance t: exact for homogeneous media; times, for each grid
  // medium, a ratio-tracking estimate (unbiased) seeded by the ray (grid_transmittance).
  ChannelValues transmittance(float t) const;
  // The phase mixture (phase, phase_pdf, sample_phase) at world point p of a heterogeneous
  // segment: each medium's share of the scattering there (the beam gather's photons).
  void set_point(const Vec3& p) const {
    PointCoefficients pc;
    if (heterogeneous()) at_point(p, false, pc, true);
  }
  // The density of sample_distance's distance at t (homogeneous, scattering media):
  // sum_c q_c sigma_t,c T_c(t), the other strategy of equiangular sampling's MIS.
  float distance_pdf(float t) const;

  // ---- The phase function of the mixture: sum_m sigma_s,m HG_m / sigma_s, per channel ----
  // (Heterogeneous: the media's scattering at the last scattering point sample_distance found.)
  // Per channel value at the cosine between the travel direction d and wi.
  ChannelValues phase(float cos_theta) const;
  // The density of sample_phase: sum_m weight_m HG_m.
  float phase_pdf(float cos_theta) const;
  Vec3 sample_phase(const Vec3& d, float u_lobe, Vec2 u) const;

 private:
  // Delta tracking over [0, t_max) from `seed`; returns the scattering distance (infinity: none
  // before t_max, or absorbed), w the weight there. scatter: whether scattering may end it.
  float track(uint64_t seed, float t_max, bool scatter, ChannelValues& w) const;
  // The coefficients at world point p (every medium of the stack); lobes' scattering there when
  // `lobes_out`.
  void at_point(const Vec3& p, bool with_emission, PointCoefficients& out, bool set_lobes) const;
  // Walks the piecewise-constant majorant along the ray over [0, t_max): f(t0, t1, majorant, emits).
  template <class F>
  void walk_majorant(float t_max, F&& f) const;

  bool emits_ = false;
  // The last tracking (heterogeneous).
  mutable uint64_t seed_ = 0;
  mutable float t_max_ = 0, t_found_ = kInfinity;
  mutable ChannelValues w_found_{};
  mutable std::array<Lobe, MediumStack::kCapacity> point_lobes_{};
};

}  // namespace gp
