// The methods and their parameters, declared once (methods.h). A parameter shared by several
// methods is declared by one function below, so its name, type, description and panel are the
// same wherever it appears ("one name means one thing", DESIGN.md); a method passes its own
// default and, where it differs, its own range, symbol and equation.
#include "integrators/methods.h"

#include <algorithm>

#include "core/film.h"

#include "core/spectrum.h"
#include "integrators/gradient/gdmlt.h"
#include "integrators/gradient/gpm.h"
#include "integrators/gradient/gpt.h"
#include "integrators/path_tracer.h"
#include "integrators/photon/msppm.h"
#include "integrators/photon/ppm.h"
#include "integrators/photon/sppm.h"
#include "integrators/spectral/sgpt.h"
#include "integrators/spectral/spectral_pt.h"

namespace gp {

namespace {

// ---- Parameters of every image method ----
ParamDecl max_depth(int d) {
  return {.name = "max_depth", .type = ParamType::Int, .default_value = d, .min = 1, .label = "Max Depth",
          .description = "longest path in segments, the camera ray and the segment to a light included "
                         "(Cycles' bounces + 2)",
          .group = "Light Paths"};
}
ParamDecl rr_depth() {
  return {.name = "rr_depth", .type = ParamType::Int, .default_value = 3, .min = 0, .label = "Roulette Depth",
          .description = "bounces after which dim paths may end early (Russian roulette): lower is faster and noisier", .group = "Light Paths"};
}
ParamDecl seed() {
  return {.name = "seed", .type = ParamType::Int, .default_value = 0, .min = 0, .label = "Seed",
          .description = "random seed: another seed gives other noise", .shared = true, .group = "Performance"};
}
ParamDecl threads() {
  return {.name = "threads", .type = ParamType::Int, .default_value = 0, .min = 0, .label = "Threads",
          .description = "worker threads, 0 = all cores (images do not depend on it)", .shared = true,
          .group = "Performance"};
}
ParamDecl tile_size() {
  return {.name = "tile_size", .type = ParamType::Int, .default_value = 16, .min = 1, .label = "Tile Size",
          .description = "tile edge in pixels (scheduling only: images do not depend on it)", .shared = true,
          .group = "Performance"};
}
ParamDecls common() { return {seed(), threads(), tile_size()}; }

ParamDecl spectral(std::string read_when = "") {
  return {.name = "spectral", .type = ParamType::String, .default_value = "auto", .choices = {"auto", "rgb", "spectral"},
          .label = "Spectral",
          .description = "render by wavelength; auto: only when a material disperses light; rgb: never (dispersion ignored); spectral: always",
          .read_when = std::move(read_when), .shared = true, .group = "Rendering"};
}
ParamDecl wavelengths(int d, std::string read_when = "") {
  return {.name = "wavelengths", .type = ParamType::Int, .default_value = d, .min = 1, .max = kMaxWavelengths,
          .label = "Wavelengths", .description = "wavelengths traced together per path: more gives less colour noise",
          .reference = "Wilkie et al. 2014", .read_when = std::move(read_when), .group = "Spectral"};
}
ParamDecl film_transparent() {
  return {.name = "film_transparent", .type = ParamType::Bool, .default_value = false, .label = "Transparent",
          .description = "the background is transparent (alpha 0) where camera rays see the World; a scene with Holdout objects or shaders writes alpha either way", .shared = true,
          .group = "Film"};
}
ParamDecl sampling_pattern() {
  return {.name = "sampling_pattern", .type = ParamType::String, .default_value = "sobol",
          .choices = {"sobol", "independent"}, .label = "Pattern",
          .description = "where the camera paths' random numbers come from; sobol: Owen-scrambled Sobol points, "
                       "stratified per pixel (less noise at the same samples, as Cycles' patterns); independent: "
                       "independent random numbers",
          .reference = "Burley 2020", .group = "Rendering"};
}
ParamDecl clamp(const char* name, const char* label, const char* which) {
  return {.name = name, .type = ParamType::Float, .default_value = 0.0, .min = 0, .label = label,
          .description = std::string("largest sum of RGB a sample of ") + which + " light may add, 0 = off (as Cycles)",
          .group = "Clamping"};
}

// ---- Photon density estimation (thesis ch. 5-10) ----
// zero_means: what a default of 0 stands for (required then).
ParamDecl photons(int64_t d, std::string zero_means = {}) {
  ParamDecl p{.name = "photons", .type = ParamType::Int, .default_value = d, .min = 1, .label = "Photons",
              .description = "photons sent from the lights per pass: more detail per pass, slower passes", .group = "Photons"};
  if (d == 0) {
    p.min = 0;
    p.zero_means = std::move(zero_means);
    p.manual_value = 100000;
  }
  return p;
}
// SPPM's and GPM's: 100 000, doubling every 8 passes up to two per pixel (auto_photons_per_pass,
// measured in docs/gradient.md "Photons per pass that follow the image").
ParamDecl photons_ramp() {
  return photons(0, "100 000, doubling every 8 passes up to two per pixel (at most 1 000 000)");
}
// GPM's own photons per pass (issue 34): its primal is SPPM's image at the same parameters, not
// at both methods' defaults. 0: from the second pass, as many as keep the counted eye work a
// half of a pass, never below SPPM's ramp (gpm.h gpm_photons_per_pass).
ParamDecl gpm_photons() {
  return photons(0, "100 000, then as many as keep the eye pass half of a pass (at least SPPM's 100 000 "
                    "doubling every 8 passes, at most 4 000 000)");
}
ParamDecl alpha(double d, const char* reference) {
  return {.name = "alpha", .type = ParamType::Float, .default_value = d, .min = 0, .max = 1, .min_open = true,
          .max_open = true, .label = "Alpha",
          .description = "how fast the photon gathers shrink: lower sharpens caustics sooner and leaves more noise",
          .symbol = "α", .reference = reference, .group = "Photons"};
}
ParamDecl radius() {
  return {.name = "radius", .type = ParamType::Float, .default_value = 0.0, .min = 0, .label = "Initial Radius",
          .description = "size of the first pass's photon gathers, in metres: larger is smoother and blurrier at first",
          .symbol = "R_0", .zero_means = "from the size of a pixel (Footprint)", .manual_value = 0.01, .group = "Photons"};
}
ParamDecl footprint(double d, const char* reference) {
  return {.name = "footprint", .type = ParamType::Float, .default_value = d, .min = 0, .min_open = true,
          .label = "Footprint", .description = "size of the first photon gathers, in pixels, when Initial Radius is Auto: larger is "
                         "smoother and blurrier at first",
          .reference = reference, .group = "Photons"};
}
ParamDecl confidence() {
  return {.name = "confidence", .type = ParamType::Float, .default_value = 0.5, .min = 0, .max = 1, .min_open = true,
          .max_open = true, .label = "Confidence",
          .description = "how sure the Error pass is that a pixel's error is below its figure: higher gives larger, "
                         "safer figures; Target Error stops on the estimated mean error either way (on the mean "
                         "figure with Error Bound Thesis, so later when higher)",
          .symbol = "1 - β", .reference = "thesis eq. 6.10", .group = "Photons"};
}
ParamDecl error_bound() {
  return {.name = "error_bound", .type = ParamType::String, .default_value = "calibrated",
          .choices = {"calibrated", "boundary", "thesis"}, .label = "Error Bound",
          .description = "how the Error pass bounds each pixel's error; calibrated: as measured, to its Confidence; "
                         "boundary: the same plus the blur where an edge crosses a photon gather (up to 1.5x the "
                         "pass time); thesis: the formula as published, which is too low at the default Confidence",
          .reference = "thesis eq. 6.12", .group = "Photons"};
}
ParamDecl hash() {
  return {.name = "hash", .type = ParamType::String, .default_value = "exact", .choices = {"exact", "stochastic"},
          .label = "Lookup",
          .description = "how photons near a point are found; exact: every one; stochastic: one per grid cell, faster "
                         "where photons are dense",
          .reference = "thesis ch. 10", .group = "Photons"};
}
ParamDecl photon_sampler(const char* d) {
  return {.name = "photon_sampler", .type = ParamType::String, .default_value = d,
          .choices = {"uniform", "adaptive"}, .label = "Photon Sampler",
          .description = "where photons are sent; uniform: wherever the lights shine; adaptive: towards what the "
                         "camera sees (Markov chains), for light through small openings",
          .reference = "thesis ch. 8", .group = "Photons"};
}
ParamDecl chains(int d, const char* group, std::string read_when = "") {
  return {.name = "chains", .type = ParamType::Int, .default_value = d, .min = 1, .label = "Chains",
          .description = "Markov chains run side by side", .read_when = std::move(read_when), .group = group};
}
ParamDecl specular_threshold() {
  return {.name = "specular_threshold", .type = ParamType::Float, .default_value = 0.05,  // kDefaultSpecularThreshold
          .min = 0, .label = "Specular Cutoff",
          .description = "roughness at or below which a surface reflects photons as a mirror does instead of "
                         "keeping them",
          .reference = "gradient-domain photon density estimation §5", .group = "Light Paths"};
}
ParamDecls photon_common(ParamDecl photons, double alpha_default, const char* alpha_ref, double footprint_default,
                         const char* footprint_ref) {
  return {std::move(photons), alpha(alpha_default, alpha_ref), radius(), footprint(footprint_default, footprint_ref),
          confidence(), error_bound(), hash()};
}

// ---- Gradient-domain reconstruction ----
ParamDecl recon(const char* d) {
  return {.name = "recon", .type = ParamType::String, .default_value = d, .choices = {"l1", "l2"},
          .label = "Reconstruction",
          .description = "how the image is rebuilt from its gradients; l1: robust to stray gradients, fewer "
                         "artefacts; l2: unbiased, may show halos around bright spots",
          .reference = "gradient-domain photon density estimation eq. 3", .group = "Reconstruction"};
}
ParamDecl lambda(const char* symbol = "λ", const char* reference = "gradient-domain photon density estimation eq. 3") {
  return {.name = "lambda", .type = ParamType::Float, .default_value = 0.2, .min = 0, .min_open = true,
          .label = "Lambda",
          .description = "weight of the noisy image against its gradients: higher keeps more noise and detail",
          .symbol = symbol, .reference = reference, .group = "Reconstruction"};
}

ParamDecls join(std::initializer_list<ParamDecls> parts) {
  ParamDecls out;
  for (const ParamDecls& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

SpectralMode spectral_mode(const Params& p) { return parse_spectral_mode(p.get<std::string>("spectral")); }

// spt, spt-hero and sgpt are spectral: mode rgb is a contradiction, not a fallback.
void require_spectral(const std::string& method, const Params& p) {
  if (spectral_mode(p) == SpectralMode::Rgb)
    throw ParamError("method '" + method + "' is spectral; spectral mode 'rgb' needs method 'pt'");
}

// ---- What the methods write and report (Method::passes, ::stats) ----
PassDecl always(std::string_view name) { return {name, ""}; }
// Combined's Alpha: with a transparent film, and on a scene that holds out (writes_alpha).
PassDecl alpha_pass() { return {pass::kAlpha, "film_transparent", true}; }
std::vector<PassDecl> photon_passes() {
  return {always(pass::kCombined), always(pass::kError), always(pass::kRadius), always(pass::kPhotonCount)};
}
std::vector<PassDecl> gradient_passes() {
  return {always(pass::kCombined), always(pass::kPrimal), always(pass::kGradientX), always(pass::kGradientY)};
}
// The adaptive photon sampler's (thesis ch. 8): with the uniform sampler they are absent.
std::vector<StatDecl> adaptive_stats() {
  return {{"acceptance rate", "accept", "{:.3f}"}, {"mutation size", "theta", "{:.3g}"},
          {"V_c", "V_c", "{:.3g}"}};  // 0.0004 under a distant light
}
// Paths whose neighbour a shift could not build: normal, shown as information.
StatDecl shift_failures() { return {"*shift failed*", "unshifted paths", "{:,.0f}"}; }
template <typename T>
std::vector<T> concat(std::vector<T> a, const std::vector<T>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<Method> make_methods() {
  const std::string adaptive_only = "photon_sampler=adaptive";
  std::vector<Method> m;
  m.push_back({.name = "pt", .label = "Path Tracing",
               .summary = "path tracing with next-event estimation and MIS (Veach 1997); spectral on dispersive scenes",
               .tooltip = "Unbiased reference, as Cycles renders: good for most scenes, noisy caustics "
                          "(next-event estimation and MIS, Veach 1997)",
               .params = join({{max_depth(32), rr_depth(), clamp("clamp_direct", "Direct Light", "direct"),
                      clamp("clamp_indirect", "Indirect Light", "indirect"), spectral(),
                      wavelengths(4, "spectral=spectral, or auto on a dispersive scene"), film_transparent(),
                      sampling_pattern()},
                     common()}),
               .make = [](const Scene& s, const Params& p) -> std::unique_ptr<Integrator> {
                 // `pt` turns into the hero-wavelength spectral path tracer when the mode asks
                 // for it; in "auto" only dispersive scenes do.
                 if (use_spectral(spectral_mode(p), s)) return std::make_unique<SpectralPathTracer>(s, p, true);
                 return std::make_unique<PathTracer>(s, p);
               },
               .passes = {always(pass::kCombined), alpha_pass()}, .supports = {.media = true, .motion_blur = true, .grid_media = true, .caustics = true}, .holdout = true});
  m.push_back({.name = "ppm", .label = "Photon Mapping",
               .summary = "progressive photon mapping: camera paths once, photons every pass (thesis ch. 5)",
               .tooltip = "Caustics and light through glass, sharpening as it renders; camera paths traced once "
                          "(progressive photon mapping, Hachisuka et al. 2008)",
               .params = join({photon_common(photons(100000), 0.7, "thesis eq. 5.7", 2.0, "thesis §7.4"),
                     {photon_sampler("uniform"), chains(64, "Photons", adaptive_only), max_depth(32), rr_depth(),
                      specular_threshold(), film_transparent()},
                     common()}),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<Ppm>(s, p); },
               .passes = concat(photon_passes(), {alpha_pass()}), .error_estimate = true,
               .merge = {.keeps_bias = true}, .stats = adaptive_stats(), .supports = {.media = true, .grid_media = true},
               .holdout = true});
  auto sppm_params = [&](const char* sampler, ParamDecl photons) {
    return join({photon_common(std::move(photons), 0.7, "thesis eq. 7.2", 2.0, "thesis §7.4"),
                 {photon_sampler(sampler), chains(64, "Photons", adaptive_only), max_depth(32), rr_depth(),
                  specular_threshold(), spectral("photon_sampler=uniform"),
                  wavelengths(4, "spectral photons: spectral=spectral or a dispersive scene, photon_sampler=uniform"),
                  film_transparent()},
                 common()});
  };
  m.push_back({.name = "sppm", .label = "Stochastic PPM",
               .summary = "stochastic progressive photon mapping: new camera paths every pass (thesis ch. 7)",
               .tooltip = "Caustics and light through glass, with depth of field and glossy surfaces; stops at a "
                          "target error (stochastic progressive photon mapping, Hachisuka and Jensen 2009)",
               .params = sppm_params("uniform", photons_ramp()),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<Sppm>(s, p, "sppm"); },
               .passes = concat(photon_passes(), {alpha_pass()}), .error_estimate = true,
               .merge = {.keeps_bias = true}, .stats = adaptive_stats(),  // with photon_sampler adaptive
               .supports = {.media = true, .motion_blur = true, .grid_media = true},  // media: RGB and spectral photons, uniform and adaptive
               .holdout = true});
  m.push_back({.name = "sppm-adaptive", .label = "SPPM Adaptive",
               .summary = "SPPM with adaptive MCMC photon paths, for light the view hardly sees (thesis ch. 8)",
               .tooltip = "Stochastic PPM that sends photons where the camera sees them: for light hidden behind "
                          "openings (adaptive Markov chain photons, Hachisuka and Jensen 2011)",
               // The adaptive sampler keeps the count it was measured with (its chains' share).
               .params = sppm_params("adaptive", photons(100000)),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<Sppm>(s, p, "sppm-adaptive"); },
               .passes = concat(photon_passes(), {alpha_pass()}), .error_estimate = true,
               .merge = {.keeps_bias = true}, .stats = adaptive_stats(),
               .supports = {.media = true, .motion_blur = true, .grid_media = true}, .holdout = true});
  m.push_back({.name = "msppm", .label = "Multisampled PPM",
               .summary = "multisampled PPM: path tracing and SPPM combined per path by MIS (thesis ch. 9)",
               .tooltip = "Path tracing and photons combined per pixel, each where it is better (multiple "
                          "importance sampling of both, Hachisuka's 2011 thesis ch. 9)",
               .params = join({{photons(0, "one per pixel (thesis §9.5)"), alpha(0.6, "thesis eq. 7.2; below 2/3 for eq. 9.25"), radius(),
                      {.name = "path_samples", .type = ParamType::Int, .default_value = 0, .min = 0,
                       .label = "Path Samples", .description = "path-tracing samples per pixel and pass",
                       .zero_means = "as many as the pixel expects photons (thesis §9.5)", .manual_value = 1,
                       .group = "Photons"},
                      {.name = "path_samples_max", .type = ParamType::Int, .default_value = 64, .min = 1,
                       .label = "Path Samples Max", .description = "most path-tracing samples per pixel and pass",
                       .read_when = "path_samples=0", .group = "Photons"},
                      max_depth(16), rr_depth()},
                     common()}),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<Msppm>(s, p); },
               .passes = {always(pass::kCombined), always(pass::kRadius), always(pass::kPhotonCount),
                          always(pass::kPathTracing)},
               .merge = {.keeps_bias = true},
               .stats = {{"path tracing share", "PT share", "{:.3f}"},
                         {"measurement points per pixel", "points/px", "{:.2f}"}},
               .supports = {.media = true, .motion_blur = true, .grid_media = true}});
  m.push_back({.name = "gpt", .label = "Gradient PT",
               .summary = "gradient-domain path tracing: gradients by shifted paths, screened Poisson (KMA15)",
               .tooltip = "Path tracing of image gradients, then a smooth reconstruction: less noise on flat areas "
                          "(gradient-domain path tracing, Kettunen et al. 2015)",
               .params = join({{recon("l2"), lambda(), max_depth(32), rr_depth()}, common()}),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<GradientPathTracer>(s, p); },
               .passes = gradient_passes(), .merge = {.reconstructs = true}, .stats = {shift_failures()},
               .supports = {.motion_blur = true}});
  m.push_back({.name = "gpm", .label = "Gradient Photons",
               .summary = "gradient-domain photon density estimation: photon gradients by shifts (Hua et al. 2017)",
               .tooltip = "Photon mapping of image gradients: smooth caustics in fewer passes (gradient-domain "
                          "photon density estimation, Hua et al. 2017)",
               .params = join({photon_common(gpm_photons(), 0.7, "thesis eq. 7.2 (the paper: 0.9)", 2.0,
                                   "thesis §7.4, as sppm: the primal is SPPM's image at the same parameters"),
                     {{.name = "gradient_footprint", .type = ParamType::Float, .default_value = 1.0, .min = 0,
                       .min_open = true, .label = "Gradient Footprint",
                       .description = "size of the first gradient gathers, in pixels: larger gives smoother gradients and "
                                      "softer edges",
                       .reference = "gradient-domain photon density estimation §5", .group = "Photons"},
                      {.name = "gradient_photons", .type = ParamType::Float, .default_value = 1.0, .min = 0,
                       .label = "Gradient Photons",
                       .description = "photons per pass a gradient gather aims at: after a pixel's first pass its "
                                      "gradients' radius is widened, up to the primal's, where fewer were found; "
                                      "0 keeps Gradient Footprint",
                       .group = "Photons"},  // measured: docs/gradient.md "Sparse photons"
                      {.name = "emission_samples", .type = ParamType::Int, .default_value = 4, .min = 0, .max = 64,
                       .label = "Emission Samples",
                       .description = "camera paths per pixel and pass, besides the gather path, for the light "
                                      "seen along them (emitters, their images in mirrors and glass); combined only",
                       .group = "Photons"},  // measured: docs/gradient.md "Emission"
                      {.name = "emission_samples_max", .type = ParamType::Int, .default_value = 16, .min = 0, .max = 64,
                       .label = "Emission Samples Max",
                       .description = "further camera paths per pass, at least Emission Samples, in the pixels that "
                                      "take them within 48 pixels of one whose light seen has varied (a light's image "
                                      "in a mirror or glass, an emitter's edge); combined only",
                       .group = "Photons"},  // measured: docs/gradient.md "Further paths where they found light"
                      {.name = "gradient_nee", .type = ParamType::Bool, .default_value = true,
                       .label = "Gradient Direct Light",
                       .description = "direct light by next-event estimation in the gradient domain (four offset "
                                      "shadow rays per pixel and pass); off keeps it in the primal, as SPPM's, and "
                                      "traces offsets only for pixels that gather photons",
                       .group = "Reconstruction"},  // measured: docs/gradient.md "Eye pass cost"
                      recon("l1"), lambda(),
                      {.name = "manifold_iterations", .type = ParamType::Int, .default_value = 20, .min = 0,
                       .label = "Manifold Steps",
                       .description = "steps of the manifold walk that shifts a caustic photon; 0 leaves caustics "
                                      "out of the gradients",
                       .reference = "gradient-domain photon density estimation §4.2 (the paper: 5)",
                       .group = "Reconstruction"},
                      max_depth(32), rr_depth(), specular_threshold()},
                     common()}),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<Gpm>(s, p); },
               .passes = concat(photon_passes(), {always(pass::kPrimal), always(pass::kGradientX), always(pass::kGradientY)}),
               .error_estimate = true,
               .merge = {.keeps_bias = true, .reconstructs = true},
               .stats = {shift_failures(), {"manifold walks", "walks", "{:,.0f}"}}, .supports = {.motion_blur = true}});
  m.push_back({.name = "gdmlt", .label = "Gradient MLT",
               .summary = "gradient-domain Metropolis light transport in primary sample space (Lehtinen et al. 2013)",
               .tooltip = "Explores bright, hard-to-find light paths by mutating them (gradient-domain Metropolis "
                          "light transport, Lehtinen et al. 2013)",
               .params = join({{{.name = "mutations", .type = ParamType::Int, .default_value = 1, .min = 1, .label = "Mutations",
                       .description = "mutations per pixel and pass", .group = "Metropolis"},
                      chains(64, "Metropolis"),
                      {.name = "large_step", .type = ParamType::Float, .default_value = 0.3, .min = 0, .max = 1,
                       .label = "Large Step", .description = "probability of a large step: a fresh path",
                       .symbol = "p_large", .reference = "Kelemen et al. 2002", .group = "Metropolis"},
                      {.name = "sigma", .type = ParamType::Float, .default_value = 0.01, .min = 0, .max = 1,
                       .min_open = true, .max_open = true, .label = "Step Size",
                       .description = "size of a small mutation: smaller explores around bright paths more closely",
                       .symbol = "σ",
                       .reference = "Kelemen et al. 2002", .group = "Metropolis"},
                      {.name = "primal_share", .type = ParamType::Float, .default_value = 0.05, .min = 0,
                       .min_open = true, .label = "Image Share",
                       .description = "how much the image's brightness, besides its gradients, steers where the chains go",
                       .symbol = "α", .reference = "GD-MLT slides", .group = "Metropolis"},
                      {.name = "bootstrap", .type = ParamType::Int, .default_value = 1, .min = 1, .label = "Bootstrap",
                       .description = "ordinary samples per pixel that start the chains and set the image's brightness",
                       .group = "Metropolis"},
                      {.name = "large_step_mis", .type = ParamType::Bool, .default_value = true,
                       .label = "Large Step MIS",
                       .description = "weigh chain and large-step samples by the balance heuristic",
                       .reference = "Kelemen et al. 2002", .group = "Metropolis"},
                      {.name = "direct", .type = ParamType::String, .default_value = "chain",
                       .choices = {"chain", "uniform"}, .label = "Direct Light",
                       .description = "where light that only mirrors and glass carry comes from; chain: the chains' splats; "
                                      "uniform: the ordinary samples",
                       .group = "Metropolis"},
                      recon("l1"), lambda(), max_depth(32), rr_depth()},
                     common()}),
               .make = [](const Scene& s, const Params& p) { return std::make_unique<GradientDomainMlt>(s, p); },
               .passes = concat(gradient_passes(), {always(pass::kSampleDensity)}),
               .merge = {.reconstructs = true},
               .stats = {{"acceptance rate", "accept", "{:.3f}"}, {"large-step share", "large", "{:.3f}"},
                         {"chains", "chains", "{:.0f}"}, shift_failures()},
               .supports = {.motion_blur = true}, .per_pixel = false, .paused_pass_covers_image = true});
  auto spt = [](bool hero) {
    return [hero](const Scene& s, const Params& p) -> std::unique_ptr<Integrator> {
      require_spectral(hero ? "spt-hero" : "spt", p);
      return std::make_unique<SpectralPathTracer>(s, p, hero);
    };
  };
  m.push_back({.name = "spt", .label = "Spectral PT",
               .summary = "spectral path tracing, one wavelength per path, Cauchy dispersion",
               .tooltip = "Path tracing by wavelength, for rainbows through dispersive glass (one wavelength per "
                          "path, Cauchy dispersion)",
               .params = join({{max_depth(32), rr_depth(), spectral(), wavelengths(1), film_transparent(), sampling_pattern()}, common()}),
               .make = spt(false), .passes = {always(pass::kCombined), alpha_pass()}, .supports = {.media = true, .motion_blur = true, .grid_media = true, .caustics = true}, .holdout = true});
  m.push_back({.name = "spt-hero", .label = "Spectral PT Hero",
               .summary = "spectral path tracing with hero wavelengths (Wilkie et al. 2014)",
               .tooltip = "Spectral path tracing with four wavelengths per path: less colour noise (hero "
                          "wavelengths, Wilkie et al. 2014)",
               .params = join({{max_depth(32), rr_depth(), spectral(), wavelengths(4), film_transparent(), sampling_pattern()}, common()}),
               .make = spt(true), .passes = {always(pass::kCombined), alpha_pass()}, .supports = {.media = true, .motion_blur = true, .grid_media = true, .caustics = true}, .holdout = true});
  m.push_back({.name = "sgpt", .label = "Spectral Gradient",
               .summary = "spectral gradient sampling: spectral shifts, 1D screened Poisson (Petitjean et al. 2018)",
               .tooltip = "Spectral path tracing with a smooth reconstruction across wavelengths (spectral "
                          "gradient sampling, Petitjean et al. 2018)",
               .params = join({{{.name = "bins", .type = ParamType::Int, .default_value = 15, .min = 3, .max = 256,
                       .label = "Bins", .description = "wavelength bands per pixel that the reconstruction smooths across", .reference = "Petitjean et al. §3.2",
                       .group = "Spectral"},
                      {.name = "delta", .type = ParamType::Float, .default_value = 0.15, .min = 0, .max = 1,
                       .min_open = true, .max_open = true, .label = "Delta",
                       .description = "distance to the neighbouring wavelength of a shift, as a fraction of 360-830 nm",
                       .symbol = "δ",
                       .reference = "Petitjean et al. §4", .group = "Spectral"},
                      {.name = "tau", .type = ParamType::Float, .default_value = 0.0, .min = 0, .label = "Tau",
                       .description = "paths dimmer than this are not shifted: faster, less smoothing", .symbol = "τ",
                       .reference = "Petitjean et al. eq. 16", .group = "Spectral"},
                      lambda("α", "Petitjean et al. eq. 14"), spectral(), wavelengths(1), max_depth(32), rr_depth()},
                     common()}),
               .make = [](const Scene& s, const Params& p) -> std::unique_ptr<Integrator> {
                 require_spectral("sgpt", p);
                 return std::make_unique<SpectralGradientPathTracer>(s, p);
               },
               .passes = {always(pass::kCombined), always(pass::kSpectralPrimal), always(pass::kSpectralGradient)},
               .stats = {{"shifted pairs", "shifted", "{:,.0f}"}, shift_failures()}, .supports = {.motion_blur = true}});
  return m;
}

