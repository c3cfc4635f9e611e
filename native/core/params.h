// Parameters of a method: their declarations (name, type, default, range or choices, a line of
// description, the paper's symbol and equation) and the dictionary of given values the method
// reads them from. Declarations live beside each method's factory (integrators/methods.cpp);
// validation, error wording, the unused-parameter report and every front end's view of the
// parameters (CLI help, _native.method_params, Blender's properties, docs/methods.md) come from
// them. Values are JSON; every read is recorded, so names given but never read can be reported
// (as pbrt-v4's ParameterDictionary does).
#pragma once

#include <nlohmann/json.hpp>

#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace gp {

class ParamError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class ParamType { Int, Float, Bool, String };
const char* to_string(ParamType t);

// One parameter as a method declares it.
struct ParamDecl {
  std::string name;
  ParamType type = ParamType::Float;
  nlohmann::json default_value;
  // Numbers: the allowed interval; an open end excludes its bound.
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false, max_open = false;
  std::vector<std::string> choices;  // strings: the allowed values (empty: any)
  std::string label;                 // short name for panels and tables ("Alpha", "Photons")
  std::string description;           // one line: what it does
  std::string symbol;                // the paper's symbol, e.g. "α" (empty: none)
  std::string reference;             // where the paper defines it, e.g. "thesis eq. 7.2"
  std::string zero_means;            // 0 is "automatic": what it then does ("from the pixel footprint")
  // A value a front end offers when the user turns "automatic" off (zero_means only).
  nlohmann::json manual_value;
  // Read only with another parameter's value, "photon_sampler=adaptive" (empty: always).
  std::string read_when;
  // The same meaning and value for every method that declares it (seed, threads, spectral
  // mode): a front end holds it once; every other parameter is held per method.
  bool shared = false;
  std::string group;  // panel of Blender's Render tab: "Photons", "Reconstruction", ...

  // "in (0, 1)", ">= 1", "one of exact, stochastic", "" (any value of the type).
  std::string range_text() const;
  // The default as a user writes it: "0.7", "exact", "true"; "0 (one per pixel)" with zero_means.
  std::string default_text() const;
  // The flag of the `render` command: --max-depth for max_depth.
  std::string flag() const;
  // The value checked against type and range, as JSON of the declared type (an integral
  // number for Int); throws ParamError "parameter 'lambda' of gpm must be > 0, got -1".
  nlohmann::json checked(const nlohmann::json& value, const std::string& method) const;
};
using ParamDecls = std::vector<ParamDecl>;

class Params {
 public:
  Params() : values_(nlohmann::json::object()) {}
  explicit Params(nlohmann::json values) : values_(std::move(values)) {
    if (!values_.is_object()) throw ParamError("parameters must be a JSON object");
  }

  // The given value or its declared default (requires bind()); a name the method does not
  // declare is a programming error (std::logic_error), caught by the registry's tests.
  template <typename T>
  T get(const std::string& name) const {
    const ParamDecl& d = decl(name);
    used_.insert(name);
    auto it = values_.find(name);
    const nlohmann::json& v = it == values_.end() || it->is_null() ? d.default_value : *it;
    return v.get<T>();
  }
  // Unbound reads with a caller's fallback (run-level values read outside a method).
  template <typename T>
  T get(const std::string& name, const T& fallback) const {
    used_.insert(name);
    auto it = values_.find(name);
    if (it == values_.end() || it->is_null()) return fallback;
    try {
      return it->get<T>();
    } catch (const nlohmann::json::exception&) {
      throw ParamError("parameter '" + name + "' has the wrong type: " + it->dump());
    }
  }
  bool has(const std::string& name) const { return values_.contains(name); }
  void set(const std::string& name, nlohmann::json v) { values_[name] = std::move(v); }

  // A copy bound to `method`'s declarations, every given value it declares checked (type,
  // range, choices: ParamDecl::checked) and normalised to the declared type. Values it does
  // not declare are kept (and stay unread: the unused-parameter report names them).
  Params bound(const std::string& method, const ParamDecls& decls) const;
  // Records `other`'s reads as this one's (a bound copy's reads, for unused()).
  void mark_read(const Params& other) const { used_.insert(other.used_.begin(), other.used_.end()); }

  // Names given but never read by the component that consumed these parameters.
  std::vector<std::string> unused() const {
    std::vector<std::string> out;
    for (auto it = values_.begin(); it != values_.end(); ++it)
      if (!used_.count(it.key())) out.push_back(it.key());
    return out;
  }
  const nlohmann::json& json() const { return values_; }

 private:
  const ParamDecl& decl(const std::string& name) const;

  nlohmann::json values_;
  mutable std::set<std::string> used_;
  std::string method_;                  // bound method, for messages
  const ParamDecls* decls_ = nullptr;   // bound declarations (static storage: the registry)
};

}  // namespace gp
