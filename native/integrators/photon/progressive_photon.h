// Shared machinery of progressive photon mapping (PPM, thesis ch. 5) and stochastic
// progressive photon mapping (SPPM, ch. 7): per-pixel measurement statistics (radius,
// accumulated count and flux), one photon pass per iterate(), gathering through a photon
// hash grid (exact or stochastic, ch. 10) and the progressive error estimate of ch. 6.
// ppm.h and sppm.h hold the two methods' documentation and parameter tables.
//
// Gathering (each measurement point queries the grid of this pass's photons) rather than
// splatting: every pixel sums its own photons in a fixed order, so no atomics, no
// thread-count dependence, and the smooth-kernel Laplacian of §6.4 is computed where the
// point's radius is known.
#pragma once

#include <chrono>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "integrators/photon/beam_estimate.h"
#include "integrators/photon/photon_hash.h"
#include "core/frame.h"
#include "core/rng.h"
#include "integrators/photon/adaptive_photons.h"
#include "integrators/photon/error_estimate.h"
#include "integrators/photon/pausable_tiles.h"
#include "integrators/integrator.h"
#include "integrators/photon/photon_tracer.h"
#include "integrators/paths/medium_stack.h"
#include "integrators/paths/medium_walk.h"
#include "integrators/paths/spectral_scene.h"
#include "core/sampling.h"
#include "materials/bsdf.h"

namespace gp {

// Radius and flux update of one measurement point after a photon pass (thesis eq. 5.7, 5.9,
// 5.12; with shared statistics eq. 7.2, 7.3, 7.5). `m` photons found, carrying `phi`.
struct PhotonStatsUpdate {
  double n_new, r2_new, ratio;  // ratio = (N + alpha M) / (N + M) = R_new^2 / R^2
};
inline PhotonStatsUpdate progressive_update(double n, double r2, double m, double alpha) {
  if (!(m > 0)) return {n, r2, 1.0};
  const double ratio = (n + alpha * m) / (n + m);
  return {n + alpha * m,  // thesis eq. 5.7
          r2 * ratio,     // thesis eq. 5.9 (squared): R^2 (N + alpha M) / (N + M)
          ratio};         // thesis eq. 5.12: tau_new = (tau_N + tau_M) * ratio
}

// The same for a pixel's beam radiance estimate (thesis eq. 5.39: the cylinder's radius by the
// surface rule, `vm` volume photons found; its flux by eq. 5.12). A non-finite pass flux adds
// nothing and returns true (counted as invalid). SPPM's and MSPPM's pass ends.
inline bool progressive_beam_update(double& vn, double& vr2, double vtau[3], RGB vphi, double vm, double alpha) {
  const bool bad = !vphi.is_finite();
  if (bad) vphi = RGB(0.0f);
  const PhotonStatsUpdate v = progressive_update(vn, vr2, vm, alpha);
  for (int c = 0; c < 3; ++c) vtau[c] = (vtau[c] + vphi[c]) * v.ratio;
  vn = v.n_new;
  vr2 = v.r2_new;
  return bad;
}

// Observers of ProgressivePhotonMapping::trace_eye_path (one SPPM camera path), called in path
// order; GPM's offset paths are one (gpm.cpp). The default observes nothing.
struct EyePathHooks {
  // Every surface the path scatters at, with its BSDF there (the walk's own, not rebuilt).
  void vertex(const SurfaceHit&, const Vec3& /*wo*/, const Bsdf&) {}
  // NEE at the measurement point with light sample (u_light, u2); c its weighted contribution.
  void nee(float /*u_light*/, const Vec2& /*u2*/, const RGB& /*c*/) {}
  void gather(const SurfaceHit&) {}                       // the measurement point
  // A specular or glossy bounce; `next` the ray it sends on (its kind: Ray::camera, Ray::bounce).
  void scatter(const Vec3& /*wo*/, const BsdfSample&, const Ray& /*next*/) {}
  void roulette(float /*survival*/) {}                    // Russian roulette survived
};

// NEE without MIS (photons cover the rest) from surface point `hit` with a given light sample:
// f |cos| L / pdf, 0 if blocked (one occlusion ray counted in `rays` when it is traced). SPPM's
// measurement points and GPM's offset gather points, which reuse the base's sample.
// The shadow ray's transmittance (paths/medium_walk.h ShadowTest: transparent surfaces, and with
// a ShadowTest of media, volume boundaries and `media`, the scene's media at R, G, B) multiplies
// the light.
RGB direct_light(const Scene& scene, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo, float u_light,
                 const Vec2& u2, int64_t& rays, const ShadowTest* shadow = nullptr,
                 const std::vector<MediumChannels>* media = nullptr);

// What a photon method built on ProgressivePhotonMapping does; its parameters (and their
// defaults) are its declarations in methods.cpp.
struct PhotonMethodOptions {
  // New measurement points every pass (SPPM) or once (PPM).
  bool retrace = true;
  // Direct light at the measurement point by next-event estimation and photons only after one
  // bounce (SPPM), or every photon deposit (PPM, as the thesis' ch. 5).
  bool nee = true;
  // Reads photon_sampler (and with "adaptive", chains): adaptive MCMC photons (adaptive_photons.h).
  bool adaptive_photons = false;
  // Spectral photons (sppm.h "Spectral photons") when the parameter `spectral` asks for them
  // (use_spectral) and the photon sampler is uniform; reads spectral and wavelengths.
  bool spectral_photons = false;
  // Photons straight from a World hidden from some kinds are gathered by Cycles' rule
  // (PhotonTracer::set_world_by_closure_share, lobe_split.h); GPM, whose photon shifts follow
  // the lights' rule, turns it off. Spectral photons keep the lights' rule.
  bool world_by_closure_share = true;
  // Participating media (issue 32, thesis §5.6): photons scatter in them and are kept as volume
  // photons, eye paths gather them with the beam radiance estimate (PPM, SPPM; RGB and spectral).
  // Off, a scene's media are left out, as the method's declaration says (methods.h).
  bool media = false;
};

// Photons of pass `pass` when `photons` is 0, SPPM's and GPM's default: 100 000 at first (what
// was measured best on small images and short runs), doubling every 8 passes up to two per pixel
// (at most 1 000 000: GPM keeps ~400 bytes of origin and chain per photon). Every pass traces
// new camera paths (GPM five per pixel), so at a fixed count the eye pass grows with the image:
// at 512 x 384 it is 45 % of an SPPM pass and 70 % of a GPM pass at 100 000. The ramp has
// 0.55-0.86x the error of 100 000 at equal time on the SDS scenes at full size; two per pixel
// from the first pass cost GPM 1.4-3.4x its error in cornell-glass's first 32 s (a render's
// first seconds want passes). docs/gradient.md "Photons per pass that follow the image".
int64_t auto_photons_per_pass(int width, int height, uint64_t pass);

struct RgbEye;       // the colours an eye path may carry (trace_eye): below,
struct SpectralEye;  // and in progressive_photon_spectral.cpp

class ProgressivePhotonMapping : public Integrator {
 public:
  ProgressivePhotonMapping(const Scene& scene, const Params& params, const PhotonMethodOptions& options);
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;
  // None where the scene has media: the bias model of ch. 6 is the surface disc's (docs/photon-mapping.md).
  double estimated_error() const override { return media_ ? -1.0 : estimated_error_; }
  // Lights', the World's and surfaces' per-kind switches: the camera path's bounce rays pass
  // surfaces hidden from their kind, next-event estimation at the measurement point lights only
  // the lobes that see the light (direct_light), the emission a specular chain finds counts when
  // the chain's last lobe sees it, and the photon tracer applies Cycles' rule to every segment
  // (photon_tracer.cpp); spectral photons the same (progressive_photon_spectral.cpp).

