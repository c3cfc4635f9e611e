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
// sigma_s T / pdf). gather_beam visits those photons with T and f_p; gather_pixel_beams runs one
// pass's gather over every pixel's segments (first radius, photon grid, sums M and the flux).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/parallel.h"

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

// ---- One pass's beam gather over every pixel (SPPM's and MSPPM's volume_gather) ----
// A pixel's camera segments of this pass: `stride` slots a pixel in `beams`, n[i] of them used;
// first_vr[i] the footprint radius at the first one's middle (FirstCylinder's lower bound).
struct PixelBeams {
  const std::vector<EyeBeam>& beams;
  int stride;
  const std::vector<uint8_t>& n;
  const std::vector<float>& first_vr;
};

// The beam radiance estimate's sums of one pass over every pixel: out_m[i] the volume photons M
// within pixel i's cylinder along all its segments, out_phi[i] sum_p power(b, p, T, f) (the
// caller's weighting: beta T f Phi_p in RGB, the wavelengths' to RGB in spectral SPPM). Both
// enter progressive_beam_update (eq. 5.37-5.39, 5.12). vr2(i) -> double&: pixel i's cylinder
// R^2, set here on the first pass it has segments (`radius` if > 0, else FirstCylinder's rule);
// 0 leaves the pixel out. The photons are hashed into `grid` (exact, cells of 2 sqrt(2) R_max).
// cancelled (may be empty) is polled every kPollPixels pixels: the sums are then partial and
// the caller abandons the pass.
template <class PixelR2, class ChannelsOf, class Power>
void gather_pixel_beams(const Scene& scene, const std::vector<Photon>& volume, PhotonHashGrid& grid,
                        const PixelBeams& pixels, double radius, PixelR2&& vr2, uint64_t seed, uint64_t pass,
                        int threads, int C, const std::function<bool()>& cancelled, ChannelsOf&& channels_of,
                        Power&& power, std::vector<float>& out_m, std::vector<RGB>& out_phi) {
  constexpr size_t kPollPixels = 4096;
  const size_t n_pixels = pixels.n.size();
  Bounds3 box;  // the photons' bounds: beams are searched only where photons are
  for (const Photon& ph : volume) box.extend(ph.p);
  // The cylinder's first radius: `radius` if given, else FirstCylinder's rule.
  const FirstCylinder first(scene, volume, box);
  for (size_t i = 0; i < n_pixels; ++i) {
    if (pixels.n[i] == 0 || vr2(i) > 0) continue;
    if (radius > 0) vr2(i) = radius * radius;
    else if (first.valid()) vr2(i) = first.r2(&pixels.beams[i * pixels.stride], pixels.n[i], pixels.first_vr[i]);
  }
  double max_r2 = 0;
  for (size_t i = 0; i < n_pixels; ++i)
    if (pixels.n[i] > 0) max_r2 = std::max(max_r2, vr2(i));
  const float max_r = static_cast<float>(std::sqrt(max_r2));
  const bool have = !volume.empty() && max_r > 0;
  if (have) grid.build(volume, 2.0f * std::sqrt(2.0f) * max_r, PhotonHashMode::Exact, seed, pass, threads, 0, cancelled);
  parallel_for(n_pixels, threads, [&](size_t lo, size_t hi) {
    // Grid media: the transmittance along a beam by one ratio-tracking walk per grid medium, read
    // at every photon's foot (TransmittanceSteps); kept for their capacity.
    std::array<TransmittanceSteps, kMaxBeamMedia> steps;
    for (size_t i = lo; i < hi; ++i) {
      if (i % kPollPixels == 0 && cancelled && cancelled()) return;  // abandoned pass (the caller checks)
      out_m[i] = 0;
      out_phi[i] = RGB(0.0f);
      if (!have || pixels.n[i] == 0 || !(vr2(i) > 0)) continue;
      const float R = static_cast<float>(std::sqrt(vr2(i)));
      double m = 0;
      RGB phi(0.0f);
      for (int k = 0; k < pixels.n[i]; ++k) {
        const EyeBeam& b = pixels.beams[i * pixels.stride + k];
        gather_beam(grid, box, b, R, C, 0xbea0 + pass, steps, channels_of,
                    [&](const Photon& ph, const ChannelValues& T, const ChannelValues& f) {
                      m += 1;
                      phi += power(b, ph, T, f);
                    });
      }
      out_m[i] = static_cast<float>(m);
      out_phi[i] = phi;
    }
  });
}

}  // namespace gp