size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1])});
      diag = up;
    }
  }
  return row[b.size()];
}

}  // namespace

const ParamDecl* Method::find(const std::string& param) const {
  for (const ParamDecl& d : params)
    if (d.name == param) return &d;
  return nullptr;
}

std::vector<std::string> Method::passes_with(const Params& bound, const Scene* scene) const {
  std::vector<std::string> out;
  for (const PassDecl& p : passes)
    if (p.when_param.empty() || bound.get<bool>(p.when_param) || (p.or_holdout && scene && scene->has_holdout()))
      out.emplace_back(p.name);
  return out;
}

// Bound parameters point at their method's declarations (Params::bound), so the registry never
// reallocates: room for kMaxMethods.
constexpr size_t kMaxMethods = 64;
struct Registry {
  std::vector<Method> all;
  size_t built_in = 0;  // the first built_in are make_methods()'; register_method's follow
  Registry() {
    all.reserve(kMaxMethods);
    for (Method& b : make_methods()) all.push_back(std::move(b));
    built_in = all.size();
  }
};
Registry& the_registry() {
  static Registry r;
  return r;
}
std::vector<Method>& registry() { return the_registry().all; }

const std::vector<Method>& methods() { return registry(); }

void register_method(Method m) {
  for (const Method& k : registry())
    if (k.name == m.name) throw std::invalid_argument("method '" + m.name + "' is registered already");
  if (registry().size() == kMaxMethods) throw std::length_error("more than 64 methods");
  registry().push_back(std::move(m));
}

