// Multisampled progressive photon mapping (MSPPM): Hachisuka, "Progressive density estimation"
// thesis ch. 9, after Hachisuka, Pantaleoni and Jensen, "A path space extension for robust light
// transport simulation" (2012). Photon density estimation and path tracing with next-event
// estimation combined by multiple importance sampling over full path densities.
//
// Every iterate():
//   1. one camera path per pixel, traced to Russian-roulette termination (§9.5 step 2), with a
//      measurement point at every non-delta vertex (glossy ones included: no diffuse/glossy
//      classification, the weights decide, §9.6); along the same path
//      and n_pt - 1 more (see "Sample counts"), path tracing: emission hit by the path and
//      next-event estimation at every non-delta vertex (§9.5 step 5), each weighted by the
//      balance heuristic;
//   2. one photon pass, photons deposited at every non-delta vertex from the first hit on, whole
//      photon paths recorded
//      (§9.5 step 1, PhotonPathRecord);
//   3. every measurement point gathers the photons within its pixel's radius; each photon's
//      flux, through the BSDF's lobes it may light (Cycles' per-kind switches, Method::lobe_visibility)
//      and with a normal map's bent cosine (gather_shading_correction), as SPPM's gather, is
//      weighted by the balance heuristic for the full path it closes (§9.5 step 4);
//      radius, count and flux of the pixel follow SPPM (eq. 7.2-7.5, shared by all the
//      measurement points of the pixel).
//
// Passes: combined, radius, photon_count, and path_tracing: the balance-weighted path-tracing
// part of combined (thesis Fig. 9.10); combined minus it is the density-estimation part.
//
// Techniques for a path y_1 .. y_k (y_k on a light; y_0 the camera): hit (the camera path
// samples every vertex), nee (light sample at y_k from y_{k-1}), and density estimation at
// every non-delta y_t, 1 <= t < k (camera samples y_1..y_t, photon y_k..y_t). With the
// path densities of eq. 9.6-9.8 as products of per-vertex area densities E_i (camera side) and
// L_i (light side),
//   q_hit = prod_{i<=k} E_i,   q_nee = prod_{i<k} E_i * p_light(y_k),
//   q_pm(t) = N_e pi R^2 * prod_{i<=t} E_i * prod_{i>=t} L_i,
// and the weight of a technique is n_i p_i / sum_k n_k p_k (eq. 9.5; eq. 9.19 with the bias
// term ignored, which the thesis justifies for alpha < 2/3, eq. 9.25). Where the photon
// technique's two vertices differ (|x_eye - x_photon| <= R), camera-side densities use the
// camera vertex and light-side ones the photon's neighbours (the heuristic of Fig. 9.3).
// Russian-roulette probabilities are left out of the densities (any weights that sum to one
// over the techniques that can make a path keep the combination consistent).
//
// Incremental weights (eq. 9.5 for density estimation in O(1) per gathered photon). With
// PE[s] = prod_{i<=s} E_i, SL[s] = prod_{i>=s} L_i and m_s = 1 where y_s is not delta,
//   1 / w_t = sum_s q(s) / q(t) = (L_{t-1} / E_t) B_{t-1} + R_t, where
//   B_j = m_j + (L_{j-1} / E_j) B_{j-1},  B_0 = 0                       (camera side)
//   R_j = m_j + (E_{j+1} / L_j) R_{j+1}                                   (light side)
//   R_{k-1} = m_{k-1} + (E_k [hit possible] + p_nee [y_{k-1} not delta]) / (n_pm L_{k-1} L_k).
// E_i needs y_{i-2}, L_i needs y_{i+2}; so c_j = B_{j-1} / E_j depends on camera vertices only
// (camera_prefix, once per pixel and pass), and R_j for j >= t + 2 on the photon's vertices only
// (photon_tails, once per photon path vertex when photons are traced, kept as P + H / n_pm since
// n_pm is per pixel). Only the densities next to the merge involve both sides: E_{t+1} and
// L_{t-1} (BSDF of the camera vertex y_t towards / from the photon's previous vertex y_{t+1}),
// L_t and E_{t+2} (BSDF of y_{t+1} towards / from y_t): four direction densities per photon
// whatever the path length, instead of the 2k of the full walk (mis_weight, kept as the
// test's reference). The hit and NEE samples use the same camera prefix (light_weight). Photons at their first or second hit end
// in R_{k-1} (emission densities of the light). A zero factor of q(t) makes a ratio infinite
// or NaN and the weight 0, as in the full walk. The path and its densities are those of the
// full walk (same Fig. 9.3 composition: camera vertices to y_t, then the photon's earlier
// vertices), so the weights are the same up to rounding and still sum to one.
//
// Sample counts (§9.4.4-9.4.5, §9.5 step 5): with alpha = 0.6 < 2/3 the unbiased techniques must
// take N'(N) = N^alpha samples for N photon passes (eq. 9.23), which §9.4.5 meets by taking as
// many path-tracing samples at a pixel as it finds photons, the local photon count being
// O(N^alpha). Per pass and pixel: n_pt = round(M), clamped to [1, path_samples_max], where
// M = (photons found in the pixel's earlier passes / sum of their R^2) * R^2 is the number of
// photons the pixel can expect to find with this pass's radius (the count of step 3, known
// before the pass; the realised count would make the weights depend on the photons they
// weight, E[M w(M)] != E[M] E[w], a bias that does not average out). The first of the n_pt
// samples is the camera path carrying the measurement points, the others are path-tracing-only
// camera paths (own random stream); the pass's PT estimate is their mean, (1 / n_i) sum_j
// w_i f / p_i (eq. 9.5). Every weight of the pass, hit and NEE in the camera pass and density
// estimation in the gathering, uses the counts n_hit = n_nee = n_pt and n_pm = N_e pi R^2
// (eq. 9.19 with the bias ignored); they enter only as the ratio n_pm / n_pt, which is the
// `n_pm` argument of light_weight and merge_weight (mis_weight takes both). n_pt is at least 1
// so that paths no photon can make (a light seen directly or through glass) keep a sample in
// every pass. path_samples = k > 0 takes k samples per pass instead (k = 1: one per pass, as
// the per-pass eye tracing of §9.5's last paragraph and as this integrator did before).
//
// Participating media (issue 32; homogeneous and grid media, scenes that have them only). The
// camera paths follow the media as SPPM's eye paths do (no free flights: photons carry the light
// scattered in media): each segment's emission is integrated (weight 1, no other technique finds
// it), its transmittance multiplies the throughput, the volume stack follows volume boundaries
// and glass, and next-event estimation goes through the shared ShadowTest (paths/medium_walk.h),
// whose transmittance multiplies the light. Photons are the one photon walk's (photon_walk.h):
// free flights, volume photons at every scattering point in a medium, surface photons with the
// media's pass weights; the record keeps each scattering point in a medium as a `medium` vertex.
//
// The weights' volume form. For a path whose vertex y_t lies in a medium, the beam radiance
// estimate (thesis §5.6, eqs. 5.37-5.39) is density estimation at y_t with a cylinder of radius
// R_v as kernel: the camera samples the line from y_{t-1} towards y_t, per unit area across the
// segment E_t = p(y_{t-1}: y_{t-2} -> y_t) / d^2 (no cosine: y_t is no surface), the photon
// samples the point y_t per unit volume, L_t = p(y_{t+1}: y_{t+2} -> y_t) p_ff(d') / d'^2
// (p_ff the free flight's distance density), and the kernel's cross-section is pi R_v^2:
//   q_beam(t) = N_e pi R_v^2 prod_{i<=t} E_i prod_{i>=t} L_i,
// the surface's q_pm(t) of eq. 9.6-9.8 with those densities at y_t. The camera path takes no
// free flights, so E_{t+1} = 0: no technique that needs the camera to scatter at y_t (merges
// past it, hit, NEE) makes the path, and the incremental sums above give
//   1 / w_beam(t) = 1 + (R^2 / R_v^2) (L_{t-1} / E_t) B_{t-1},
//   L_{t-1} / E_t = f_phase(y_t: y_{t+1} -> y_{t-1}) |cos at y_{t-1}| / p(y_{t-1}: y_{t-2} -> y_t),
// (the d^2 cancel), while a surface merge at s < t with a photon that scattered at y_t needs the
// beam's term in its light-side sum, R_t = R_v^2 / R^2, carried down its tail (a third sum beside
// P and H, photon_tails). That is not built yet. What is built is the partition SPPM makes, which
// needs no densities in media: a path with a medium vertex is taken, with weight 1, by density
// estimation at the camera path's first mergeable vertex -- the first non-delta surface, if the
// camera reaches it before any medium vertex (a surface photon that scattered in a medium,
// PhotonTail::through_medium), else the beam at the first medium vertex, reached through delta
// vertices only (volume photons gathered along the pixel's beams: segments through scattering
// media before the first mergeable vertex, at most kMaxBeams, beam_estimate.h, with a progressive
// cylinder per pixel as SPPM's, eq. 5.39). Every such path has exactly one such vertex. Paths
// without a medium vertex keep the weights above; their densities leave out the transmittance
// and the free flights' pass probabilities, which makes the weights less than optimal but still a
// function of the path that sums to one over the techniques that make it, so the combination
// stays unbiased.
//
// Transparent BSDFs (issue 30): next-event estimation passes a surface with a Transparent BSDF
// filtered by its transparency, as pt's (ShadowTest, up to transparent_bounces). So that each
// path has one set of vertices for all techniques, such a surface is no vertex of the paths that
// go on through it: the camera path's sample through it (EyeVertex::crossed) leaves it out of the
// camera prefix, and the photon's (PhotonPathVertex::crossed) out of its tail. It stays the end
// of the paths that merge at it (a Mix with a diffuse part).
//
// Parameters: declared once, with their defaults, ranges and equations, in methods.cpp
// (`gradphoton methods msppm`, docs/methods.md#msppm).
//
// Passes: combined, radius, photon_count. Statistics: path tracing samples (total, and per pixel
// and pass), photons traced/stored, photon rays,
// average radius, measurement points per pixel, photons found per point, the share of the
// image from each family of techniques ("path tracing share"), seconds in the camera pass,
// photon pass (with the tails) and gathering ("eye / trace / lookup seconds"), the largest
// over the mean radius of the gathering pixels (it sets the hash grid's cells), and with media
// "volume photons stored" and "average cylinder radius", as SPPM's.
#pragma once