  // Radiance (RGB) of pixel i as the image shows it, for tests.
  RGB pixel_radiance(size_t i) const;
  // The terms of pixel i's error bound (thesis §6.3, luminance), as the `error` pass uses them.
  struct ErrorTerms {
    double radiance = 0;        // L_i (eq. 5.13 / 7.1)
    double laplacian = 0;       // progressive smooth-kernel estimate of Lap L (eq. 6.30-6.32)
    double bias = 0;            // B'_i: kBiasDisc R^2 Lap L (eq. 6.18-6.20, see error_bound)
    double bias_sd = 0;         // standard error of B'_i, from the per-pass Laplacians
    double noise_sd = 0;        // sqrt(V_i / i) (eq. 6.10, 6.22; INFINITY below 2 passes)
    double half_width = 0;      // E_i of eq. 6.10 at the user's confidence
    double sigma = 0;           // sd of the noise the bound assumes around `bias` (noise_sd for eq. 6.12)
    double bound = 0;           // absolute error bound at the user's confidence (the error pass x L_i)
    double mean_abs = 0;        // estimated E|L_i - L|: folded mean of bias + sigma T (the --target-error stop)
    double photon_passes = 0;   // passes that gathered photons here
    double corrected_mean = 0;  // mean of the bias-corrected per-pass samples x_j (eq. 6.22)
    double radius = 0;          // R_i
    double cut = 0;             // mean share of the query discs that receives no photons (disc_shape)
    double edge_bias = 0;       // first-order boundary bias: L_i less the local linear fits (DiscShape)
    double edge_bias_sd = 0;    // its standard error, from the spread of the passes' biases
    double edge_variance = 0;   // Var(L_i - edge_bias) - Var L_i (BoundarySums::Bias::variance_change)
  };
  ErrorTerms error_terms(size_t i) const;
  // True when the passes carry sampled wavelengths (spectral photons).
  bool spectral() const { return spectral_; }
  // Bytes held by the per-pass photon data (surface and volume photons, their grids, the tracer's
  // chunks, the camera segments), for the flat-memory test.
  size_t memory_bytes() const;