void unregister_method(const std::string& name) {
  if (registry().size() <= the_registry().built_in || registry().back().name != name)
    throw std::invalid_argument("method '" + name + "' is not the last one registered");
  registry().pop_back();
}

const Method* lookup_method(const std::string& name) {
  for (const Method& m : methods())
    if (m.name == name) return &m;
  return nullptr;
}

const Method& find_method(const std::string& name) {
  if (const Method* m = lookup_method(name)) return *m;
  std::string known;
  for (const Method& m : methods()) known += (known.empty() ? "" : ", ") + m.name;
  throw ParamError("unknown method '" + name + "' (known: " + known + ")");
}

std::vector<std::string> integrator_names() {
  std::vector<std::string> out;
  for (const Method& m : methods()) out.push_back(m.name);
  return out;
}

std::unique_ptr<Integrator> make_integrator(const std::string& method, const Scene& scene, const Params& params) {
  const Method& m = find_method(method);
  const Params bound = params.bound(m.name, m.params);
  auto integrator = m.make(scene, bound);
  params.mark_read(bound);
  return integrator;
}

std::vector<std::string> unused_parameter_report(const std::string& method, const Params& params) {
  const Method& m = find_method(method);
  std::vector<std::string> out;
  for (const std::string& name : params.unused()) {
    if (const ParamDecl* d = m.find(name)) {
      out.push_back("parameter '" + name + "' of " + method + " is not read with these settings" +
                    (d->read_when.empty() ? "" : " (read only with " + d->read_when + ")"));
      continue;
    }
    std::string line = "parameter '" + name + "' is not a parameter of " + method;
    const ParamDecl* best = nullptr;
    size_t best_d = 3;  // suggest only near misses: two edits at most
    for (const ParamDecl& d : m.params)
      if (const size_t e = edit_distance(name, d.name); e < best_d) best_d = e, best = &d;
    if (best) line += " (did you mean '" + best->name + "'?)";
    out.push_back(line);
  }
  return out;
}

}  // namespace gp
