// What the camera-path loop (camera_path.h) needs of participating media besides the media
// themselves (media/medium.h): shadow rays that cross medium boundaries and report how far they
// went in each medium, and per-channel transmittance from those lengths.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "media/medium.h"
#include "scene/scene.h"

namespace gp {

// What a shadow ray's transmittance is counted in: RGB, or a path's wavelengths (each
// surface's colour upsampled per hit, as textured inputs are), with the scene's media at them.
struct ShadowChannels {
  int count = 3;
  const float* lambda = nullptr;          // the wavelengths (nm), count of them; null: RGB
  const MediumChannels* media = nullptr;  // Scene::media at these channels (scenes with media)
  RayState state;                         // the path's ray at the vertex (its transparent bounces)
};

// Whether a ray of Light Path state `state` ends at the next surface it meets, after that
// surface's emission: its transparent bounces passed Light Paths > Transparent
// (Scene::transparent_bounces; Cycles' PATH_RAY_TERMINATE_ON_NEXT_SURFACE, path_state.h
// path_state_next). Measured in Blender 3.4's Cycles (issue 30): ten clear panes before an
// emitter show it with Transparent 9 and hide it with 8, so the ray that made the
// (transparent_bounces + 1)-th pass still sees the next surface's emission; and with
// Transparent 1 a floor seen through one pane is shaded as usual (its shadow rays then cross
// none, ShadowTest). Every camera-path walk shares it (the camera-path loop, the photon methods'
// eye walk, gpt's, sgpt's and msppm's); a transparent bounce is not a bounce for their depth
// (RayState::next).
inline bool transparent_done(int transparent_bounces, const RayState& state) {
  return state.transparent > 0 && state.transparent > transparent_bounces;
}

// The mean of a path's n channel values (RGB, or its wavelengths), n > 0.
inline float channel_mean(const ChannelValues& w, int n) {
  float sum = 0;
  for (int k = 0; k < n; ++k) sum += w[k];
  return sum / n;
}

// Film > Transparent in the spectral methods: the RGB weight of a camera path's passes through
// Transparent BSDF closures, carried beside its spectral throughput for its transparency only
// (path_transparency). Cycles averages the RGB throughput of a path that escaped after transparent
// bounces only (a red pane: 1/3, alpha 2/3); the mean of a wavelength bundle's throughput
// estimates the mean of the pane's upsampled spectrum instead (a red pane's alpha read 0.43 in
// spt and spt-hero, 0.28 in spectral sppm: FilmTransparent's test). So a pass multiplies in the closure's RGB colour, before
// upsampling, over the hero's pick probability (the RGB BSDF sampled with the hero's numbers:
// closure picks depend on mix factors, not on colours, so it takes the same closure); the
// colour itself keeps its spectral throughput. Media and Russian roulette scale it by their
// factor's mean over the path's wavelengths (exact for grey media; a coloured medium's
// transparency stays its spectral mean, as before). The camera-path loop's spectral path
// (spectral/spectral_pt.cpp) and the photon methods' spectral eye walk hold one each.
class RgbTransparency {
 public:
  // A BSDF sample drawn at the path's vertex: a transparent pass (materials/bsdf.h's
  // is_transparent_pass) multiplies in the hit's RGB BSDF `rgb`'s weight for the same numbers;
  // any other sample ends the transparent walk (the path no longer counts towards the
  // transparency).
  void scatter(const Bsdf* rgb, const Vec3& wo, float uc, Vec2 u, const BsdfSample& bs) {
    if (!walking_) return;
    if (!is_transparent_pass(bs)) {
      walking_ = false;
      return;
    }
    const std::optional<BsdfSample> s = rgb ? rgb->sample(wo, uc, u) : std::nullopt;
    weight_ *= s && is_transparent_pass(*s) && s->pdf > 0 ? s->f * (std::abs(s->wi.z) / s->pdf) : RGB(0.0f);
  }
  // A transparent pass weighed by RGB factor w (the photon methods' eye walk's pass through a
  // photon-diffuse surface's Transparent BSDF: its RGB weight over the pass's probability).
  void pass(const RGB& w) {
    if (walking_) weight_ *= w;
  }
  // A factor per channel of the path (media's transmittance): its mean over them.
  void scale(const ChannelValues& w, int n) {
    if (walking_ && n > 0) weight_ *= channel_mean(w, n);
  }
  void scale(float f) { weight_ *= f; }
  // The path left the camera's walk (a medium scattered it).
  void end() { walking_ = false; }
  bool walking() const { return walking_; }
  float average() const { return weight_.average(); }