 protected:
  struct VisiblePoint {
    Vec3 p;
    Frame frame;
    Vec3 wo;            // local
    RGB beta;           // eye path throughput up to the point
    int material = -1;  // -1: no measurement point this pass
    ShadePoint uv;      // texture coordinate and triangle there (Scene::bsdf)
    Vec3 ng, n_smooth;  // its geometric and unmapped normals (a normal map's bump shadowing)
  };
  struct PixelState {
    double r2 = 0;                 // R_i^2 (0 until the pixel first sees a diffuse surface)
    double n = 0;                  // N_i
    double tau[3] = {0, 0, 0};     // flux within R_i, not divided by the photons emitted
    double lap = 0;                // smooth-kernel Laplacian of the luminance flux (§6.4)
    double direct[3] = {0, 0, 0};  // sum over passes of the eye path's own light (Le, NEE)
    double coverage = 0;           // passes whose camera ray hit the scene (film_transparent)
    ErrorStats err;                // bias-corrected per-pass samples, B'_j of pass j (eq. 6.22; error_bound = thesis)
    PassSamples pass;              // per-pass estimates and radii: x_j with the latest B' (calibrated)
    ErrorStats lap_err;            // per-pass Laplacian estimates (the bias estimate's own noise)
    double r2_sum = 0;             // sum of the query radii R_j^2 of the passes with a point (eq. 6.18)
    uint32_t photon_passes = 0;    // passes whose gather found photons (phi > 0)
    BoundarySums boundary;         // the passes' disc shapes and boundary photon sums (record_error_sample)
    // The beam radiance estimate's own statistics (thesis §5.6): the cylinder's radius, the photons
    // counted in it and their flux, updated as the surface's (eq. 5.39 = eq. 5.9; 5.12).
    double vr2 = 0, vn = 0, vtau[3] = {0, 0, 0};
  };
  // The part of the query disc (radius R in the tangent plane of the measurement point, axes of
  // boundary_frame) that receives photons, as DiscShape: beyond a surface's edge, behind a wall or
  // under a box standing on it no photon lands. kCutProbes stratified points of the disc, each a
  // ray along the tangent plane from the point (blocked by anything but glass, which photons pass:
  // nothing there photons reach) and one down
  // the normal from just above it (no surface within kOffPlane R: the surface ended). The whole
  // disc's moments less the missing probes' (exact where nothing is missing). `rays` counts them.
  DiscShape disc_shape(const VisiblePoint& vp, double R, Rng& rng, int64_t& rays) const;
  static constexpr int kCutProbes = 8;
  // A photon farther than kOffPlane R from the tangent plane of the measurement point landed on
  // another surface (the wall at a contact line, the far face of an edge): the disc kernel counts
  // it as if it lit the point's own surface.
  static constexpr float kOffPlane = 0.25f;
  // In front of the plane the point's own surface rises only where it is concave, little within R:
  // a photon more than kInFront R in front landed on a surface that meets this one at a concave
  // corner (a wall over a floor), and counted as this surface's it pulled the fit's gradient
  // towards the corner (ceiling over the back wall of cornell-box: -0.07 L against an error of -0.01 L).
  static constexpr float kInFront = 0.05f;
  // Tangent axes of the boundary moments: the geometric normal's frame, on the side the point is seen from.
  static Frame boundary_frame(const VisiblePoint& vp) { return Frame(dot(vp.ng, vp.frame.n) < 0 ? -vp.ng : vp.ng); }
  // One pass's boundary data of a pixel: the disc's part with photons, the luminance flux of other
  // surfaces' photons, and the first moment (tangent axes) of the point's own surface's photons.
  struct PassBoundary {
    DiscShape shape;
    double foreign = 0, mu = 0, mv = 0;
  };
  // After pass j's update of pixel s (radius, flux and Laplacian already reduced): its
  // bias-corrected sample x_j = L_p,j - B'_j (eq. 6.22) and its own Laplacian estimate, from the
  // eye path's light Ld, the photon flux phi and Laplacian sum lap_j gathered with radius
  // sqrt(r2_query) (0: no point this pass) from ne_pass photons. Shared with GPM.
  // cut: the disc's share with no receiving surface this pass (disc_cut_fraction).
  // boundary: this pass's PassBoundary (none: a whole disc, no other surface's photons).
  void record_error_sample(PixelState& s, double Ld, double phi, double lap_j, double r2_query, double ne_pass,
                           const PassBoundary* boundary = nullptr) const;

  // The eye pass over the tiles it has not done (eye_tiles); false when it paused first.
  bool eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause, std::atomic<int64_t>& rays,
                std::atomic<int64_t>& invalid);
  // fn over the open eye pass's tiles not done yet. With `may_pause`, it stops handing out tiles
  // once the sink asks (ProgressSink::pause) after at least one, and returns false: the next call
  // goes on with the others, so the pass is the same as a whole one. True when the pass is done.
  bool eye_tiles(ProgressSink* sink, bool may_pause, const std::function<void(const Tile&)>& fn);
  bool eye_tile_done(size_t pixel) const;
  // The first pass paused before its end (iterate, ProgressSink::pause): develop() shows its
  // preview, the light its camera paths saw themselves at the tiles they reached.
  bool first_pass_open() const { return stats_.passes == 0 && (stage_ != Stage::Eye || eye_tiles_.open()); }

