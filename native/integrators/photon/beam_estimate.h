// The beam radiance estimate's photon query (Jarosz et al. 2008; thesis §5.6, eqs. 5.37-5.39),
// written once for the photon methods that gather volume photons along camera segments: SPPM's
// volume_gather (progressive_photon.cpp) and MSPPM's (msppm.cpp).
//
// A pixel's in-scattered radiance along its camera segments through media is
//   L_v = 1 / (N_e pi R^2) sum_p beta T(x, x_p) f_p(theta_p) Phi_p
// over the volume photons p within the cylinder of radius R around each segment (perpendicular
// distance <= R, between the segment's ends): beta the eye throughput at the segment's start,
// T the transmittance from it to the photon's foot on the segment, f_p the phase function between
// the photon's direction of travel and the direction towards the camera, and Phi_p the photon's
// power, which already carries sigma_s(x_p) (photon_walk.h: the free flight's weight
// sigma_s T / pdf). gather_beam visits those photons with T and f_p; the caller sums.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "integrators/photon/photon_hash.h"
#include "integrators/photon/photon_tracer.h"
#include "media/medium.h"
#include "scene/scene.h"

namespace gp {

// A camera segment through a scattering medium: where the beam radiance estimate gathers volume
// photons, t in [0, t_max) along o + t d; beta the path's throughput at o per channel (RGB or
// the pass's wavelengths), the media it is in (MediumSegment rebuilds them).
constexpr int kMaxBeamMedia = 4;  // overlapping media per segment kept
struct EyeBeam {
  Vec3 o, d;
  float t_max = 0;
  ChannelValues beta{};
  std::array<int16_t, kMaxBeamMedia> media{};
  uint8_t n_media = 0;
  bool hero_only = false;  // spectral: the eye path is hero-only (its beta carries C)
};

// A beam from the ray `ray` (to t_end) of a path with throughput `beta` in the media of `stack`.
inline EyeBeam make_beam(const Ray& ray, float t_end, const ChannelValues& beta, const MediumStack& stack,
                         bool hero_only = false) {
  EyeBeam b;
  b.o = ray.o;
  b.d = ray.d;
  b.t_max = t_end;
  b.beta = beta;
  b.hero_only = hero_only;
  b.n_media = 0;
  for (int i = 0; i < stack.size() && b.n_media < kMaxBeamMedia; ++i) b.media[b.n_media++] = static_cast<int16_t>(stack[i].medium);
  return b;
}

// The part of beam b within `box` grown by R: [t0, t1) (empty: t0 >= t1).
inline void clip_beam(const Bounds3& box, const EyeBeam& b, float R, float& t0, float& t1) {
  t0 = 0;
  t1 = b.t_max;
  for (int a = 0; a < 3; ++a) {
    const float inv = 1.0f / b.d[a];
    float ta = (box.lo[a] - R - b.o[a]) * inv, tb = (box.hi[a] + R - b.o[a]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (std::isnan(ta) || std::isnan(tb)) continue;  // parallel to the slab, on its plane
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
}

// ---- The cylinder's first radius (no `radius` given) ----
// The pixel footprint that starts the surface's disc is far too thin for volume photons,
// which fill a volume, not a surface: a cylinder of a footprint's radius finds a photon in a
// few passes, so its estimate stays noisy and its radius hardly shrinks. Instead the first
// radius is the one whose cylinders, along the pixel's segments within the photons' bounds,
// would hold kPhotons photons were this pass's volume photons within the scene's bounds spread
// evenly over them (never below the footprint, nor above a tenth of the bounds' diagonal); where
// they are denser it shrinks the faster. (The scene's bounds, not the photons': in a World medium
// photons wander far from the scene.)
class FirstCylinder {
 public:
  static constexpr double kPhotons = 16;
  // box: the volume photons' bounds.
  FirstCylinder(const Scene& scene, const std::vector<Photon>& volume, const Bounds3& box) {
    region_ = scene.bounds();
    if (region_.empty()) region_ = box;  // no surfaces at all
    if (!region_.empty()) {
      const float pad = 0.01f * length(region_.diagonal()) + 1e-4f;  // a flat scene still has a volume
      region_.lo = region_.lo - Vec3(pad);
      region_.hi = region_.hi + Vec3(pad);
    }
    size_t inside = 0;
    for (const Photon& ph : volume)
      inside += ph.p.x >= region_.lo.x && ph.p.y >= region_.lo.y && ph.p.z >= region_.lo.z && ph.p.x <= region_.hi.x &&
                ph.p.y <= region_.hi.y && ph.p.z <= region_.hi.z;
    if (inside > 0 && !region_.empty()) {
      const Vec3 e = region_.diagonal();
      const double volume_m3 = static_cast<double>(e.x) * e.y * e.z;
      density_ = static_cast<double>(inside) / volume_m3;
      diag2_ = length_squared(e);
    }
  }
  bool valid() const { return density_ > 0; }
  // R^2 for a pixel's n beams, footprint_r the footprint radius at the first's middle; 0 when its
  // beams miss the region.
  double r2(const EyeBeam* beams, int n, float footprint_r) const {
    double len = 0;
    for (int k = 0; k < n; ++k) {
      float t0, t1;
      clip_beam(region_, beams[k], 0.0f, t0, t1);
      if (t0 < t1) len += t1 - t0;
    }
    if (!(len > 0)) return 0.0;
    const double r2 = kPhotons / (M_PI * density_ * len);
    return std::clamp(r2, static_cast<double>(footprint_r) * footprint_r, 0.01 * diag2_);
  }

 private:
  Bounds3 region_;
  double density_ = 0, diag2_ = 0;
};

// Visits the volume photons of `grid` (built with cells of at least 2 sqrt(2) R) within the
// cylinder of radius R around beam b, each once: visit(photon, T, f) with T the transmittance
// from the beam's start to the photon's foot and f the phase function there (channels_of(m):
// medium m's coefficients at the C channels). box: the photons' bounds. steps: kMaxBeamMedia
// ratio-tracking walks (grid media), kept by the caller for their capacity; salt seeds them.
//
// The segment is cut into pieces of length 2R, each searched with a sphere of radius sqrt(2) R
// about its middle (which holds the cylinder's piece), and a photon counts for the piece its
// foot lies in, so each is counted once.
template <class ChannelsOf, class Visit>
void gather_beam(const PhotonHashGrid& grid, const Bounds3& box, const EyeBeam& b, float R, int C, uint64_t salt,
                 std::array<TransmittanceSteps, kMaxBeamMedia>& steps, ChannelsOf&& channels_of, Visit&& visit) {
  const float R2 = R * R;
  MediumStack stack;
  for (int j = 0; j < b.n_media; ++j) stack.cross(j, b.media[j], true);
  const MediumSegment segment(stack, Ray(b.o, b.d), C, channels_of);
  float t0, t1;  // the segment within the photons' bounds grown by R
  clip_beam(box, b, R, t0, t1);
  if (!(t0 < t1)) return;
  // Every photon's foot lies within [t0, t1] (the photon is in the box, its foot within R).
  for (int g = 0; g < segment.n_grids; ++g)
    steps[g].track(*segment.grids[g].c, C, b.o, b.d, std::min(t1, b.t_max), ray_seed(b.o, b.d, salt + g));
  const bool mixture = segment.heterogeneous() && segment.n_lobes > 1;
  // T(x, x_p): the homogeneous media's exactly, the grids' by their walks.
  auto transmittance = [&](float tp) {
    if (!segment.heterogeneous()) return segment.transmittance(tp);
    ChannelValues T{};
    for (int w = 0; w < C; ++w) T[w] = segment.sigma_t[w] > 0 ? std::exp(-segment.sigma_t[w] * tp) : 1.0f;
    for (int g = 0; g < segment.n_grids; ++g) {
      const ChannelValues Tg = steps[g].at(tp);
      for (int w = 0; w < C; ++w) T[w] *= Tg[w];
    }
    return T;
  };
  // Pieces counted in integers (a float t += 2R could stall far along a long segment).
  const double pieces = std::ceil((static_cast<double>(t1) - t0) / (2.0 * R));
  const int64_t n_pieces = static_cast<int64_t>(std::min(pieces, 1e7));
  for (int64_t piece = 0; piece < n_pieces; ++piece) {
    const float t = t0 + static_cast<float>(piece) * 2 * R;
    grid.query(b.o + b.d * (t + R), std::sqrt(2.0f) * R, [&](const Photon& ph, float, float) {
      const Vec3 off = ph.p - b.o;
      const float tp = dot(off, b.d);
      if (tp < t || tp >= t + 2 * R || tp < 0 || tp >= b.t_max) return;  // another piece's
      if (length_squared(off - b.d * tp) > R2) return;                       // outside the cylinder
      const float cos_theta = dot(ph.wi, b.d);  // travel direction -wi, towards the camera -d
      const ChannelValues T = transmittance(tp);
      if (mixture) segment.set_point(ph.p);  // the media's shares of the scattering at the photon
      const ChannelValues f = segment.phase(cos_theta);
      visit(ph, T, f);
    });
  }
}

}  // namespace gp
