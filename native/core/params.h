// Parameter dictionary for building integrators from the CLI, Python or Blender. Values are
// JSON; every read is recorded so mistyped names are reported as unused (as pbrt does).
#pragma once

#include <nlohmann/json.hpp>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace gp {

class ParamError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Params {
 public:
  Params() : values_(nlohmann::json::object()) {}
  explicit Params(nlohmann::json values) : values_(std::move(values)) {
    if (!values_.is_object()) throw ParamError("parameters must be a JSON object");
  }

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
  // Names given but never read by the component that consumed these parameters.
  std::vector<std::string> unused() const {
    std::vector<std::string> out;
    for (auto it = values_.begin(); it != values_.end(); ++it)
      if (!used_.count(it.key())) out.push_back(it.key());
    return out;
  }
  const nlohmann::json& json() const { return values_; }

 private:
  nlohmann::json values_;
  mutable std::set<std::string> used_;
};

}  // namespace gp