  // ---- One camera path of the eye pass (shared with GPM, whose offsets follow it) ----
  struct EyePath {
    RGB Ld{0.0f};           // light the path saw itself: emission before any photon could, NEE
    VisiblePoint vp;        // the measurement point (material -1: none)
    float path_length = 0;  // distance travelled to it (initial radius)
    bool escaped = false;   // the camera ray left the scene with film_transparent: no background
    float transparent = 0;  // escaped: its transparency (path_transparency)
  };
  // SPPM's camera path: through specular and glossy vertices by BSDF sampling (Russian roulette
  // from rr_depth) to the first photon-diffuse vertex, where it takes NEE when photons skip
  // direct light, and stops there as the measurement point.
  // `first`, when given, is the closest hit of `ray` already traced (Scene::intersect_coherent).
  // `emission_only`: the path stops at that vertex without NEE, so Ld is the emission it saw
  // (GPM's further camera paths for the light seen along them: gpm.h).
  template <class Hooks>
  EyePath trace_eye_path(Ray ray, Rng& rng, int64_t& rays, Hooks& hooks,
                         const std::optional<SurfaceHit>* first = nullptr, bool emission_only = false) const;
  // The eye path walk both eye passes share (RGB: trace_eye_path; wavelengths: the spectral eye
  // pass), generic over what the path carries (`Colour`: RgbEye here, SpectralEye in
  // progressive_photon_spectral.cpp) with its estimator at the measurement point, at each bounce
  // and at roulette in the eye_nee / eye_scatter / eye_survive overloads.
  // A camera segment through a scattering medium (media only): beam_estimate.h's EyeBeam.
  static constexpr int kMaxBeams = 4;       // per camera path; further segments gather nothing
  static constexpr int kMaxBeamMedia = gp::kMaxBeamMedia;
  using EyeBeam = gp::EyeBeam;
  struct EyeEnd {
    VisiblePoint vp;        // the measurement point (material -1: none)
    float path_length = 0;  // distance travelled to it (initial radius)
    bool escaped = false;   // the camera ray left the scene with film_transparent: no background
    float transparent = 0;  // escaped: its transparency (path_transparency; a red pane's 1/3)
    int n_beams = 0;        // camera segments through scattering media (media only)
    std::array<EyeBeam, kMaxBeams> beams;
    float beam_length = 0;  // distance travelled to the first beam's middle (initial cylinder radius)
  };
  template <class Colour, class Hooks>
  EyeEnd trace_eye(Ray ray, Rng& rng, int64_t& rays, Colour& c, Hooks& hooks, const std::optional<SurfaceHit>* first,
                   bool emission_only) const;
  // shadow: null without media (Scene::occluded), else the shadow ray's transmittance counts.
  RGB eye_nee(RgbEye& c, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo, float u_light,
              const Vec2& u2, int64_t& rays, const ShadowTest* shadow) const;
  std::optional<BsdfSample> eye_scatter(RgbEye& c, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo,
                                        float uc, Vec2 u) const;
  bool eye_survive(RgbEye& c, float u, float* survival) const;
  // The BSDF at an eye vertex (Scene::bsdf); spectral: also the material at the pass's
  // wavelengths, from the same run of its node graph.
  Bsdf eye_bsdf(RgbEye& c, const SurfaceHit& hit) const;
  Bsdf eye_bsdf(SpectralEye& c, const SurfaceHit& hit) const;
  // The Transparent BSDF closures' weight at the hit per channel (Bsdf::transparency; spectral:
  // at each wavelength).
  ChannelValues eye_transparency(RgbEye& c, const SurfaceHit& hit, const Bsdf& bsdf) const;
  ChannelValues eye_transparency(SpectralEye& c, const SurfaceHit& hit, const Bsdf& bsdf) const;
  RGB eye_nee(SpectralEye& c, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo, float u_light,
              const Vec2& u2, int64_t& rays, const ShadowTest* shadow) const;
  std::optional<BsdfSample> eye_scatter(SpectralEye& c, const SurfaceHit& hit, const Bsdf& bsdf,
                                        const Vec3& wo, float uc, Vec2 u) const;
  bool eye_survive(SpectralEye& c, float u, float* survival) const;
  // Factor on every photon estimate: V_c of eq. 8.11 with the adaptive sampler, else 1.
  double photon_scale() const { return adaptive_ ? adaptive_->vc() : 1.0; }
  void update_error_estimate();
  // The end of a photon pass, shared by SPPM and GPM: the pass counted, the error estimate
  // updated, the update's time and the pass's statistics (rays and invalid samples of its own
  // besides the photons') added.
  void end_pass(std::chrono::steady_clock::time_point t_update, const PhotonPassStats& ps, int64_t rays,
                int64_t invalid);
  // The Laplacian, B'_i and its standard error of pixel k (the rest of ErrorTerms left 0).
  ErrorTerms bias_estimate(size_t k) const;
  // cut, edge_bias and edge_bias_sd of pixel k into e (e.radiance set).
  void edge_bias(size_t k, ErrorTerms& e) const;
  // Reads parameter film_transparent (PPM, SPPM: their eye passes, RGB and spectral, write
  // the alpha pass with it, and on a scene that holds out: writes_alpha).
  void read_film_transparent(const Params& params) {
    film_transparent_ = params.get<bool>("film_transparent");
    writes_alpha_ = writes_alpha(film_transparent_, scene_);
  }

