#include "distributed/run_info.h"

#include <fmt/format.h>

#include <cstring>
#include <stdexcept>

#include "scene/scene.h"

namespace gp {

namespace {

constexpr const char* kPrefix = "gradphoton.";

class Fnv1a {
 public:
  template <typename T>
  void add(const T& v) { bytes(&v, sizeof(T)); }
  void add(const std::string& s) { add(s.size()); bytes(s.data(), s.size()); }
  template <typename T>
  void add_all(const std::vector<T>& v) { add(v.size()); bytes(v.data(), v.size() * sizeof(T)); }
  void add(const Vec3& v) { add(v.x); add(v.y); add(v.z); }
  void add(const RGB& c) { add(c.r); add(c.g); add(c.b); }
  uint64_t value() const { return h_; }

 private:
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h_ = (h_ ^ b[i]) * 1099511628211ull;
  }
  uint64_t h_ = 14695981039346656037ull;
};

std::string field(const std::map<std::string, std::string>& a, const char* name, const std::string& path) {
  auto it = a.find(std::string(kPrefix) + name);
  if (it == a.end()) throw std::runtime_error(fmt::format("{}: no '{}{}' in the EXR header", path, kPrefix, name));
  return it->second;
}

template <typename T>
T number(const std::map<std::string, std::string>& a, const char* name, const std::string& path) {
  const std::string s = field(a, name, path);
  try {
    size_t used = 0;
    T v;
    if constexpr (std::is_same_v<T, double>) v = std::stod(s, &used);
    else if constexpr (std::is_same_v<T, uint64_t>) v = std::stoull(s, &used);
    else v = static_cast<T>(std::stoll(s, &used));
    if (used == s.size()) return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(fmt::format("{}: header field '{}{}' is not a number: '{}'", path, kPrefix, name, s));
}

}  // namespace

std::string scene_fingerprint(const Scene& scene) {
  Fnv1a h;
  h.add(scene.meshes.size());
  for (const Mesh& m : scene.meshes) {
    h.add_all(m.positions);
    h.add_all(m.indices);
    h.add_all(m.material_ids);
  }
  h.add(scene.materials.size());
  for (const Material& m : scene.materials) {
    h.add(m.name);
    h.add(static_cast<int>(m.type));
    h.add(m.color);
    h.add(m.roughness);
    h.add(m.ior);
    h.add(m.cauchy_b);
    h.add(m.radiance());
    h.add(m.two_sided);
  }
  h.add(scene.lights.size());
  for (const Light& l : scene.lights) {
    h.add(static_cast<int>(l.type));
    h.add(l.emit);
    h.add(l.position);
    h.add(l.direction);
    h.add(l.spot_cos_half);
    h.add(l.spot_smooth);
    for (const auto* map : {l.map.get(), l.camera_map.get()})
      if (map) h.add(map->identity());  // an image or sky World: which, turned and scaled how
  }
  const Camera& c = scene.camera;
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}) h.add(c.camera_to_world.point(p));
  h.add(c.fov_degrees);
  h.add(static_cast<int>(c.sensor_fit));
  h.add(c.aperture_radius);
  h.add(c.focus_distance);
  return fmt::format("{:016x}", h.value());
}

RunInfo make_run_info(const std::string& method, const Params& params, const Stats& stats, const Scene& scene) {
  RunInfo r;
  r.method = method;
  r.seeds = {params.has("seed") ? params.json().at("seed").get<uint64_t>() : 0};
  r.passes = stats.passes;
  r.paths = stats.paths;
  r.seconds = stats.seconds;
  r.width = scene.camera.width;
  r.height = scene.camera.height;
  r.params = params.json();
  for (const char* k : kRunSpecificParams) r.params.erase(k);
  r.scene = scene.source;
  r.scene_hash = scene_fingerprint(scene);
  return r;
}

std::map<std::string, std::string> to_attributes(const RunInfo& r) {
  std::string seeds;
  for (uint64_t s : r.seeds) seeds += (seeds.empty() ? "" : ",") + std::to_string(s);
  const std::string p = kPrefix;
  return {{p + "method", r.method},
          {p + "seed", seeds},
          {p + "runs", std::to_string(r.runs)},
          {p + "passes", std::to_string(r.passes)},
          {p + "paths", std::to_string(r.paths)},
          {p + "seconds", fmt::format("{:.6g}", r.seconds)},
          {p + "size", fmt::format("{}x{}", r.width, r.height)},
          {p + "params", r.params.dump()},
          {p + "scene", r.scene},
          {p + "scene_hash", r.scene_hash},
          {p + "version", r.version}};
}

bool has_run_info(const std::map<std::string, std::string>& attributes) {
  for (const auto& [k, v] : attributes)
    if (k.rfind(kPrefix, 0) == 0) return true;
  return false;
}

RunInfo from_attributes(const std::map<std::string, std::string>& a, const std::string& path) {
  if (!has_run_info(a))
    throw std::runtime_error(fmt::format(
        "{}: no gradphoton run metadata in the EXR header (written by an older gradphoton, or not by gradphoton)", path));
  RunInfo r;
  r.method = field(a, "method", path);
  const std::string seeds = field(a, "seed", path);
  size_t start = 0;
  while (start <= seeds.size()) {
    const size_t comma = std::min(seeds.find(',', start), seeds.size());
    const std::string one = seeds.substr(start, comma - start);
    try {
      size_t used = 0;
      r.seeds.push_back(std::stoull(one, &used));
      if (used != one.size()) throw std::invalid_argument(one);
    } catch (const std::exception&) {
      throw std::runtime_error(fmt::format("{}: header field 'gradphoton.seed' is not a seed list: '{}'", path, seeds));
    }
    start = comma + 1;
  }
  r.runs = number<int64_t>(a, "runs", path);
  r.passes = number<int64_t>(a, "passes", path);
  r.paths = number<int64_t>(a, "paths", path);
  r.seconds = number<double>(a, "seconds", path);
  const std::string size = field(a, "size", path);
  if (std::sscanf(size.c_str(), "%dx%d", &r.width, &r.height) != 2)
    throw std::runtime_error(fmt::format("{}: header field 'gradphoton.size' is not WxH: '{}'", path, size));
  r.params = nlohmann::json::parse(field(a, "params", path), nullptr, false);
  if (!r.params.is_object())
    throw std::runtime_error(fmt::format("{}: header field 'gradphoton.params' is not a JSON object", path));
  r.scene = field(a, "scene", path);
  r.scene_hash = field(a, "scene_hash", path);
  r.version = field(a, "version", path);
  return r;
}

}  // namespace gp