#include <vector>

#include "integrators/paths/medium_stack.h"
#include "integrators/photon/beam_estimate.h"
#include "integrators/photon/pausable_tiles.h"
#include "integrators/photon/photon_hash.h"
#include "integrators/integrator.h"
#include "integrators/photon/photon_tracer.h"

namespace gp {

class Msppm : public Integrator {
 public:
  Msppm(const Scene& scene, const Params& params);
  std::string name() const override { return "msppm"; }
  // Lights', the World's and surfaces' per-kind switches, as SPPM: the camera paths' bounce rays
  // pass surfaces hidden from their kind, emission they find counts when the light is visible
  // to that kind (from a light hidden from some kinds, by the lobes that see it: f_V / p_V),
  // next-event estimation lights only those lobes, photons follow photon_tracer.cpp's rule and
  // the gather evaluates their lobes. The weights take the vertex before a light with the
  // light's lobes (msppm_detail::light_lobes) and every other vertex with all of them: any
  // weights that sum to one over the techniques that can make a path keep the combination
  // unbiased, and a surface's switches leave every technique able to make the paths the others
  // make, but one: next-event estimation does not see a light through a surface hidden from
  // some kinds that casts shadows, whose light the other techniques then count only in part
  // (docs/blender.md: the path tracer, as Cycles, counts only its BSDF rays' MIS share).
  void iterate(ProgressSink* sink) override;
  void develop(Film& film) const override;
  RGB pixel_radiance(size_t i) const;
  // Last pass, per pixel: the path-tracing samples traced, and the path-tracing count n_pt that
  // the weights used (N_e pi R^2 / the ratio passed to light_weight / merge_weight). Equal.
  int path_samples_traced(size_t i) const { return pass_traced_[i]; }
  double path_samples_in_weights(size_t i) const { return pass_npm_[i] > 0 ? pass_npm_full_[i] / pass_npm_[i] : 0.0; }
  double photons_found(size_t i) const { return gather_m_[i]; }