  // ---- Spectral photons (progressive_photon_spectral.cpp) ----
  // One set of wavelengths per pass, shared by its eye paths and photons.
  SampledWavelengths pass_wavelengths(uint64_t pass) const;
  bool spectral_eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause, std::atomic<int64_t>& rays,
                         std::atomic<int64_t>& invalid);
  PhotonPassStats spectral_trace(uint64_t pass, const std::function<bool()>& cancelled);
  // The gathers poll the cancel check every this many pixels (2 M at 1080p).
  static constexpr size_t kCancelPollPixels = 4096;
  void spectral_gather(const std::function<bool()>& cancelled);
  // sample_to_rgb is linear: RGB of a unit value at wavelength k of this pass's set.
  RGB spectral_to_rgb(const SpectralValues& v) const {
    RGB out(0.0f);
    for (int k = 0; k < wl_.count; ++k) out += wl_basis_[k] * v[k];
    return out;
  }
  struct SpectralPhoton {
    Photon photon;
    SpectralValues power;
    bool hero_only;  // went through a smooth dispersive refraction: only the hero is left
  };
  bool spectral_ = false;
  std::unique_ptr<SceneSpectra> spectra_;
  std::vector<std::vector<SpectralPhoton>> spectral_volume_chunks_;  // volume photons, per chunk

  // ---- Participating media: volume photons and the beam radiance estimate (thesis §5.6) ----
  // Statistics are kept per pixel, one cylinder radius for all of a pixel's camera segments
  // through media, as SPPM keeps one disc per pixel (ch. 7's shared statistics): SPPM's camera
  // path, and so its segments, change every pass, so a per-segment radius would have no history
  // to shrink from; per pixel, the passes' segments are samples of the pixel's beam as the passes'
  // measurement points are samples of its surface, and eq. 5.39 holds for any query shape.
  bool media_ = false;
  CameraMedia camera_media_;                // the media eye paths start in (paths/medium_stack.h)
  std::vector<MediumChannels> media_rgb_;   // Scene::media at R, G, B
  std::vector<MediumChannels> pass_media_;  // and at the pass's wavelengths (spectral photons)
  std::vector<EyeBeam> beams_;              // kMaxBeams per pixel, this pass's (PPM: the first's)
  std::vector<uint8_t> n_beams_;
  std::vector<float> first_vr_;             // footprint radius proposed for the cylinder (at the first beam's middle)
  std::vector<Photon> volume_photons_;      // this pass only, as photons_
  std::vector<SpectralValues> volume_power_;  // spectral: by volume photon index
  std::vector<uint8_t> volume_hero_;
  PhotonHashGrid volume_grid_;
  std::vector<float> gather_vm_;
  std::vector<RGB> gather_vphi_;
  int channels() const { return spectral_ ? wl_.count : 3; }
  const MediumChannels& medium_channels(int m) const { return spectral_ ? pass_media_[m] : media_rgb_[m]; }
  // The beam radiance estimate of every pixel's segments from this pass's volume photons.
  void volume_gather(uint64_t pass, const std::function<bool()>& cancelled);
  // V(u) of the adaptive sampler for volume photons: near this pass's segments.
  BeamVisibility beam_visibility_;
  void build_beam_visibility(const std::function<bool()>& cancelled);
  // The eye pass's segments of `pixel` (and its first cylinder radius).
  void store_beams(size_t pixel, const EyeEnd& end, Vec2 half_extent);
  SampledWavelengths wl_;
  bool dispersive_ = false;                 // a material disperses: paths may be hero-only (pass_wavelengths)
  std::array<RGB, kMaxWavelengths> wl_basis_;
  SpectraAtWavelengths pass_spectra_;       // materials and lights at wl_
  std::vector<SpectralValues> vp_beta_;     // eye throughput per pixel at wl_ (hero-only: x C)
  std::vector<uint8_t> vp_hero_;            // eye path is hero-only
  std::vector<SpectralValues> photon_power_;  // by photon index
  std::vector<uint8_t> photon_hero_;
  std::vector<std::vector<SpectralPhoton>> spectral_chunks_;

  const Scene& scene_;
  bool retrace_, nee_;
  double alpha_, radius_, footprint_pixels_, confidence_;
  int64_t photons_per_pass_;  // 0: auto_photons_per_pass
  int64_t photons_for_pass(uint64_t pass) const {
    return photons_per_pass_ > 0 ? photons_per_pass_ : auto_photons_per_pass(width_, height_, pass);
  }
  PhotonHashMode hash_mode_;
  int max_depth_, rr_depth_, threads_, tile_size_;
  float threshold_;
  uint64_t seed_;
  int width_, height_;
  // Initial radius from the pixel footprint: the cone one pixel subtends, grown along the eye
  // path to the gather point (a ray-cone stand-in for ray differentials), `footprint` pixels
  // wide. One rule for SPPM and the methods built on it (GPM's primal is SPPM's image).
  float footprint_radius(float path_length) const { return footprint_radius(path_length, scene_.camera.half_extent()); }
  float footprint_radius(float path_length, Vec2 half_extent) const {
    return static_cast<float>(footprint_pixels_) * scene_.camera.pixel_footprint(path_length, half_extent);
  }
  // First radius of every pixel whose gather point is new: `radius` if given, else its
  // footprint (first_r_), never below a scene-relative floor. Pixels with a radius keep it.
  void set_initial_radii();

  PhotonTracer tracer_;
  std::unique_ptr<AdaptivePhotonSampler> adaptive_;  // photon_sampler = adaptive (thesis ch. 8)
  VisibilityGrid visibility_;                         // this pass's measurement points, for V(u)
  std::vector<VisibilityGrid::Point> visibility_points_;
  PhotonHashGrid grid_;
  std::vector<Photon> photons_;        // this pass only; cleared (capacity kept) every pass
  std::vector<VisiblePoint> vp_;
  std::vector<RGB> pass_direct_;       // this pass's eye-path light per pixel
  std::vector<float> pass_covered_;  // this pass's camera ray hit the scene (1; 1 - a mixed holdout's weight) or escaped (0)
  bool film_transparent_ = false;
  bool writes_alpha_ = false;  // develop() writes pass alpha (read_film_transparent)
  std::vector<float> first_r_;         // footprint radius proposed by the eye pass
  std::vector<PixelState> px_;
  std::vector<float> gather_m_, gather_lap_;
  std::vector<std::array<float, 3>> gather_boundary_;  // other surfaces' flux, own flux's first moment (u, v)
  std::vector<RGB> gather_phi_;
  bool have_points_ = false;
  // ---- The open pass, between calls of iterate() that paused (only before the first pass
  // ends: a pause in a later pass would show the image of the passes before it again) ----
  enum class Stage { Eye, Photons, Gather };
  Stage stage_ = Stage::Eye;           // what the open pass does next
  PausableTiles eye_tiles_;             // the open eye pass's tiles
  PhotonPassStats open_ps_;            // its photons' figures, from Photons to Gather
  PassPause::Kept open_;  // an open pass's ray counts (PassPause)
  double estimated_error_ = INFINITY;
  double t_quantile_ = INFINITY;       // t(dof, 1 - beta/2) of the last pass (eq. 6.10)
  // error_bound = "thesis": eq. 6.12 as written (E_i + |B'_i|, B' with R_i^2 (eq. 6.19), t with
  // i dof); "calibrated" (default): B' with the mean of the passes' R_j^2 (eq. 6.18), t with i - 1
  // dof, and the bound at exactly the confidence for an error B' + noise, the noise of L_i and of
  // B' itself combined (FoldedNormalQuantile). docs/error-calibration.md measures both.
  bool thesis_bound_ = false;
  // error_bound = "boundary": "calibrated" plus the bias of gather discs cut by a geometric edge
  // (disc_shape's probe rays, record_error_sample's linear fit); opt-in for its cost (up to 1.5x
  // an SPPM pass, docs/benchmarks.md), which the default must not put on every render.
  bool boundary_bound_ = false;
  FoldedNormalQuantile folded_;
  double t_over_z_ = 1;               // t(dof, 1 - beta/2) / z(1 - beta/2)
  std::vector<double> bias_cut_;       // bias_significance_cut(n) for n = 0 .. passes
  double significance_cut(uint32_t n) const { return n < bias_cut_.size() ? bias_cut_[n] : bias_significance_cut(n); }
  std::vector<float> error_;           // per-pixel relative bound (eq. 6.13)
  int64_t emitted_total_ = 0;
};

