// Typed, path-aware reading of JSON scene values. Every getter knows the JSON Pointer of the
// value it reads ("/objects/3/radius"), so a wrong value throws
// SceneError("<file>: <path>: <what is wrong>"); keys a reader does not know are counted
// "unknown key" warnings, the way pbrt reports unused parameters. The scene loader
// (scene/loader.cpp) reads every value through here.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/color.h"
#include "core/log.h"
#include "core/math.h"
#include "scene/loader.h"
#include "scene/shapes.h"  // linear_determinant

namespace gp {

// ordered_json keeps the file's order: materials get indices in the order they are written.
using json = nlohmann::ordered_json;

// RFC 6901 escaping of one JSON Pointer token, and the pointer of a member or element of `path`.
std::string pointer_token(std::string_view key);
std::string sub(const std::string& path, std::string_view key);
std::string sub(const std::string& path, size_t index);

// "a, b, c"
std::string join(const std::vector<std::string>& items);

// Parses `text` (comments allowed); a syntax or number error throws SceneError naming `file`
// and the byte offset.
json parse_json(const std::string& text, const std::string& file);

class JsonReader {
 public:
  JsonReader(std::string file, Warnings& warnings) : file_(std::move(file)), warnings_(warnings) {}
  const std::string& file() const { return file_; }

  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    throw SceneError(fmt::format("{}: {}: {}", file_, path.empty() ? "/" : path, message));
  }

  void check_keys(const json& obj, const std::string& path, std::initializer_list<std::string_view> allowed) {
    check_keys(obj, path, std::span<const std::string_view>(allowed.begin(), allowed.size()));
  }
  void check_keys(const json& obj, const std::string& path, std::span<const std::string_view> allowed) {
    for (auto it = obj.begin(); it != obj.end(); ++it)
      if (std::find(allowed.begin(), allowed.end(), std::string_view(it.key())) == allowed.end())
        warnings_.add("unknown key", fmt::format("{}: {}", file_, sub(path, it.key())));
  }

  static const json* find(const json& obj, const char* key) {
    auto it = obj.find(key);
    return it == obj.end() ? nullptr : &*it;
  }
  const json& need(const json& obj, const char* key, const std::string& path) const {
    const json* j = find(obj, key);
    if (!j) fail(path, fmt::format("missing required key '{}'", key));
    return *j;
  }

  void require_object(const json& j, const std::string& path) const {
    if (!j.is_object()) fail(path, fmt::format("expected an object, got {}", describe(j)));
  }
  void require_array(const json& j, const std::string& path) const {
    if (!j.is_array()) fail(path, fmt::format("expected an array, got {}", describe(j)));
  }
  static std::string describe(const json& j) {
    std::string text = j.dump();
    if (text.size() > 40) text = text.substr(0, 37) + "...";
    return fmt::format("{} {}", j.type_name(), text);
  }

  float get_float(const json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, fmt::format("expected a number, got {}", describe(j)));
    const double d = j.get<double>();
    const float f = static_cast<float>(d);
    if (!std::isfinite(d) || !std::isfinite(f)) fail(path, fmt::format("number {} is not finite as a 32-bit float", d));
    return f;
  }
  float get_nonnegative(const json& j, const std::string& path) const {
    const float f = get_float(j, path);
    if (f < 0) fail(path, fmt::format("must not be negative (got {})", f));
    return f;
  }
  float get_positive(const json& j, const std::string& path) const {
    const float f = get_float(j, path);
    if (!(f > 0)) fail(path, fmt::format("must be positive (got {})", f));
    return f;
  }
  float get_in_range(const json& j, const std::string& path, float lo, float hi) const {
    const float f = get_float(j, path);
    if (f < lo || f > hi) fail(path, fmt::format("must be in [{}, {}] (got {})", lo, hi, f));
    return f;
  }
  int64_t get_int(const json& j, const std::string& path, int64_t lo, int64_t hi) const {
    if (!j.is_number_integer()) fail(path, fmt::format("expected an integer, got {}", describe(j)));
    if (j.is_number_unsigned() && j.get<uint64_t>() > static_cast<uint64_t>(hi))
      fail(path, fmt::format("must be in [{}, {}] (got {})", lo, hi, j.dump()));
    const int64_t v = j.get<int64_t>();
    if (v < lo || v > hi) fail(path, fmt::format("must be in [{}, {}] (got {})", lo, hi, v));
    return v;
  }
  bool get_bool(const json& j, const std::string& path) const {
    if (!j.is_boolean()) fail(path, fmt::format("expected true or false, got {}", describe(j)));
    return j.get<bool>();
  }
  std::string get_string(const json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, fmt::format("expected a string, got {}", describe(j)));
    return j.get<std::string>();
  }
  void require_length(const json& j, const std::string& path, size_t n, const char* what) const {
    if (!j.is_array() || j.size() != n)
      fail(path, fmt::format("expected {} (an array of {} numbers), got {}", what, n, describe(j)));
  }
  Vec3 get_vec3(const json& j, const std::string& path) const {
    require_length(j, path, 3, "a vector [x, y, z]");
    return {get_float(j[0], sub(path, 0)), get_float(j[1], sub(path, 1)), get_float(j[2], sub(path, 2))};
  }
  Vec2 get_vec2(const json& j, const std::string& path) const {
    require_length(j, path, 2, "a pair [u, v]");
    return {get_float(j[0], sub(path, 0)), get_float(j[1], sub(path, 1))};
  }
  Vec3 get_direction(const json& j, const std::string& path) const {
    const Vec3 d = get_vec3(j, path);
    const float len = length(d);
    if (!(len > 0) || !std::isfinite(len)) fail(path, "direction must be a non-zero vector");
    return d / len;
  }
  // A colour: [r, g, b] or one number (grey); components must not be negative.
  RGB get_color(const json& j, const std::string& path) const {
    if (j.is_number()) {
      const float g = get_nonnegative(j, path);
      return RGB(g);
    }
    if (!j.is_array() || j.size() != 3)
      fail(path, fmt::format("expected a colour [r, g, b] or a single number, got {}", describe(j)));
    return {get_nonnegative(j[0], sub(path, 0)), get_nonnegative(j[1], sub(path, 1)),
            get_nonnegative(j[2], sub(path, 2))};
  }
  // 16 numbers, row-major; must be affine (last row 0 0 0 1) with an invertible linear part.
  Transform get_matrix(const json& j, const std::string& path) const {
    require_length(j, path, 16, "a row-major 4x4 matrix");
    Transform t;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) t.m[r][c] = get_float(j[4 * r + c], sub(path, 4 * r + c));
    if (t.m[3][0] != 0 || t.m[3][1] != 0 || t.m[3][2] != 0 || t.m[3][3] != 1)
      fail(path, "the last row must be [0, 0, 0, 1] (affine transforms only)");
    if (linear_determinant(t) == 0) fail(path, "the matrix is singular (its 3x3 part has determinant 0)");
    return t;
  }


 protected:
  std::string file_;
  Warnings& warnings_;
};

}  // namespace gp