  // One vertex of a full path for the density evaluation (camera, surface or light vertex).
  struct PathVertex {
    Vec3 p, ng;
    const Frame* frame = nullptr;
    int material = -1;
    Vec2 uv;  // texture coordinate there (Scene::bsdf)
    bool delta = false;      // specular BSDF
    bool mergeable = false;  // not delta: density estimation possible here (§9.6)
    int light = -1;          // light vertex: its light
    bool distant = false;    // light vertex of a sun / environment: `dir` is the light's direction of travel
    Vec3 dir;
  };
  // Balance-heuristic weight of technique `technique` (0 = hit, 1 = nee, 2 + t = density
  // estimation at y_t) for the path y[0] (camera) .. y[k] (light), k = y.size() - 1. Walks the
  // whole path (O(k) BSDF densities): no longer used by rendering, kept as the reference that
  // the O(1) merge_weight() and light_weight() are tested against.
  // n_pm = N_e pi R^2 samples of each density-estimation technique, n_pt samples of each of hit
  // and NEE (the n_i of eq. 9.19).
  double mis_weight(const std::vector<PathVertex>& y, int technique, double n_pm, double n_pt = 1.0) const;

  // ---- O(1) weight of density estimation (see "Incremental weights" above) ----
  // Per deposited photon, from its own path only: y_{t+1} (the photon's previous vertex, its
  // light vertex for a photon at its first hit), the unit direction from it to y_{t+2}, and the
  // light-side sums that R_{t+1} = P + H / n_pm needs besides the densities at y_{t+1}:
  //   P = m_{t+1} + p_rev A_P,   H = p_rev A_H + B_H,
  // p_rev the direction density at y_{t+1} from y_t towards y_{t+2}.
  struct PhotonTail {
    Vec3 p, ng;       // y_{t+1}
    Frame frame;
    Vec3 to_next;     // depth >= 2: towards y_{t+2}; depth 1 (light vertex): its `dir`
    double A_P = 0, A_H = 0, B_H = 0;
    int material = -1, light = -1;
    Vec2 uv;  // texture coordinate there (Scene::bsdf)
    uint8_t lobes = kAllLobes;  // those its densities take (msppm_detail::light_lobes at depth 2)
    int depth = 0;    // segments from the light to the deposit (d = k - t)
    bool delta = false, mergeable = false, distant = false;
    // The photon scattered in a medium before this deposit: no densities (depth 0); the gather
    // counts it only at the camera path's first mergeable vertex ("Participating media").
    bool through_medium = false;
  };
  // Fills tails[i] for the i-th deposit of `record` (resized to its deposit count).
  void photon_tails(const PhotonPathRecord& record, std::vector<PhotonTail>& tails) const;
  // Camera side: c[j] = B_{j-1} / E_j for j = 1 .. n of the camera path y[0] (camera) ..
  // y[n] (c[0] unused); needs only the camera path.
  void camera_prefix(const PathVertex* y, int n, double* c) const;
  // Weight of density estimation at camera vertex y[t] (mergeable) with the photon whose tail
  // is `tail`: the path y_0 .. y_t, then the photon's earlier vertices. Equals mis_weight() of
  // that full path for technique 2 + t (up to rounding).
  // `n_pm` here and in light_weight: the ratio n_pm / n_pt of the two sample counts (eq. 9.19
  // depends on them only through it); equals mis_weight(..., n_pm * n_pt', n_pt') for any n_pt'.
  double merge_weight(const PathVertex* y, int t, const double* c, const PhotonTail& tail, double n_pm) const;
  // Weight of technique 0 (hit) or 1 (nee) for the camera path y[0] .. y[k-1] ending on the
  // light vertex y[k] (k = y.size() - 1), in O(1) from c_{k-1} (camera_prefix's c[k-1]):
  // 1 / w = (q_hit + q_nee + sum_s q(s)) / q_technique, all over PE[k-1], with
  // sum_s q(s) / PE[k-1] = n_pm L_{k-1} L_k (m_{k-1} + L_{k-2} c_{k-1}). Equals mis_weight().
  double light_weight(const std::vector<PathVertex>& y, int technique, double c_last, double n_pm) const;
  // A recorded photon-path vertex as a path vertex.
  PathVertex photon_path_vertex(const PhotonPathVertex& v, bool mergeable) const;