// The RGB eye path (trace_eye's colour): throughput beta, light Ld the path saw itself.
struct RgbEye {
  RGB beta{1.0f}, Ld{0.0f};
  const std::vector<MediumChannels>* media = nullptr;  // the scene's media at R, G, B (media only)
  void environment(const RGB& Le, int) { Ld += beta * Le; }
  void area_light(const RGB& Le, int, const LightSet&) { Ld += beta * Le; }
  RGB vp_beta() const { return beta; }
  // ---- Participating media (trace_eye) ----
  int channels() const { return 3; }
  const MediumChannels& medium_channels(int m) const { return (*media)[m]; }
  ChannelValues channel_weights() const { return {beta.r, beta.g, beta.b}; }
  void medium_weight(const ChannelValues& w) { beta *= RGB(w[0], w[1], w[2]); }
  void medium_emission(const ChannelValues& e) { Ld += beta * RGB(e[0], e[1], e[2]); }
  bool is_hero_only() const { return false; }
  void transparent_weight(const ChannelValues& t, const RGB&) { medium_weight(t); }  // t is RGB here
};

template <class Colour, class Hooks>
ProgressivePhotonMapping::EyeEnd ProgressivePhotonMapping::trace_eye(Ray ray, Rng& rng, int64_t& rays, Colour& c,
                                                                      Hooks& hooks,
                                                                      const std::optional<SurfaceHit>* first,
                                                                      bool emission_only) const {
  const LightSet& lights = scene_.light_set();
  EyeEnd out;
  // The kind of the ray being traced, for the lights' and the World's Ray Visibility: the camera,
  // then the lobe of the last bounce (a light object crossed keeps it, as in the path tracer).
  uint8_t kind = kRayCamera;
  constexpr int kMaxCrossings = 8;  // light objects and volume boundaries crossed without a bounce
  int crossings = 0;
  // The media the path is in (Cycles' volume stack), only where the method renders media.
  MediumStack stack = media_ ? camera_media_.at(scene_, ray) : scene_.initial_medium_stack();
  ShadowTest shadow(scene_, media_ ? &stack : nullptr);
  for (int depth = 0; depth < max_depth_; ++depth) {
    ++rays;
    const std::optional<SurfaceHit> traced = first ? std::nullopt : scene_.intersect(ray);
    const std::optional<SurfaceHit>& hit = first ? *first : traced;
    first = nullptr;
    // ---- Participating media along the segment: its emission integrated exactly, a beam for
    // the volume photons (the beam radiance estimate, volume_gather), and its transmittance to
    // the surface behind it (no free flight: the photons carry the light scattered in it) ----
    if (media_ && !stack.empty()) {
      const MediumSegment segment(stack, ray, c.channels(),
                                  [&](int m) -> const MediumChannels& { return c.medium_channels(m); });
      const float t_end = hit ? hit->t : kInfinity;
      c.medium_emission(segment.emission_integral(t_end));
      if (segment.scatters && out.n_beams < kMaxBeams) {
        out.beams[out.n_beams++] = make_beam(ray, t_end, c.channel_weights(), stack, c.is_hero_only());
        if (out.n_beams == 1)  // the middle of the first beam (of a World medium: within the scene)
          out.beam_length = out.path_length + 0.5f * std::min(t_end, length(scene_.bounds().diagonal()));
      }
      c.medium_weight(segment.transmittance(t_end));
    }
    // Emission seen along the camera path: only at depth 0 or after specular/glossy bounces,
    // which no photon covers, so nothing is counted twice.
    if (!hit) {
      const int env = lights.environment();
      if (depth == 0 && (film_transparent_ || ray.held_out)) {  // a holdout: black
        out.escaped = true;  // after transparent bounces only: no background, alpha 1 - transparency
        out.transparent = path_transparency(c);
      }
      else if (env >= 0 && lights.lights()[env].visible_to(kind)) c.environment(lights.environment_radiance(ray), env);
      break;
    }
    out.path_length += hit->t;
    if (hit->light >= 0 && lights.lights()[hit->light].visible_to(kind))
      c.area_light(lights.area_radiance(hit->light, -ray.d), hit->light, lights);
    if (transparent_done(scene_.transparent_bounces, ray.state)) break;  // Light Paths > Transparent (medium_walk.h)
    const Bsdf bsdf = eye_bsdf(c, *hit);
    if (bsdf.is_black()) break;
    const Vec3 wo = hit->frame.to_local(-ray.d);
    if (wo.z == 0) break;
    hooks.vertex(*hit, wo, bsdf);
    bool measure = bsdf.is_diffuse_for_photons(threshold_);
    // A photon-diffuse surface with a Transparent BSDF in its mix (a leaf's Alpha: Cycles' Mix of
    // a Transparent BSDF and the rest): with probability q, the closure's mean weight, the path
    // passes straight through (a transparent bounce, weight T / q per channel, as a BSDF sample
    // of that closure), else it is measured here weighted 1 / (1 - q) (the measurement and its
    // NEE evaluate the other closures only). Without this the mix's see-through part was lost.
    // q is the RGB weight's mean in the spectral eye too (bsdf: eye_bsdf's RGB BSDF), as Cycles
    // picks the closure: the pass's RGB weight is then 1 / q times the closure's colour, whose
    // mean, the path's transparency (RgbTransparency), is 1, never above it; the wavelengths'
    // mean (used before) left a green pane's mix weight above 1, clamped, alpha 0.85 for 0.75.
    std::optional<BsdfSample> through;
    if (measure && scene_.material(hit->material).transparent_shadow()) {
      ChannelValues T = eye_transparency(c, *hit, bsdf);
      const RGB rgb = bsdf.transparency();
      float mean = 0;
      for (const float t : {rgb.r, rgb.g, rgb.b}) mean += t;
      const float q = std::min(mean / 3, 0.999f);
      if (q > 0.0f) {
        if (rng.uniform() < q) {
          for (int k = 0; k < c.channels(); ++k) T[k] /= q;
          c.transparent_weight(T, rgb * (1.0f / q));
          BsdfSample pass;
          pass.f = RGB(1.0f);
          pass.wi = -wo;
          pass.pdf = 1.0f;
          pass.delta = pass.transmission = true;
          pass.lobe = kRayTransmission;
          through = pass;
          measure = false;
        } else {
          ChannelValues w;
          w.fill(1.0f / (1.0f - q));
          c.medium_weight(w);
        }
      }
    }
    if (measure) {
      if (emission_only) break;
      // ---- Measurement point; direct light by NEE when photons skip it ----
      if (nee_ && !lights.empty()) {
        const float u_light = rng.uniform();
        const Vec2 u2(rng.uniform(), rng.uniform());
        if (media_) shadow.at_surface(hit->mesh, scene_.material(hit->material).interior, hit->ng, ray.d);
        hooks.nee(u_light, u2, eye_nee(c, *hit, bsdf, wo, u_light, u2, rays, media_ ? &shadow : nullptr));
      }
      out.vp.p = hit->p;
      out.vp.frame = hit->frame;
      out.vp.wo = wo;
      out.vp.beta = c.vp_beta();
      out.vp.material = hit->material;
      out.vp.uv = ShadePoint(*hit);
      out.vp.ng = hit->ng;
      out.vp.n_smooth = hit->n_smooth;
      hooks.gather(*hit);
      break;
    }
    // ---- Specular or glossy vertex (or a transparent pass drawn above): continue by BSDF sampling ----
    std::optional<BsdfSample> bs = through;
    if (!bs) {
      const float uc = rng.uniform();
      const Vec2 u(rng.uniform(), rng.uniform());
      bs = eye_scatter(c, *hit, bsdf, wo, uc, u);
    }
    if (!bs) break;
    const Material& material = scene_.material(hit->material);
    // A light object, a volume boundary (a clear Transparent BSDF, which shadow rays pass
    // filtered, is a transparent bounce below).
    const bool crossed = material.is_pass_through() && !material.transparent_shadow();
    const Vec3 wi_world = hit->frame.to_world(bs->wi);
    // A sample through a surface with an interior medium (glass of murky water) crosses it.
    if (media_ && material.interior >= 0 && (dot(wi_world, hit->ng) < 0) == (dot(ray.d, hit->ng) < 0))
      stack.cross(hit->mesh, material.interior, dot(ray.d, hit->ng) < 0);
    const Ray next = scattered_ray(hit->p, hit->ng, wi_world, ray, crossed, *bs);
    // Neither a light object crossed nor a Transparent BSDF's pass is a bounce (as in
    // paths/camera_path.h: Cycles counts the latter against Light Paths > Transparent only).
    const bool transparent = !crossed && is_transparent_pass(*bs);  // scattered_ray keeps its kind
    if (!crossed && !transparent) kind = bs->lobe;
    hooks.scatter(wo, *bs, next);
    ray = next;
    if (transparent || (crossed && ++crossings <= kMaxCrossings)) --depth;
    if (depth + 1 >= rr_depth_) {
      float survival = 1.0f;
      if (!eye_survive(c, rng.uniform(), &survival)) break;
      hooks.roulette(survival);
    }
  }
  return out;
}

