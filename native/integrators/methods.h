// The methods: each one's name, a line on what it is, the declarations of its parameters and its
// factory, registered together (methods.cpp). make_integrator, integrator_names, the
// validation and unused-parameter wording, the CLI help, _native.method_params, Blender's
// properties and panels and the table in docs/methods.md are all made from this one list.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/params.h"

namespace gp {

class Integrator;
struct Scene;

// How independent-seed runs of a method merge (`gradphoton merge`, distributed/merge.h): each
// pass is the runs' mean weighted by their work, except that
struct MergeRule {
  // the merged image keeps the bias of one run's passes (photon density estimation: the radius
  // shrinks with each run's own passes), said to the user;
  bool keeps_bias = false;
  // primal and gradients are merged, then `combined` is reconstructed once by the method's own
  // screened Poisson solve (L1 is not linear: averaging reconstructions would be wrong).
  bool reconstructs = false;
};

// A pass a method's develop() writes (core/film.h pass::kAll), or writes only when parameter
// `when_param` is true (film_transparent's alpha), or also when the scene holds out
// (`or_holdout`: Scene::has_holdout, alpha: writes_alpha). Checked against develop() by methods_test.
struct PassDecl {
  std::string_view name;
  std::string when_param;  // empty: always
  bool or_holdout = false;
};

// A statistic a method reports in Stats::extra, by its key (lower-case words, units last:
// "eye seconds"), with what front ends show of it: a short label and a Python str.format spec
// (Blender's status line). A key with '*' sums every key it matches as a glob (shift failures,
// counted by reason: "shift failed: occluded", "sensor shift failed: ...").
struct StatDecl {
  std::string key, label, format;
};

// Scene features beyond surfaces and lights, for "method X does not render Y" messages.
struct SceneFeatures {
  bool media = false, motion_blur = false;
  bool grid_media = false;  // heterogeneous (OpenVDB) media too, not homogeneous ones only
  bool environment_map = true;  // an image World: every method samples it (lights/environment_map.h)
  // Light Paths > Caustics (Filter Glossy, Reflective / Refractive caustics: Scene::filter_glossy):
  // the camera paths of pt, spt and spt-hero (paths/camera_path.h). The photon and gradient
  // methods, which exist to render caustics, render them unfiltered.
  bool caustics = false;
};

// What a method is, in one place: front ends (CLI help, Python, Blender's method menu, panels,
// passes and status line), `gradphoton merge` and docs/methods.md read it.
struct Method {
  std::string name;
  std::string label;    // Blender's method menu ("Stochastic PPM")
  std::string summary;  // one line: what it computes, the paper (CLI, docs)
  std::string tooltip;  // what it is good for, in a Cycles user's words (Blender's menu)
  ParamDecls params;
  // Builds the method from parameters already bound to `params` (Params::bound).
  std::function<std::unique_ptr<Integrator>(const Scene&, const Params&)> make;
  std::vector<PassDecl> passes;  // what develop() writes (the auxiliary albedo/normal/depth besides)
  bool error_estimate = false;   // estimated_error() >= 0: the error pass and --target-error
  MergeRule merge;
  std::vector<StatDecl> stats;   // the key statistics front ends show
  SceneFeatures supports;
  // Which of Cycles' per-kind switches (Diffuse / Glossy / Transmission ray visibility) it
  // honours: those of surfaces (Material::visible_lobes: bounce rays of a hidden kind pass
  // through) and those of lights and the World (Light::visible_lobes: a light lights only the
  // lobes that see it, the World by Cycles' own rule for it, lobe_split.h). Camera and Shadow
  // switches, and the World's Camera switch, are honoured by every method. Front ends warn,
  // naming the method, where a scene sets what it ignores.
  struct LobeVisibility {
    bool surfaces = true, lights = true;
  } lobe_visibility;
  // Whether its camera paths honour Holdout (Material::holdout): those that start from CameraRays
  // end at a holdout surface with no colour and alpha 0, as Cycles. Front ends warn otherwise.
  bool holdout = false;
  // Pixels are traced independently (each from its own random stream): `render --pixel`
  // renders one pixel's samples as the full render does. False: global Markov chains (gdmlt).
  bool per_pixel = true;
  // A pass paused part-way (ProgressSink::pause) develops to an image of every pixel (gdmlt: the
  // chains' splats so far over the whole film), not of the tiles it reached with the rest black
  // (pt): so front ends may pause its first full pass too, after their reduced-size previews.
  bool paused_pass_covers_image = false;

  const ParamDecl* find(const std::string& param) const;
  // `params` checked and bound to this method's declarations (Params::bound), for building one
  // of its classes directly (tests).
  Params bind(const Params& params = Params()) const { return params.bound(name, this->params); }
  // The passes develop() writes with `params` (bound: every declared parameter has its value)
  // on `scene` (its features: Scene::has_holdout); without a scene, on one with no holdout.
  std::vector<std::string> passes_with(const Params& bound, const Scene* scene = nullptr) const;
};

// Every method, in the order front ends list them.
const std::vector<Method>& methods();
// Adds a method after the built-in ones (a method of a test or an extension: everything that
// reads methods() then offers it). std::invalid_argument for a name already taken. Not
// thread-safe: register before rendering.
void register_method(Method m);
// Removes a method added by register_method (a test's, at its end, so that later tests see the
// built-in list). std::invalid_argument unless it is the last one registered.
void unregister_method(const std::string& name);
// The method called `name`; ParamError naming the known ones when there is none.
const Method& find_method(const std::string& name);
// The method called `name`, or null (a name read from a file: `gradphoton merge`).
const Method* lookup_method(const std::string& name);

// Builds a method by name ("pt", ...) from its registration (methods.h). Unknown names and
// values outside their declaration (type, range, choices) throw ParamError; unread parameters
// are left in `params.unused()` for the caller to report (unused_parameter_report).
std::unique_ptr<Integrator> make_integrator(const std::string& method, const Scene& scene,
                                            const Params& params);
// Names make_integrator accepts, in the order of methods(), for --help texts and the Blender enum.
std::vector<std::string> integrator_names();

// One line per parameter given but left unread by the method built from `params` (after
// make_integrator): "parameter 'alhpa' is not a parameter of sppm (did you mean 'alpha'?)", or
// for a declared one that these settings leave unread, "parameter 'chains' of sppm is not read
// here (read only with photon_sampler=adaptive)".
std::vector<std::string> unused_parameter_report(const std::string& method, const Params& params);

}  // namespace gp