 private:
  struct EyeVertex {
    Vec3 p, ng, wo;  // wo: unit world direction towards the previous vertex
    Vec3 n_smooth;   // the unmapped normal: with ng, a normal map's bump shadowing (Scene::bsdf)
    Frame frame;
    RGB beta;        // camera-path throughput up to this vertex
    int material = -1;
    Vec2 uv;  // texture coordinate there (Scene::bsdf)
    bool delta = false, mergeable = false;
    // The path went on through a Transparent BSDF here as shadow rays do: a vertex only of the
    // paths that end here (msppm_weights.cpp), not of those that go on.
    bool crossed = false;
  };
  struct PixelState {
    double r2 = 0, n = 0;
    double tau[3] = {0, 0, 0};
    double direct[3] = {0, 0, 0};  // per pass the mean of its weighted path-tracing samples, summed
    double found_sum = 0, r2_sum = 0;  // photons found and R^2, summed over the passes that gathered
  };
  // The beam radiance estimate's cylinder radius, count and flux (thesis eq. 5.39, 5.12): scenes
  // with media only (vpx_), so that the others hold none of it.
  struct VolumeState {
    double vr2 = 0, vn = 0, vtau[3] = {0, 0, 0};
  };

  // A camera-path vertex as a path vertex for the weights (its frame by pointer: `e` outlives it).
  static PathVertex path_vertex(const EyeVertex& e);
  double n_pm(size_t pixel) const;  // N_e pi R^2 of the density-estimation technique
  // The camera paths of the pass over the tiles not done yet (PausableTiles: with `may_pause`,
  // it stops when the sink asks and returns false; the next call goes on).
  bool eye_pass(uint64_t pass, ProgressSink* sink, bool may_pause, std::atomic<int64_t>& rays,
                std::atomic<int64_t>& invalid);
  void photon_pass(uint64_t pass, PhotonPassStats& stats);
  // The beam radiance estimate of every pixel's beams from this pass's volume photons (media).
  void volume_gather(uint64_t pass);

