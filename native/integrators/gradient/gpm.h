// Gradient-domain photon density estimation (GPM): Hua, Gruson, Nowrouzezahrai, Hachisuka,
// "Gradient-Domain Photon Density Estimation" (Eurographics 2017), §4, built on SPPM (sppm.h).
//
// Every pass: (1) one camera path per pixel to its gather point z_t (as SPPM, the same random
// numbers, so with the same radius the primal image is SPPM's), shifted to the four neighbours by half-vector
// copy (§4.1, shift.h; the offsets keep the base's sub-pixel position and lens sample); (2) one
// SPPM photon pass, each photon remembering its previous vertex y_{s-1} (PhotonOrigin);
// (3) each base gather point gathers its photons y_s within its radius (density estimation only
// at base gather points, §4.3) and, for each photon and each neighbour, builds the offset path:
//   - the offset photon: candidate y*_s of eq. 5 in the gather points' tangent frames, traced
//     from y_{s-1}: y'_s = trace(y_{s-1} -> y*_s), Jacobian eq. 6 (photon_shift.h);
//   - DD endings (y_{s-1} diffuse): y'_s is reconnected to y_{s-1} directly (§4.2 step 2),
//     whose BSDF is re-evaluated for the new outgoing direction; the Jacobian is eq. 6 alone;
//   - specular and glossy chains (y_{b+1} .. y_{s-1} not diffuse, y_b the last diffuse vertex or
//     the light vertex): y'_s is y*_s projected onto the receiver along the offset gather point's
//     normal (not traced from y_{s-1}: the walk moves that vertex, and only the projection is
//     undone exactly by the inverse shift's; gpm.cpp project_candidate), then a manifold walk
//     (JM12 §5.2, manifold.h) from y_b to y'_s with every
//     half-vector held (delta vertices: the normal; glossy ones, roughness <= 0.05: the base's);
//     the Jacobian is eq. 7-10 written in the directions the photon tracer sampled,
//       |d omega'/d omega| = prod_glossy |d omega'_i/d o| / |d omega_i/d o|
//                            * |d omega'_b/dA(y'_s)| / |d omega_b/dA(y_s)| * |dA(y'_s)/dA(y_s)|,
//     the last factor being the projection's (photon_shift.h projection_jacobian), the middle one eq. 8's
//     generalized geometry term over cos at y_b, with glossy
//     vertices held at their half-vectors (eq. 9's middle term) and their own direction
//     Jacobians outside (its first and third terms); delta vertices drop out (eq. 10's discarded
//     rows and columns); the offset photon's power is the base's times the ratio of y_b's
//     directional factor (BSDF, or the light's emission) and of the chain's BSDFs;
//   - the offset path contributes with the base's kernel K = 1/(pi r^2) when y'_s lies within r
//     of the offset gather point z'_t, else 0 (r: the gradients' radius, below);
//   - reversibility (§4.3): the inverse shift of y'_s (eq. 5 from z'_t back to z_t, traced from
//     y_{s-1}, or projected for a chain) must land on y_s; otherwise it is a failed shift;
//   - MIS between the two pixels of each difference by the balance heuristic of eq. 11,
//     w = 1 / (1 + p(Ty)p(Tz)|T'(y)T'(z)| / (p(y)p(z))); a failed shift gives offset 0, weight 1.
// The four MIS-weighted flux differences of a pixel share one radius reduction (thesis eq.
// 7.2-7.5; GPM §4.3) with their base flux, at the paper's initial radius of one pixel footprint
// (`gradient_footprint`), widened after a pixel's first pass where photons are sparse
// (`gradient_photons`, Gpm::widen_gradient_radius). The primal is gathered at SPPM's radius (`footprint`, two pixels, its
// own reduction): one pixel made every photon gathered, and shifted four times, by 4x fewer
// pixels, but left the primal 1.5-1.7x noisier than SPPM's at equal time, and the screened
// Poisson solve keeps the primal's low frequencies. Both radii shrink to 0, so the gradients and
// the primal estimate the same image in the limit (docs/gradient.md "Two radii").
//
// What is not shifted, and stays in the primal domain (kept apart, added after the screened
// Poisson reconstruction, so it is estimated exactly as SPPM estimates it and neither biases the
// gradients nor is biased by them; the gradient passes include its finite differences):
//   - photons whose chain cannot be walked: longer than kMaxChainVertices, counted as "shift
//     failed: specular chain not walkable" (a distant light's chain walks across its parallel
//     beam, its direction held: manifold.h);
//   - emission seen along the camera path (at depth 0 or after specular/glossy bounces).
//     `combined` estimates it with `emission_samples` further camera paths per pixel and pass
//     besides the gather path (each stops at its first photon-diffuse vertex: no NEE, no gather)
//     in every pixel in the first pass, then in the pixels where it has varied between paths or
//     whose gather paths went through specular or glossy surfaces (`emission_samples_max` of them
//     within 48 pixels of a pixel whose light seen has varied: gpm.cpp further_paths),
//     because a GPM pass costs several SPPM passes and this part gains nothing from gradients:
//     with one path per pass, the light and its images in mirrors and glass were as noisy as
//     SPPM's at a third to a fifth of its passes (cornell-glass; docs/gradient.md "Emission").
//     `primal` keeps the gather path's alone, so it stays SPPM's image.
// A walk that does not converge in `manifold_iterations` steps is a failed shift (offset 0,
// weight 1, counted as "shift failed: manifold walk did not converge"), as in the paper.
// Direct light at the gather point by next-event estimation (SPPM's) is in the gradient domain:
// the offset gather points take the same light sample (as GPT), own visibility and BSDF, with
// the sensor subpath's ratio in the MIS weight (the light point's area density is shared).
// With `gradient_nee` off it is kept apart with the emission (primal domain, SPPM's estimate),
// and then a pixel needs its offsets only when its gather finds a photon to shift: the eye pass
// traces them for pixels whose last gather did, the gather replays the others' from their start
// (same random numbers, same records: gpm.cpp eager_offsets, replay_offsets), and a pixel that
// shifts nothing never traces them (issue 34: sun-caustic's floor, lit by the sun, holds photons
// only in the ball's caustic).
// No further camera paths where no camera path can meet emission (lights only point, spot and
// sun, no medium): each would add 0 (gpm.cpp, the constructor).
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods gpm`, docs/methods.md#gpm).
// alpha, photons and the primal's initial radius mean what they mean in SPPM, so that the primal
// pass is SPPM's image at the same parameters; GPM may default to its own photons per pass
// (issue 34: methods.cpp gpm_photons); why each default: docs/methods.md#gpm.
//
// Passes: combined (reconstruction + primal-domain part), primal (= SPPM's image for the same
// seed and parameters), gradient_x,
// gradient_y (forward differences describing the primal pass: L2 reconstruction of primal and
// gradients gives combined back), error, radius, photon_count (as SPPM).
// Statistics: Stats::extra counts sensor ("sensor shift failed: ...") and photon ("shift
// failed: ...") shift failures by reason, "photon shifts" attempted, "manifold walks" and
// "manifold walk iterations".
#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <vector>

#include "integrators/shift/manifold.h"
#include "integrators/shift/shift.h"
#include "integrators/photon/progressive_photon.h"
#include "reconstruction/poisson.h"

namespace gp {

// ---- Photons per pass with `photons` 0 (issue 34) ----
// A GPM eye pass (five camera paths per pixel, their next-event shots, further camera paths) is a
// fixed cost per pass that more photons spread over more light. With `photons` 0 each pass after
// the first takes as many photons as make the last pass's eye work half a pass (kEyeShare: the
// issue asked for a quarter, which lost at equal work):
//   eye / (eye + N * per_photon) = 1/2  ->  N = eye / per_photon,
// never below SPPM's ramp (auto_photons_per_pass), at most kMaxEmitted, and at most as many as
// would store kMaxStored photons at the last pass's stored share (memory: the ramp's largest pass).
// Work is counted, not timed, so that a seed gives the same image on any machine and at any
// load (and merged runs stay runs of their own seeds): rays, stored photons and walk iterations
// weighted by their instructions per item (gpm.cpp; docs/gradient.md "Photons per pass that
// follow the eye pass's work").
struct GpmPassWork {
  int64_t eye_rays = 0;       // rays of the eye pass: camera paths, offsets, shadow rays, further paths
  int64_t photon_rays = 0;    // photon tracing's closest-hit rays
  int64_t shift_rays = 0;     // the gather's: step-1 rays, walk projections, offset replays
  int64_t walk_iterations = 0;
  int64_t emitted = 0, stored = 0;  // the pass's photons
  // In eye rays (kGpm*Weight, gpm.cpp).
  double eye_work() const;
  double photon_work() const;
};
// The rule's two constants (gpm.cpp kEyeShare, kRampFloor are the defaults; tests and equal-work
// sweeps set others): the eye pass's target share of a pass's counted work, and the fraction of
// SPPM's ramp the count never goes below.
struct GpmPhotonRule {
  double eye_share;
  double ramp_floor;
};
GpmPhotonRule default_gpm_photon_rule();
int64_t gpm_photons_per_pass(const GpmPassWork& last, int width, int height, uint64_t pass,
                             const GpmPhotonRule& rule = default_gpm_photon_rule());

class Gpm : public ProgressivePhotonMapping {
 public:
  Gpm(const Scene& scene, const Params& params);
  std::string name() const override { return "gpm"; }
  // Every per-kind switch: its base paths are SPPM's (and gather by the photons' lobes), the
  // camera offsets' rays take the base's kind, and a photon whose last segment met a surface
  // hidden from some of its kinds is not shifted (shift_dd_photon).
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;
  // Tests: trace every pixel's offsets in the eye pass (the lazy rule's reference image).
  void set_eager_offsets(bool eager) { eager_all_offsets_ = eager; }
  // Tests: `photons` 0 takes SPPM's ramp, not gpm_photons_per_pass (regressions found with it).
  void set_ramp_photons(bool ramp) { ramp_photons_ = ramp; }
  void set_photon_rule(const GpmPhotonRule& rule) { photon_rule_ = rule; }
  // Tests: the further camera paths each pixel took (finite ones), over all passes so far.
  const std::vector<int64_t>& further_paths_per_pixel() const { return further_per_pixel_; }
  // Tests: how near (pixels) a pixel whose light seen has varied makes others take the max.
  void set_emission_spread(int pixels) { emission_spread_ = pixels; }

  // Offsets in the order the per-pixel sums are kept (as GradientPathTracer).
  enum Direction { kRight = 0, kLeft = 1, kDown = 2, kUp = 3 };

  // The offset gather point z'_t of one neighbour, from the half-vector copy of the eye path.
  struct OffsetPoint {
    bool exists = false;  // the neighbour is inside the image
    ShiftFailure failure = ShiftFailure::None;
    Vec3 p, ng;
    Frame frame;
    Vec3 wo;              // local
    RGB beta;             // f(T z) |T'(z)| / p(z): throughput in the base's measure (eq. 4)
    double ratio = 1;     // p(T z) |T'(z)| / p(z), for eq. 11
    int material = -1;
    Vec2 uv;  // texture coordinate there (Scene::bsdf)
    Vec3 n_smooth;  // the interpolated normal before a normal map (bump shadowing, bent cosine)
    bool ok() const { return exists && failure == ShiftFailure::None; }
  };

 private:
  // The gradients' own progressive statistics: they gather with their own radius (the paper's
  // one pixel, §5), reduced by their own photon count (thesis eq. 7.2-7.3), while the primal
  // keeps SPPM's (PixelState: two pixels), so that `primal` is SPPM's image at the same parameters.
  struct GradState {
    double r2 = 0;                 // the gradients' R_i^2 (0 until the primal's is set)
    double n = 0;                  // their N_i
    double tau_fb[3] = {0, 0, 0};  // flux of photons kept in the primal domain (specular chains)
    double diff[4][3] = {};        // MIS-weighted flux differences per direction, within r2
    double nee[3] = {0, 0, 0};     // sum over passes of the direct light by NEE
    double nee_diff[4][3] = {};    // sum over passes of its MIS-weighted differences
    double emission[3] = {0, 0, 0};  // sum over passes of each pass's mean emission seen (all paths)
    double emission_lum = 0, emission_lum2 = 0;  // luminance sums of every path's emission seen
    double emission_paths = 0;                   // and how many paths
    bool scattered = false;  // a gather path went through a specular or glossy vertex
    bool sized = false;      // widened (or not) after the pixel's first gather (gpm.cpp)
    // Whether this pixel's light seen along camera paths has varied between paths so far: there
    // further paths lower the variance (an emitter's edge or its image in glass, not the inside
    // of an emitter or a pixel that never saw one). Pixels seen through specular or glossy
    // surfaces take them too: there a light's image may be seen rarely (a small light through a
    // glass ball), and a pass that first sees it should not give it one path's weight.
    bool emission_varies() const {
      return emission_lum2 * emission_paths - emission_lum * emission_lum > 1e-9 * emission_lum2 * emission_paths;
    }
  };
  void widen_gradient_radius(GradState& g, double r2_primal, double m_primal) const;
  // One pass's light seen along a pixel's camera paths: the gather path's and its further ones.
  struct EmissionSeen {
    RGB mean{0.0f};             // their mean (summed in double: a few near FLT_MAX overflow a float)
    double lum = 0, lum2 = 0;  // luminance sum and sum of squares over the paths
    int paths = 0;
    bool scattered = false;  // the gather path went through a specular or glossy vertex
  };

  bool takes_further_paths(size_t pixel, uint64_t pass) const;
  int further_paths(size_t pixel, uint64_t pass) const;  // how many, from earlier passes (gpm.cpp)
  // Whether the eye pass traces the pixel's offsets, or leaves them to replay_offsets.
  bool eager_offsets(size_t pixel) const;
  std::array<OffsetPoint, 4> replay_offsets(size_t pixel, uint64_t pass, int64_t& rays, int64_t* fail_count) const;
  // (x, y): the film pixel the start belongs to (with a wide pixel filter start.film may lie
  // outside it).
  EmissionSeen emission_seen(PixelStart& start, int x, int y, const Vec2& ext, const RGB& gather_path, int further,
                             int64_t& rays, int64_t& invalid) const;
  // The eye pass over the tiles not done yet (eye_tiles: with `may_pause`, it stops when the sink
  // asks and returns false; the next call goes on, with the same random numbers).
  bool gpm_eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause, std::atomic<int64_t>& rays,
                    std::atomic<int64_t>& invalid, std::array<std::atomic<int64_t>, 2 * kShiftFailureCount>& failures);

  // One photon's offset for one neighbour (§4.2): where it lands relative to the offset gather
  // point and what it carries there.
  struct PhotonShift {
    ShiftFailure failure = ShiftFailure::None;
    bool in_kernel = false;  // y'_s within the base's radius of z'_t, on a side it gathers
    RGB power{0.0f};         // f(y')|T'(y)| / p(y): the offset photon's power in the base's measure
    Vec3 wi_gather;          // local direction at z'_t towards y'_{s-1}
    double ratio_y = 0;      // p(T y)|T'(y)| / p(y) of eq. 11 (light subpath)
  };
  // The base chain's factors for the light-subpath shift: they depend on the photon alone, so
  // they are evaluated once per pass for all the pixels that gather it and their four offsets.
  struct ChainBase {
    bool ok = false;
    PreparedChain prepared;  // the chain with its targets, tangent map, eq. 8 term, throughput
    RGB g{0.0f};            // y_b's directional factor towards y_{b+1}
    double pdf = 0;         // y_b's solid-angle pdf of that direction
  };
  struct WalkStats {
    int64_t walks = 0, iterations = 0;
  };
  // Step 1 (eq. 5-6) and the DD reconnection of step 2.
  // org_bsdf: y_{s-1}'s BSDF, built on the first call for the photon and kept for its other offsets.
  // o_transmits: the offset gather point's BSDF transmits (Bsdf::transmits): an offset photon on
  // its far side is in its kernel too (photon_gather_side, as the base's gather).
  PhotonShift shift_dd_photon(const VisiblePoint& vp, const OffsetPoint& o, bool o_transmits, float R,
                              const Photon& ph, const PhotonOrigin& org, std::optional<Bsdf>& org_bsdf,
                              int64_t& rays) const;
  // Step 1 and the manifold walk of step 2 for specular and glossy chains (eq. 7-10).
  PhotonShift shift_chain_photon(const VisiblePoint& vp, const OffsetPoint& o, bool o_transmits, float R,
                                 const Photon& ph, const PhotonOrigin& org, const PhotonChain& chain,
                                 const ChainBase& base, int64_t& rays, WalkStats& walk_stats) const;
  // The chain's ChainBase, from this pass's cache (evaluated by the first thread that needs it;
  // a thread that finds it being evaluated elsewhere evaluates its own copy into `local`).
  const ChainBase& chain_base(const Photon& ph, const PhotonOrigin& org, ChainBase& local) const;
  ChainBase evaluate_chain_base(const Photon& ph, const PhotonOrigin& org) const;
  // y_b's directional factor (f |cos| with the adjoint correction, or a light's emission) and pdf.
  RGB reconnection_factor(const PhotonChain& chain, const Vec3& dir, double& pdf) const;

  ReconOptions recon_;
  bool ramp_photons_ = false;
  GpmPassWork last_work_;  // the last pass's, for the next pass's photon count (gpm_photons_per_pass)
  GpmPhotonRule photon_rule_ = default_gpm_photon_rule();
  int64_t photons_next(uint64_t pass) const {
    return photons_per_pass_ > 0 || pass == 0 || ramp_photons_ ? photons_for_pass(pass)
                                                                : gpm_photons_per_pass(last_work_, width_, height_, pass, photon_rule_);
  }
  std::vector<std::array<OffsetPoint, 4>> off_;
  std::vector<PhotonOrigin> origins_;
  std::vector<PhotonChain> chains_;
  mutable std::vector<ChainBase> chain_bases_;                 // per chain, this pass
  mutable std::unique_ptr<std::atomic<uint8_t>[]> chain_state_;  // 0 empty, 1 evaluating, 2 ready
  size_t chain_state_size_ = 0;
  int manifold_iterations_ = 5;
  double gradient_radius_scale_ = 1;  // gradient_footprint / footprint (or 1 for a radius in metres)
  double gradient_photons_ = 0;       // photons per pass a gradient gather aims at (0: fixed radius)
  std::vector<GradState> grad_;
  std::vector<RGB> gather_fb_;
  std::vector<float> gather_mg_;                    // photons within the gradients' radius
  std::vector<std::array<RGB, 4>> gather_diff_;
  std::vector<RGB> pass_nee_;                       // this pass's NEE light per pixel
  std::vector<std::array<RGB, 4>> pass_nee_diff_;   // and its differences
  int emission_samples_ = 0;                        // further camera paths per pixel and pass
  int emission_samples_max_ = 0;                    // where the light seen has varied (>= the above)
  std::vector<int64_t> further_per_pixel_;          // further paths traced (finite), all passes
  // Pixels: how near one whose light seen has varied a pixel takes the max (a square; measured:
  // 0 and 96 lost to 48 on cornell-glass, docs/gradient.md "Further paths where they found light").
  int emission_spread_ = 48;
  std::vector<uint8_t> near_varied_;                // within emission_spread_ of a varied pixel
  void update_near_varied();
  bool gradient_nee_ = true;                        // direct light by NEE in the gradient domain
  bool eager_all_offsets_ = false;                  // tests: every offset in the eye pass
  std::vector<uint8_t> offsets_ready_;              // off_[pixel] traced this pass
  std::vector<uint8_t> gathered_shifts_;            // the pixel's last gather shifted photons
  std::vector<EmissionSeen> pass_emission_;         // this pass's per pixel
  // The first pass's sensor shift failures while it is open (paused: first_pass_open).
  std::array<int64_t, kShiftFailureCount> open_failures_{};
};

}  // namespace gp