// The RGB eye path's estimator at the measurement point, at a bounce and at roulette.
inline RGB ProgressivePhotonMapping::eye_nee(RgbEye& c, const SurfaceHit& hit, const Bsdf& bsdf, const Vec3& wo,
                                             float u_light, const Vec2& u2, int64_t& rays,
                                             const ShadowTest* shadow) const {
  const RGB d = c.beta * direct_light(scene_, hit, bsdf, wo, u_light, u2, rays, shadow, &media_rgb_);
  c.Ld += d;
  return d;
}
inline std::optional<BsdfSample> ProgressivePhotonMapping::eye_scatter(RgbEye& c, const SurfaceHit&, const Bsdf& bsdf,
                                                                       const Vec3& wo, float uc, Vec2 u) const {
  const auto bs = bsdf.sample(wo, uc, u);
  if (!bs || bs->pdf <= 0 || bs->f.is_black()) return std::nullopt;
  c.beta *= bs->f * (std::abs(bs->wi.z) / bs->pdf);
  return bs;
}
inline Bsdf ProgressivePhotonMapping::eye_bsdf(RgbEye&, const SurfaceHit& hit) const { return scene_.bsdf(hit); }
inline ChannelValues ProgressivePhotonMapping::eye_transparency(RgbEye&, const SurfaceHit&, const Bsdf& bsdf) const {
  const RGB t = bsdf.transparency();
  return {t.r, t.g, t.b};
}
inline bool ProgressivePhotonMapping::eye_survive(RgbEye& c, float u, float* survival) const {
  return russian_roulette(c.beta, u, survival);
}

template <class Hooks>
ProgressivePhotonMapping::EyePath ProgressivePhotonMapping::trace_eye_path(Ray ray, Rng& rng, int64_t& rays,
                                                                           Hooks& hooks,
                                                                           const std::optional<SurfaceHit>* first,
                                                                           bool emission_only) const {
  RgbEye c;
  c.media = &media_rgb_;
  const EyeEnd end = trace_eye(ray, rng, rays, c, hooks, first, emission_only);
  EyePath out;
  out.Ld = c.Ld;
  out.vp = end.vp;
  out.path_length = end.path_length;
  out.escaped = end.escaped;
  out.transparent = end.transparent;
  return out;
}

}  // namespace gp