  const Scene& scene_;
  double alpha_, radius_;
  int64_t photons_per_pass_;
  int max_depth_, rr_depth_, threads_, tile_size_;
  uint64_t seed_;
  int path_samples_, path_samples_max_;
  int width_, height_;

  PhotonTracer tracer_;
  PhotonHashGrid grid_;
  std::vector<Photon> photons_;
  std::vector<std::vector<PhotonTail>> chunk_tails_;  // per photon of chunk_photons_
  // Photon i's tail: chunk c holds photons_[tail_base_[c] .. tail_base_[c + 1]); tail_block_[b]
  // is the chunk of photon b * 2^kTailBlockBits.
  static constexpr int kTailBlockBits = 10;
  std::vector<size_t> tail_base_;
  std::vector<uint32_t> tail_block_;
  const PhotonTail& tail(uint32_t index) const;
  std::vector<std::vector<Photon>> chunk_photons_;
  // max_depth_ bounces and, in a scene with Transparent BSDFs that shadow rays pass, up to
  // transparent_bounces + 1 passes through them (transparent_done): a camera path's most vertices.
  int eye_stride_ = 0;
  // This pass's camera-path vertices, a list per tile (PausableTiles' order): its pixels' paths
  // one after the other, each as long as it went (not max_depth_ per pixel, which reserved
  // 1.8 kB per pixel for paths of a few vertices: docs/adaptive-and-msppm.md "Memory"); eye_at_[i]:
  // pixel i's first vertex in its tile's list.
  std::vector<std::vector<EyeVertex>> tile_eye_;
  std::vector<uint32_t> eye_at_;
  size_t tile_of(size_t pixel) const;
  const EyeVertex* eye_vertices(size_t pixel) const { return tile_eye_[tile_of(pixel)].data() + eye_at_[pixel]; }
  std::vector<int> eye_count_;
  std::vector<Vec3> eye_origin_;
  std::vector<RGB> pass_direct_;
  std::vector<double> pass_npm_;  // n_pm / n_pt = N_e pi R^2 / n_pt the camera pass weighted with; the gathering uses the same
  std::vector<double> pass_npm_full_;  // N_e pi R^2 of the pass
  std::vector<int> pass_npt_;     // n_pt: path-tracing samples of the pass, fixed before it
  std::vector<int> pass_traced_;  // path-tracing samples actually traced in the pass
  std::vector<float> first_r_;
  std::vector<PixelState> px_;
  std::vector<float> gather_m_;
  std::vector<RGB> gather_phi_;
  int64_t emitted_total_ = 0;
  double fallback_r_ = 0;

