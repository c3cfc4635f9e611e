// The methods: each one's name, a line on what it is, the declarations of its parameters and its
// factory, registered together (methods.cpp). make_integrator, integrator_names, the
// validation and unused-parameter wording, the CLI help, _native.method_params, Blender's
// properties and panels and the table in docs/methods.md are all made from this one list.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/params.h"

namespace gp {

class Integrator;
struct Scene;

struct Method {
  std::string name;
  std::string summary;  // one line: what it computes, the paper
  ParamDecls params;
  // Builds the method from parameters already bound to `params` (Params::bound).
  std::function<std::unique_ptr<Integrator>(const Scene&, const Params&)> make;
  // Pixels are traced independently (each from its own random stream): `render --pixel`
  // renders one pixel's samples as the full render does. False: global Markov chains (gdmlt).
  bool per_pixel = true;

  const ParamDecl* find(const std::string& param) const;
  // `params` checked and bound to this method's declarations (Params::bound), for building one
  // of its classes directly (tests).
  Params bind(const Params& params = Params()) const { return params.bound(name, this->params); }
};

// Every method, in the order front ends list them.
const std::vector<Method>& methods();
// The method called `name`; ParamError naming the known ones when there is none.
const Method& find_method(const std::string& name);

// One line per parameter given but left unread by the method built from `params` (after
// make_integrator): "parameter 'alhpa' is not a parameter of sppm (did you mean 'alpha'?)", or
// for a declared one that these settings leave unread, "parameter 'chains' of sppm is not read
// here (read only with photon_sampler=adaptive)".
std::vector<std::string> unused_parameter_report(const std::string& method, const Params& params);

}  // namespace gp
