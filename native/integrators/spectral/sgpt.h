// Spectral gradient sampling (Petitjean, Bauszat, Eisemann 2018, §3): per pixel, a discretised
// spectrum I (B bins over 360-830 nm) and its spectral gradients G_j = I_{j+s} - I_j estimated
// from pairs of correlated paths, then a 1D screened Poisson reconstruction (eq. 14).
//
// Each sample traces a base path at one uniformly sampled wavelength lambda (bin j), with
// next-event estimation and BSDF sampling combined by the balance heuristic as in pt, and
// shifts it to lambda + delta and lambda - delta (cyclic, eq. 9) with the spectral shift of
// §3.1 (spectral_shift.h): the offset is the base path until the first wavelength-dependent
// (dispersive) refraction, copies the generalised half vector (eq. 12) through dispersive and
// specular vertices with the Jacobian of eq. 13, and reconnects to the base path at two
// consecutive connectable (neither near-specular nor dispersive) vertices. At every vertex the
// offset evaluates the base's light sample (the same random numbers: the same point on an area
// light, the same direction of a distant one), from its own vertex once diverged, with the
// reconnection Jacobian at the light point ([KMA*15] §5.2). Each event (emission found by a
// BSDF-sampled ray, or a light sample) of the base path pairs with the offset's same event;
// the pair is weighted by the symmetric balance heuristic of eq. 10-11 (eq. 18 with C > 1) whose
// denominator sums both strategies (BSDF, light) of both paths; pairs whose smaller
// contribution f is <= tau fall back to standard sampling (eq. 15-16), and the offset is not
// traced past the point where no base event has f > tau. The base path alone gives the primal I.
//
// Russian roulette acts on the roulette-compensated hero throughput (as pt). The offset's
// density uses the survival probability its own throughput would have had as a base path, so
// that the two weights of a pair sum to 1.
//
// Differences from the paper, deliberately:
//   - delta is snapped to a whole number of bins s = round(delta * B) (s >= 1), so the
//     gradient of bin j pairs it exactly with bin j + s (for B = 15, delta 0.15 -> 2 bins =
//     62.7 nm); the shifted wavelength keeps its position inside the bin.
//   - f in eq. 16 is the measurement contribution in the product solid-angle measure the
//     estimator works in (throughput times emitted spectral radiance, no pixel importance), so
//     tau is in units of spectral radiance; the paper's values (2.5-10, Mitsuba's measure) do
//     not carry over numerically (docs/spectral.md has the measurement behind the default).
//
// With `wavelengths` C > 1 the base path carries the hero and C - 1 rotations and each offset
// their shifted copies (§3.4): every wavelength of the set contributes its pair, weighted by
// eq. 18 over the 2C techniques (times the two strategies); a smooth dispersive refraction
// leaves only the hero's pair.
//
// Blender scenes as Cycles renders them (docs/blender.md): per-kind ray visibility of surfaces,
// lights and the World (Cycles' own rule for a constant World, lobe_split.h), for the base and
// the offsets alike (sgpt.cpp, LobeScatter); light
// objects crossed as spt crosses them; per-wavelength BSDFs with the hit's normals, so a normal
// or bump map's shadowing term applies at every vertex (Scene::bsdf(params, hit)).
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods sgpt`, docs/methods.md#sgpt).
//
// Colour: the primal colour is summed per sample with the exact CMFs at lambda (as spt does);
// the reconstruction's correction (I' - I, zero-mean because the L2 solve is linear and
// unbiased) is added at bin resolution. So binning changes the noise, not the expected colour.
//
// Passes: combined (reconstructed), spectral_primal (the base paths' colour, no
// reconstruction), spectral_gradient (RMS of the B gradient estimates).
#pragma once

#include <array>
#include <vector>

#include "core/rng.h"
#include "core/spectrum.h"
#include "integrators/shift/shift.h"
#include "integrators/integrator.h"
#include "integrators/spectral/spectral_pt.h"
#include "reconstruction/spectral_poisson.h"

namespace gp {

// Whether the shift may reconnect at a vertex of this material (the "connectable" vertices
// above; [KMA*15] §5.2): one whose BSDF has a lobe the offset can evaluate at a new direction
// pair and that does not depend on the wavelength through its direction. By its lobes: a
// diffuse lobe (diffuse, plastic's base, principled's Burley diffuse) or a conductor's or
// dielectric's glossy lobe at least as rough as the specular threshold, not dispersive; a mix
// when either part is. Emission-only surfaces end the path there and count as connectable.
// A mixed-lobe vertex whose base path went on through a Dirac lobe is not reconnected to
// (OffsetPath::scatter in sgpt.cpp checks the sampled lobe).
bool connectable(const Material& m);

class SpectralGradientPathTracer : public Integrator {
 public:
  SpectralGradientPathTracer(const Scene& scene, const Params& params);
  std::string name() const override { return "sgpt"; }
  void iterate(ProgressSink* sink) override;
  // Every per-kind switch: base and offset rays carry the base's lobes (surfaces'), and lights
  // and the World hidden from some kinds light only the lobes that see them, at the base's and
  // at each offset's own vertices (sgpt.cpp, LobeScatter).
  void develop(Film& film) const override;

  int bins() const { return bins_; }
  int stride() const { return stride_; }
  // Image averages of the per-pixel estimates: primal bins I_j and gradients G_j (for tests:
  // E[G_j] = E[I_{j+s}] - E[I_j] when the shift and its weights are right).
  // Optionally over the pixels [x0, x1) x [y0, y1) only (averaged over those).
  void image_totals(std::vector<double>* primal, std::vector<double>* gradient, int x0 = 0, int y0 = 0,
                    int x1 = -1, int y1 = -1) const;

  // Shift statistics by outcome (also in stats().extra); failures by the reasons every shift
  // mapping counts (shift/shift.h ShiftFailure: "shift failed: occluded", ...).
  struct ShiftCounts {
    int64_t attempts = 0, shifted = 0, below_tau = 0;
    std::array<int64_t, kShiftFailureCount> failed{};
    void fail(ShiftFailure f) { ++failed[static_cast<int>(f)]; }
  };

 private:
  // Adds one sample's primal and gradient estimates for pixel `pixel`; false (and nothing
  // added) when any of them is NaN/Inf.
  bool sample_pixel(size_t pixel, Rng& rng, Ray ray, RayCounts& rays, ShiftCounts& counts);
  RGB bins_to_rgb(const double* bins) const;

  const Scene& scene_;
  SceneSpectra spectra_;
  int bins_, count_, stride_, max_depth_, rr_depth_, threads_, tile_size_;
  double delta_, tau_, lambda_;  // lambda_: the weight alpha of the paper's eq. 14
  uint64_t seed_;
  int width_, height_;
  SpectralPoisson poisson_;
  std::vector<RGB> bin_rgb_;       // RGB of a unit bin integral, per bin
  std::vector<double> primal_;     // per pixel, per bin: sums of f / p
  std::vector<double> rgb_;        // per pixel: RGB sums of the base samples, exact CMFs
  std::vector<double> gradient_;   // per pixel, per bin: sums of the G_j estimates
  std::vector<uint32_t> samples_;
  ShiftCounts counts_;
};

}  // namespace gp