  // ---- Participating media ("Participating media" above; scenes with media only) ----
  static constexpr int kMaxBeams = 4;  // per pixel and pass, as SPPM's; further segments gather nothing
  bool media_ = false;
  CameraMedia camera_media_;  // the media eye paths start in (paths/medium_stack.h)
  std::vector<MediumChannels> media_rgb_;  // Scene::media at R, G, B
  std::vector<EyeBeam> beams_;             // kMaxBeams per pixel, this pass's
  std::vector<uint8_t> n_beams_;
  std::vector<VolumeState> vpx_;           // per pixel
  std::vector<float> first_vr_;            // footprint radius at the first beam's middle
  std::vector<Photon> volume_photons_;     // this pass's
  std::vector<std::vector<Photon>> chunk_volume_;
  PhotonHashGrid volume_grid_;
  std::vector<float> gather_vm_;
  std::vector<RGB> gather_vphi_;  // mean first-pass footprint radius, for pixels without their own

  // ---- The first pass, which pauses between eye tiles and between its stages when the sink
  // asks (ProgressSink::pause: Blender's F12 window shows develop()'s preview) and goes on at
  // the next call with the same random numbers; a later pass is one whole (a pause there would
  // show the passes before it again) ----
  enum class Stage { Start, Radii, Eye, Photons, Gather };
  Stage stage_ = Stage::Start;  // what the open pass does next
  PausableTiles eye_tiles_;
  PhotonPassStats open_ps_;
  PassPause::Kept open_;  // an open pass's ray counts (PassPause)
  // The first eye pass's path tracing, once it is whole: the preview until the first pass ends
  // (before radii exist path tracing takes weight 1, so it is a plain path-traced image).
  std::vector<RGB> preview_;
  bool first_pass_open() const { return stats_.passes == 0 && (stage_ != Stage::Start || eye_tiles_.open()); }
};

}  // namespace gp