 private:
  RGB weight_{1.0f};
  bool walking_ = true;  // only transparent passes so far
};

// Cycles' transparency of a camera path that escaped to a transparent background after
// transparent bounces only: the average of its throughput (integrate_background adds
// average(throughput) to the transparent pass; alpha = 1 - it), in [0, 1], over RGB: an RGB
// path's channels, or a spectral path's RgbTransparency (rgb_transparency()). The camera-path
// loop and the photon methods' eye walk share it.
template <class P>
float path_transparency(const P& path) {
  float t;
  if constexpr (requires { path.rgb_transparency(); }) {
    t = path.rgb_transparency().average();
  } else {
    const int n = path.channels();
    t = n > 0 ? channel_mean(path.channel_weights(), n) : 1.0f;
  }
  return std::isfinite(t) ? std::clamp(t, 0.0f, 1.0f) : 1.0f;
}

// The shadow test of next-event estimation: the per-channel transmittance from a vertex to a
// light sample, 0 where something blocks it. Without media (stack null) and without transparent
// surfaces it is Scene::occluded, unchanged (all ones or all zeros). With media it follows the
// ray through surfaces that cast no shadow (light objects, volume boundaries), tracking the
// media it is in from the path's stack, and multiplies in their transmittance. Surfaces with a
// Transparent BSDF (Material::transparent_shadow) let it through filtered by the closure's
// weight at the hit (Cycles' transparent shadows: kernel/integrator/intersect_shadow.h,
// shade_shadow.h, shader_bsdf_transparency), at most max(transparent_bounces - the path's
// transparent bounces - 1, 0) of them (integrate_shadow_max_transparent_hits); any other
// surface, or one transparent surface too many, blocks it.
class ShadowTest {
 public:
  ShadowTest(const Scene& scene, const MediumStack* stack) : scene_(scene), stack_(stack) {}

  // The surface vertex the next shadow ray leaves from, when its material has an interior
  // medium: a shadow ray into the other side crosses that boundary first (rough glass of murky
  // water). ray_d: the direction the path arrived along.
  void at_surface(int mesh, int interior, const Vec3& ng, const Vec3& ray_d) {
    mesh_ = mesh;
    interior_ = interior;
    ng_ = ng;
    ray_d_ = ray_d;
  }
  void in_medium() { interior_ = -1; }

  // The transmittance in ch's channels (entries past ch.count are 0). p: the vertex, ng: its
  // geometric normal (null for a point in a medium: no offset).
  ChannelValues transmittance(const Vec3& p, const Vec3* ng, const LightSample& ls, const ShadowChannels& ch) const;
  // Whether the shadow test tracks media (the scene has some).
  bool tracks_media() const { return stack_ != nullptr; }

 private:
  // Multiplies T by the transparency of the surface at `hit`; false when that leaves nothing.
  bool filter(const SurfaceHit& hit, const ShadowChannels& ch, ChannelValues& T) const;

  const Scene& scene_;
  const MediumStack* stack_;
  int mesh_ = -1, interior_ = -1;
  Vec3 ng_, ray_d_;
};

// Whether a transmittance from ShadowTest leaves nothing in its first `count` channels.
inline bool is_blocked(const ChannelValues& T, int count) {
  for (int k = 0; k < count; ++k)
    if (T[k] > 0) return false;
  return true;
}

// exp(-sum_m sigma_t,m(c) d_m) per channel: exact Beer-Lambert through homogeneous segments;
// times, for each stretch through a grid medium, its ratio-tracking estimate (unbiased; its
// random numbers seeded by the stretch's ray, media/medium.h grid_transmittance).
template <class F>
ChannelValues transmittance(const MediumLengths& lengths, int channels, F&& channels_of) {
  ChannelValues tau{};
  for (int i = 0; i < lengths.n; ++i) {
    const MediumChannels& c = channels_of(lengths.medium[i]);
    for (int k = 0; k < channels; ++k)
      if (c.sigma_t[k] > 0) tau[k] += c.sigma_t[k] * lengths.length[i];  // sigma 0: nothing, even over infinity
  }
  ChannelValues T{};
  for (int k = 0; k < channels; ++k) T[k] = std::exp(-tau[k]);
  for (int i = 0; i < lengths.n_pieces; ++i) {
    const MediumLengths::Piece& p = lengths.pieces[i];
    const ChannelValues Tg =
        grid_transmittance(channels_of(p.medium), channels, p.o, p.d, 0.0f, p.t, ray_seed(p.o, p.d, 0x5ad0));
    for (int k = 0; k < channels; ++k) T[k] *= Tg[k];
  }
  return T;
}

}  // namespace gp
