#include "core/params.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace gp {

const char* to_string(ParamType t) {
  switch (t) {
    case ParamType::Int: return "int";
    case ParamType::Float: return "float";
    case ParamType::Bool: return "bool";
    case ParamType::String: return "string";
  }
  return "?";
}

std::string ParamDecl::range_text() const {
  if (!choices.empty()) {
    std::string s = "one of ";
    for (size_t i = 0; i < choices.size(); ++i) s += (i ? ", " : "") + choices[i];
    return s;
  }
  const bool lo = std::isfinite(min), hi = std::isfinite(max);
  if (lo && hi)
    return fmt::format("in {}{:g}, {:g}{}", min_open ? '(' : '[', min, max, max_open ? ')' : ']');
  if (lo) return fmt::format("{} {:g}", min_open ? ">" : ">=", min);
  if (hi) return fmt::format("{} {:g}", max_open ? "<" : "<=", max);
  return "";
}

std::string ParamDecl::default_text() const {
  std::string s = default_value.is_string()          ? default_value.get<std::string>()
                  : default_value.is_number_float() ? fmt::format("{:g}", default_value.get<double>())
                                                    : default_value.dump();
  if (!zero_means.empty() && default_value == 0) s += " (" + zero_means + ")";
  return s;
}

std::string ParamDecl::flag() const {
  std::string f = "--" + name;
  std::replace(f.begin(), f.end(), '_', '-');
  return f;
}

nlohmann::json ParamDecl::checked(const nlohmann::json& value, const std::string& method) const {
  auto fail = [&](const std::string& must) {
    return ParamError(fmt::format("parameter '{}' of {} must be {}, got {}", name, method, must, value.dump()));
  };
  switch (type) {
    case ParamType::Bool:
      if (!value.is_boolean()) throw fail("true or false");
      return value;
    case ParamType::String:
      if (!value.is_string()) throw fail(choices.empty() ? std::string("a string") : range_text());
      if (!choices.empty() && std::find(choices.begin(), choices.end(), value.get<std::string>()) == choices.end())
        throw fail(range_text());
      return value;
    case ParamType::Int:
    case ParamType::Float: {
      if (!value.is_number()) throw fail(type == ParamType::Int ? "an integer" : "a number");
      const double v = value.get<double>();
      if (type == ParamType::Int && !(std::isfinite(v) && v == std::floor(v))) throw fail("an integer");
      const bool below = min_open ? !(v > min) : !(v >= min);
      const bool above = max_open ? !(v < max) : !(v <= max);
      if (!std::isfinite(v) || below || above) throw fail(range_text());
      if (type == ParamType::Float) return v;
      if (value.is_number_unsigned()) return value;  // seeds up to 2^64 - 1
      return static_cast<int64_t>(v);
    }
  }
  return value;
}

Params Params::bound(const std::string& method, const ParamDecls& decls) const {
  Params p(values_);
  p.method_ = method;
  p.decls_ = &decls;
  for (const ParamDecl& d : decls) {
    auto it = p.values_.find(d.name);
    if (it != p.values_.end() && !it->is_null()) *it = d.checked(*it, method);
  }
  return p;
}

const ParamDecl& Params::decl(const std::string& name) const {
  if (decls_)
    for (const ParamDecl& d : *decls_)
      if (d.name == name) return d;
  throw std::logic_error(decls_ ? "method " + method_ + " reads parameter '" + name + "', which it does not declare"
                                : "parameter '" + name + "' read without declarations (Params::bound)");
}

}  // namespace gp
