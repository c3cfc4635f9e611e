#include "lights/world_graph.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>

#include "core/frame.h"
#include "core/parallel.h"
#include "lights/environment_map.h"
#include "lights/sky.h"

namespace gp {

using nlohmann::json;

// ---- The frame of a graph: which edits reuse its bake ----

namespace {

// Nodes whose value does not depend on the direction but through their linked inputs (no
// hidden Generated / Normal input, no context read but Light Path, which the bake does not see).
const std::set<std::string>& direction_free_nodes() {
  static const std::set<std::string> s = {
      "ShaderNodeLightPath", "ShaderNodeValue", "ShaderNodeRGB", "ShaderNodeMath", "ShaderNodeVectorMath",
      "ShaderNodeMix", "ShaderNodeMixRGB", "ShaderNodeValToRGB", "ShaderNodeRGBCurve", "ShaderNodeFloatCurve",
      "ShaderNodeHueSaturation", "ShaderNodeInvert", "ShaderNodeGamma", "ShaderNodeBrightContrast",
      "ShaderNodeSeparateColor", "ShaderNodeCombineColor", "ShaderNodeSeparateRGB", "ShaderNodeCombineRGB",
      "ShaderNodeSeparateXYZ", "ShaderNodeCombineXYZ", "ShaderNodeMapRange", "ShaderNodeClamp",
      "ShaderNodeBlackbody", "ShaderNodeRGBToBW"};
  return s;
}

// A node's or closure's "type" ("" when absent or not a string: never a json exception).
std::string type_of(const json& n) {
  if (!n.is_object()) return "";
  auto it = n.find("type");
  return it != n.end() && it->is_string() ? it->get<std::string>() : "";
}

bool is_link_to(const json& v, const std::string& id) {
  return v.is_object() && v.contains("link") && v["link"].is_string() && v["link"].get<std::string>() == id;
}

const json* input_of(const json& node, const char* name) {
  if (!node.is_object()) return nullptr;
  auto in = node.find("inputs");
  if (in == node.end() || !in->is_object()) return nullptr;
  auto it = in->find(name);
  return it == in->end() ? nullptr : &*it;
}

std::string prop_string(const json& node, const char* name, const std::string& fallback) {
  if (!node.is_object()) return fallback;
  auto p = node.find("props");
  if (p == node.end() || !p->is_object()) return fallback;
  auto it = p->find(name);
  return it != p->end() && it->is_string() ? it->get<std::string>() : fallback;
}

float prop_number(const json& node, const char* name, float fallback) {
  auto p = node.find("props");
  if (p == node.end() || !p->is_object()) return fallback;
  auto it = p->find(name);
  return it != p->end() && it->is_number() ? it->get<float>() : fallback;
}

bool prop_bool(const json& node, const char* name, bool fallback) {
  auto p = node.find("props");
  if (p == node.end() || !p->is_object()) return fallback;
  auto it = p->find(name);
  return it != p->end() && it->is_boolean() ? it->get<bool>() : fallback;
}

// A constant vector input (absent: `fallback`), or false for a link or a malformed value.
bool vector_input(const json& node, const char* name, Vec3 fallback, Vec3* out) {
  const json* v = input_of(node, name);
  if (!v) {
    *out = fallback;
    return true;
  }
  if (!v->is_array() || v->size() != 3) return false;
  for (int k = 0; k < 3; ++k)
    if (!(*v)[k].is_number()) return false;
  *out = Vec3((*v)[0].get<float>(), (*v)[1].get<float>(), (*v)[2].get<float>());
  return std::isfinite(out->x) && std::isfinite(out->y) && std::isfinite(out->z);
}

bool prop_has(const json& nodes, const std::string& id, const char* name) {
  const json& n = nodes[id];
  return n.is_object() && n.contains("props") && n["props"].is_object() && n["props"].contains(name);
}

// Blender's Euler XYZ (radians) as a matrix: Rz Ry Rx (svm/mapping_util.h, euler_to_transform).
void euler_xyz(const Vec3& e, float m[3][3]) {
  const float cx = std::cos(e.x), cy = std::cos(e.y), cz = std::cos(e.z);
  const float sx = std::sin(e.x), sy = std::sin(e.y), sz = std::sin(e.z);
  const float r[3][3] = {{cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz},
                         {cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz},
                         {-sy, cy * sx, cy * cx}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m[i][j] = r[i][j];
}

Vec3 mat_apply(const float m[3][3], const Vec3& v) {
  return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
          m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}
Vec3 mat_apply_t(const float m[3][3], const Vec3& v) {
  return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z, m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
          m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
}

// Erases what only weighs a term of the sum under closure `c` (WorldGraph::split_terms' walk):
// the constant factors of Mixes, the constant strengths of Backgrounds and the colours of those
// whose colour is constant too (a uniform term). A Mix of linked factor or a Background of
// linked strength is a term whole: kept as it is.
void strip_weights(json& c, int depth) {
  if (!c.is_object() || depth > 64) return;  // (the loader bounds the depth already)
  auto linked = [&](const char* key) {
    const auto it = c.find(key);
    return it != c.end() && shading::is_link(*it);
  };
  const std::string t = type_of(c);
  if (t == "mix" || t == "add") {
    if (t == "mix") {
      if (linked("factor")) return;
      c.erase("factor");
    }
    for (const char* child : {"a", "b"})
      if (auto it = c.find(child); it != c.end()) strip_weights(*it, depth + 1);
  } else if (t == "background") {
    if (linked("strength")) return;
    c.erase("strength");
    if (!linked("color")) c.erase("color");
  }
}

// Cycles' angle between unit vectors, accurate for small angles (util/math: precise_angle).
double precise_angle(const Vec3& a, const Vec3& b) { return 2.0 * std::atan2(double(length(a - b)), double(length(a + b))); }

}  // namespace

WorldGraphFrame world_graph_frame(const json& env, const std::string& images) {
  WorldGraphFrame f;
  json canon = env;
  const json* nodes = env.is_object() && env.contains("nodes") && env["nodes"].is_object() ? &env["nodes"] : nullptr;
  // The one Mapping fed by a Texture Coordinate's Generated or Object (no object: the
  // direction, svm/tex_coord.h for the background), its linear part sign(s) F with F a rotation.
  std::string mapping, texcoord;
  int mappings = 0, texcoords = 0;
  if (nodes)
    for (const auto& [id, n] : nodes->items()) {
      const std::string type = type_of(n);
      if (type == "ShaderNodeMapping") mapping = id, ++mappings;
      if (type == "ShaderNodeTexCoord") texcoord = id, ++texcoords;
    }
  float F[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // the Mapping's rotation
  float sign = 1.0f;
  bool rotation = false;  // a Mapping as above, sign F d a function of F d
  bool turned = false;    // and textures reading it see the direction sign F d (no location)
  if (nodes && mappings == 1 && texcoords == 1) {
    const json& m = (*nodes)[mapping];
    const json& tc = (*nodes)[texcoord];
    const json* v = input_of(m, "Vector");
    const std::string kind = prop_string(m, "vector_type", "POINT");
    Vec3 loc, rot, scale;
    const bool constants = vector_input(m, "Location", Vec3(0.0f), &loc) && vector_input(m, "Rotation", Vec3(0.0f), &rot) &&
                           vector_input(m, "Scale", Vec3(1.0f), &scale);
    const bool from_direction = v && is_link_to(*v, texcoord) && v->contains("output") && (*v)["output"].is_string() &&
                                ((*v)["output"] == "Generated" || (*v)["output"] == "Object") &&
                                !(tc.contains("props") && tc["props"].is_object() && tc["props"].contains("object_matrix"));
    // A uniform scale commutes with the rotation; a location moves the vector off the
    // direction's line (Point: R s d + loc is still a function of R d; Texture: R^T (d - loc) / s
    // is not).
    const bool uniform = scale.x == scale.y && scale.y == scale.z && scale.x != 0.0f;
    const bool no_loc = loc.x == 0.0f && loc.y == 0.0f && loc.z == 0.0f;
    if (constants && from_direction && uniform && (kind != "TEXTURE" || no_loc)) {
      euler_xyz(rot, F);
      if (kind == "TEXTURE") {  // R^T d / s
        for (int i = 0; i < 3; ++i)
          for (int j = i + 1; j < 3; ++j) std::swap(F[i][j], F[j][i]);
      }
      sign = scale.x > 0 ? 1.0f : -1.0f;
      rotation = true;
      turned = kind != "POINT" || no_loc;
    }
  }
  // Separable: every node but the Mapping and its Texture Coordinate is direction-free or a
  // texture whose Vector is the Mapping's, and nothing else reads the Texture Coordinate.
  bool separable = rotation;
  if (separable)
    for (const auto& [id, n] : nodes->items()) {
      if (id == mapping || id == texcoord) continue;
      const std::string type = type_of(n);
      if (type == "ShaderNodeTexEnvironment" || type == "ShaderNodeTexSky") {
        const json* tv = input_of(n, "Vector");
        if (!tv || !is_link_to(*tv, mapping)) separable = false;
      } else if (!direction_free_nodes().count(type)) {
        separable = false;
      }
      if (n.is_object() && n.contains("inputs") && n["inputs"].is_object())
        for (const auto& [name, in] : n["inputs"].items())
          if (is_link_to(in, texcoord)) separable = false;
    }
  if (separable) {
    canon["nodes"][mapping]["inputs"].erase("Rotation");
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) f.frame[i][j] = F[i][j];
  }
  // The root's strength, when the root is a Background of constant positive strength.
  if (env.is_object() && env.contains("surface") && env["surface"].is_object()) {
    const json& root = env["surface"];
    if (type_of(root) == "background") {
      const auto it = root.find("strength");
      const float s = it == root.end() ? 1.0f : it->is_number() ? it->get<float>() : -1.0f;
      if (s > 0.0f && std::isfinite(s)) {
        f.strength = s;
        canon["surface"].erase("strength");
      }
    }
  }
  f.key = canon.dump() + "\n" + images;
  // A sum of constant weights at the root (WorldGraph::split_terms): the key less its weights.
  if (canon.is_object() && canon.contains("surface")) {
    json terms = canon;
    json& root = terms["surface"];
    const std::string rt = type_of(root);
    const auto fac = root.is_object() ? root.find("factor") : root.end();
    if (rt == "add" || (rt == "mix" && (fac == root.end() || !shading::is_link(*fac)))) {
      strip_weights(root, 0);
      f.terms_key = terms.dump() + "\n" + images;
    }
  }
  // Nishita suns: a Sky Texture reading the direction (Vector unlinked, or the Texture
  // Coordinate's) or the Mapping above (sign F d); its sun in the World at F^T (sign sun).
  f.suns_complete = true;
  if (nodes)
    for (const auto& [id, n] : nodes->items()) {
      if (type_of(n) != "ShaderNodeTexSky") continue;
      if (prop_string(n, "sky_type", "NISHITA") != "NISHITA" || !prop_bool(n, "sun_disc", true)) continue;
      const json* v = input_of(n, "Vector");
      float M[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
      float sg = 1.0f;
      const bool direct = !v || (is_link_to(*v, texcoord) && v->contains("output") &&
                                 ((*v)["output"] == "Generated" || (*v)["output"] == "Object") &&
                                 !prop_has(*nodes, texcoord, "object_matrix"));
      if (v && turned && is_link_to(*v, mapping)) {
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) M[i][j] = F[i][j];
        sg = sign;
      } else if (!direct) {
        f.suns_complete = false;  // a vector this cannot follow: the grid keeps that disc
        continue;
      }
      SkyOptions o;
      o.sun_elevation = prop_number(n, "sun_elevation", o.sun_elevation);
      o.sun_rotation = prop_number(n, "sun_rotation", o.sun_rotation);
      o.sun_size = prop_number(n, "sun_size", o.sun_size);
      o = SkyTexture::normalized(o);
      const Vec3 sun = SkyTexture::nishita_sun_direction(o.sun_elevation, o.sun_rotation) * sg;
      if (!std::isfinite(sun.x) || !std::isfinite(o.sun_size)) {
        f.suns_complete = false;
        continue;
      }
      f.suns.push_back({normalize(mat_apply_t(M, sun)), o.sun_size});
    }
  if (!f.suns_complete) f.suns.clear();
  return f;
}

// ---- The shared bakes ----

// The graph's terms baked (WorldGraph::Term): what its sampling is combined from by the terms'
// weights. Shared by the graphs of one terms_key (sums) while a WorldBake holds it.
// What both bakes keep of the frame they were baked for, and of a sun's cone: written once.
struct BakedFrame {
  float frame[3][3];  // the graph's it was baked for
  float strength = 1.0f;
};
struct SunCone {
  Vec3 dir;  // in the baked graph's World
  double half = 0, one_minus_cos = 0;
};

struct WorldTermsBake {
  BakedTerms grid;  // without the sun discs that `cones` sample
  BakedFrame at;
  struct Cone : SunCone {
    std::vector<RGB> integral;  // per term: its value over the cone
  };
  std::vector<Cone> cones;
};

struct WorldBake {
  std::shared_ptr<const WorldTermsBake> terms;  // kept for re-weighting (sums only)
  BakedDirections grid;  // without the sun discs that `cones` sample
  BakedFrame at;
  struct Cone : SunCone {
    float p = 0;  // probability of this cone in sample()
  };
  std::vector<Cone> cones;
  float p_cones = 0;
  RGB integral{0.0f};  // grid and cones
};

namespace {
std::mutex g_bake_mutex;
std::map<std::string, std::weak_ptr<const WorldBake>> g_bakes;
std::map<std::string, std::weak_ptr<const WorldTermsBake>> g_terms;  // by terms_key

// The first one in for `key` kept (a bake runs parallel work outside the lock: two threads may
// make the same one); `made` stored when none is alive. Returns the one to use.
template <class T>
std::shared_ptr<const T> keep_first(std::map<std::string, std::weak_ptr<const T>>& cache, const std::string& key,
                                    std::shared_ptr<const T> made) {
  std::lock_guard lock(g_bake_mutex);
  auto& slot = cache[key];
  if (auto other = slot.lock()) return other;
  slot = made;
  for (auto it = cache.begin(); it != cache.end();) it = it->second.expired() ? cache.erase(it) : std::next(it);
  return made;
}

template <class T>
std::shared_ptr<const T> find_alive(const std::map<std::string, std::weak_ptr<const T>>& cache, const std::string& key) {
  std::lock_guard lock(g_bake_mutex);
  const auto it = cache.find(key);
  return it == cache.end() ? nullptr : it->second.lock();
}

Vec3 sample_cone(const Vec3& axis, double one_minus_cos_max, Vec2 u) {
  // Uniform in the cone: 1 - cos(theta) uniform in [0, 1 - cos(half)].
  const double omc = u.x * one_minus_cos_max;
  const double sin_t = std::sqrt(std::max(0.0, omc * (2.0 - omc)));
  const double ph = 2.0 * M_PI * u.y;
  const Frame fr(axis);
  return normalize(fr.to_world(Vec3(float(sin_t * std::cos(ph)), float(sin_t * std::sin(ph)), float(1.0 - omc))));
}
}  // namespace

namespace {
thread_local const Vec3* t_world_ray_origin = nullptr;
}  // namespace

WorldRayOrigin::WorldRayOrigin(const Vec3& origin) : origin_(origin), previous_(t_world_ray_origin) {
  t_world_ray_origin = &origin_;
}
WorldRayOrigin::~WorldRayOrigin() { t_world_ray_origin = previous_; }
const Vec3* WorldRayOrigin::get() { return t_world_ray_origin; }

size_t world_bake_cache_size() {
  std::lock_guard lock(g_bake_mutex);
  size_t n = 0;
  for (const auto& [k, v] : g_bakes) n += !v.expired();
  return n;
}

WorldGraph::~WorldGraph() = default;

WorldGraph::WorldGraph(std::shared_ptr<const shading::ShaderProgram> program, std::vector<WorldClosure> closures,
                       int sampling_width, const shading::ShadingCamera* camera, std::string identity,
                       const WorldGraphFrame* frame)
    : program_(std::move(program)), closures_(std::move(closures)), identity_(std::move(identity)) {
  if (closures_.empty()) throw std::invalid_argument("a World graph without a closure");
  for (size_t i = 0; i < closures_.size(); ++i) {
    const WorldClosure& c = closures_[i];
    if (c.kind == WorldClosure::Kind::Background) continue;
    // Children come before their parent: the list is a tree built bottom-up, never a cycle.
    if (c.a < 0 || c.b < 0 || size_t(c.a) >= i || size_t(c.b) >= i)
      throw std::invalid_argument("a World graph's Mix or Add closure without its two inputs");
  }
  if ((closures_.back().fac_linked || closures_.back().color_linked || closures_.back().strength_linked) && !program_)
    throw std::invalid_argument("a World graph's closure reads a node but there is no node program");
  if (camera) {
    camera_ = *camera;
    has_camera_ = true;
  }
  split_terms();
  const int width = sampling_width > 0 ? sampling_width : 1024;  // Cycles' default map resolution
  if (!frame) {
    baked_ = combine(bake_terms(width, WorldGraphFrame()), false);
    return;
  }
  // Share the bake of an equal key; else re-weight the terms' bake of an equal terms_key (a
  // sum's weights edited); else bake. Built outside the lock (a bake runs parallel work, which
  // must not wait on a lock another bake holds), the first one in kept.
  const std::string key = frame->key + "\n" + std::to_string(width);
  baked_ = find_alive(g_bakes, key);
  reused_ = baked_ != nullptr;
  if (!baked_) {
    const std::string terms_key = frame->terms_key.empty() ? "" : frame->terms_key + "\n" + std::to_string(width);
    std::shared_ptr<const WorldTermsBake> terms;
    if (!terms_key.empty()) terms = find_alive(g_terms, terms_key);
    reused_terms_ = terms != nullptr;
    if (!terms) {
      terms = bake_terms(width, *frame);
      if (!terms_key.empty()) {
        const auto kept = keep_first(g_terms, terms_key, terms);
        reused_terms_ = kept != terms;
        terms = kept;
      }
    }
    const auto made = combine(terms, !terms_key.empty());
    baked_ = keep_first(g_bakes, key, made);
    reused_ = baked_ != made;
  }
  // A bake made for the graph turned by F0 with strength s0: this one is s1 g(F1 d) =
  // (s1 / s0) x that graph along F0^T F1 d (a rotation: the density moves, unscaled). A bake of
  // this graph's own frame (the same rotation, or terms re-weighted in it) is used as it is, so
  // that it samples bit for bit as a fresh bake (F^T F is the identity only up to rounding).
  if (reused_) scale_ = frame->strength / baked_->at.strength;
  if ((reused_ || reused_terms_) && std::memcmp(baked_->at.frame, frame->frame, sizeof frame->frame) != 0) {
    turned_ = true;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        float q = 0;
        for (int k = 0; k < 3; ++k) q += baked_->at.frame[k][i] * frame->frame[k][j];
        q_[i][j] = q;
      }
  }
}

void WorldGraph::split_terms() {
  // The root an Add or a Mix of constant factor: the sum of the terms below (svm closure
  // weights: Add passes its weight to both, Mix (1 - f) and f with f clamped as closure() does).
  const WorldClosure& root = closures_.back();
  const bool sum = root.kind == WorldClosure::Kind::Add || (root.kind == WorldClosure::Kind::Mix && !root.fac_linked);
  if (!sum) {
    terms_ = {Term{int(closures_.size()) - 1, false, 1.0f}};
    return;
  }
  std::function<void(int, float)> walk = [&](int i, float w) {
    const WorldClosure& c = closures_[size_t(i)];
    if (c.kind == WorldClosure::Kind::Add) {
      walk(c.a, w);
      walk(c.b, w);
    } else if (c.kind == WorldClosure::Kind::Mix && !c.fac_linked) {
      const float f = std::isfinite(c.fac_constant) ? std::clamp(c.fac_constant, 0.0f, 1.0f) : 0.0f;
      walk(c.a, w * (1.0f - f));
      walk(c.b, w * f);
    } else if (c.kind == WorldClosure::Kind::Background && !c.strength_linked) {
      if (c.color_linked) terms_.push_back(Term{i, true, c.strength_constant * w});
      else constant_ += c.color_constant * (c.strength_constant * w);
    } else {
      terms_.push_back(Term{i, false, w});  // (a Mix of linked factor, a Background of linked strength)
    }
  };
  walk(int(closures_.size()) - 1, 1.0f);
}

Vec3 WorldGraph::to_bake(const Vec3& d) const { return turned_ ? normalize(mat_apply(q_, d)) : d; }
Vec3 WorldGraph::from_bake(const Vec3& v) const { return turned_ ? normalize(mat_apply_t(q_, v)) : v; }

RGB WorldGraph::integral() const { return baked_->integral * scale_; }
int WorldGraph::sampling_width() const { return baked_->grid.grid.nu(); }
int WorldGraph::sampling_height() const { return baked_->grid.grid.nv(); }
float WorldGraph::sun_probability() const { return baked_->p_cones; }

RGB WorldGraph::closure(int i, const Vec3* regs) const {
  const WorldClosure& c = closures_[size_t(i)];
  switch (c.kind) {
    case WorldClosure::Kind::Background: {
      const RGB color = c.color_linked ? RGB(regs[c.color.reg].x, regs[c.color.reg].y, regs[c.color.reg].z)
                                       : c.color_constant;
      const float s = c.strength_linked ? shading::as_float(regs[c.strength.reg], c.strength.conv) : c.strength_constant;
      return color * s;
    }
    case WorldClosure::Kind::Add: return closure(c.a, regs) + closure(c.b, regs);
    case WorldClosure::Kind::Mix: {
      // svm_node_mix_closure: the factor clamped to [0, 1] (saturatef).
      float f = c.fac_linked ? shading::as_float(regs[c.fac.reg], c.fac.conv) : c.fac_constant;
      f = std::isfinite(f) ? std::clamp(f, 0.0f, 1.0f) : 0.0f;
      RGB L(0.0f);
      if (f < 1.0f) L += closure(c.a, regs) * (1.0f - f);
      if (f > 0.0f) L += closure(c.b, regs) * f;
      return L;
    }
  }
  return RGB(0.0f);
}

// The node program's registers for a ray of state `ray` leaving the scene along `dir` (this
// thread's, valid until its next run; null without a program).
const Vec3* WorldGraph::run(const Vec3& dir, const RayState& ray) const {
  if (!program_) return nullptr;
  thread_local std::vector<Vec3> regs;
  shading::ShadingContext ctx = shading::ShadingContext::direction(dir);
  ctx.ray = ray;
  ctx.camera = has_camera_ ? &camera_ : nullptr;
  regs.resize(program_->num_registers());
  program_->run(ctx, regs.data());
  return regs.data();
}

namespace {
// A negative strength or colour (allowed by Blender) lights nothing here; NaN never leaves.
RGB lit(RGB L) {
  for (int k = 0; k < 3; ++k)
    if (!(L[k] > 0.0f) || !std::isfinite(L[k])) L[k] = 0.0f;
  return L;
}
}  // namespace

RGB WorldGraph::eval(const Vec3& dir, const RayState& ray) const {
  return lit(closure(int(closures_.size()) - 1, run(dir, ray)));
}

std::shared_ptr<const WorldTermsBake> WorldGraph::bake_terms(int width, const WorldGraphFrame& frame) const {
  auto t = std::make_shared<WorldTermsBake>();
  std::memcpy(t->at.frame, frame.frame, sizeof t->at.frame);
  t->at.strength = frame.strength;
  // Each term's value as a light sample sees the World (no path flags): one program run for all.
  const auto values = [this](const Vec3& d, RGB* out) {
    const Vec3* regs = run(d, RayState());
    for (size_t k = 0; k < terms_.size(); ++k) {
      const Term& term = terms_[k];
      const WorldClosure& c = closures_[size_t(term.closure)];
      out[k] = lit(term.colour ? RGB(regs[c.color.reg].x, regs[c.color.reg].y, regs[c.color.reg].z)
                               : closure(term.closure, regs));
    }
  };
  // W x W/2 equirectangular cells (environment_map.h's orientation), each the mean of S x S
  // evaluations (2 x 2 up to 1024 columns: a small bright feature is less likely to fall
  // between them). Sun discs the cones sample are left out.
  const int W = std::clamp(width, 4, 8192), H = std::max(2, W / 2);
  const int S = W <= 1024 ? 2 : 1;
  const bool cones = !frame.suns.empty();
  const int K = static_cast<int>(terms_.size());
  t->grid = bake_direction_terms(W, H, S, 0, K, [&values, cones](const Vec3& d, RGB* out) {
    if (!cones) return values(d, out);
    SkySunDiscsOff off;
    values(d, out);
  });
  // Each sun's light per term: the mean over a stratified grid of its cone.
  std::vector<RGB> v(size_t(K) + 1);
  for (const WorldGraphFrame::Sun& s : frame.suns) {
    WorldTermsBake::Cone c;
    c.dir = s.direction;
    c.half = 0.5 * s.size;
    c.one_minus_cos = 2.0 * std::sin(0.5 * c.half) * std::sin(0.5 * c.half);
    if (!(c.one_minus_cos > 0)) continue;
    const int n = 24;
    c.integral.assign(size_t(K), RGB(0.0f));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        values(sample_cone(c.dir, c.one_minus_cos, Vec2((i + 0.5f) / n, (j + 0.5f) / n)), v.data());
        for (int k = 0; k < K; ++k) c.integral[size_t(k)] += v[size_t(k)];
      }
    for (RGB& integral : c.integral) integral = integral * static_cast<float>(2.0 * M_PI * c.one_minus_cos / (n * n));
    t->cones.push_back(std::move(c));
  }
  return t;
}

std::shared_ptr<const WorldBake> WorldGraph::combine(std::shared_ptr<const WorldTermsBake> terms, bool keep) const {
  const WorldTermsBake& t = *terms;
  auto b = std::make_shared<WorldBake>();
  b->at = t.at;
  std::vector<float> weights;
  for (const Term& term : terms_) weights.push_back(term.weight);
  b->grid = combine_direction_terms(t.grid, weights, constant_);
  b->integral = b->grid.integral;
  // Each sun's power: its terms' light over the cone, weighted (a uniform term: its colour x
  // the cone's solid angle).
  std::vector<float> power;
  for (const WorldTermsBake::Cone& tc : t.cones) {
    RGB integral(0.0f);
    for (size_t k = 0; k < weights.size(); ++k) integral += tc.integral[k] * weights[k];
    if (!constant_.is_black()) integral += constant_ * static_cast<float>(2.0 * M_PI * tc.one_minus_cos);
    if (!(integral.average() > 0) || !std::isfinite(integral.average())) continue;  // below the horizon: dark
    WorldBake::Cone c;
    static_cast<SunCone&>(c) = tc;
    b->integral += integral;
    power.push_back(integral.average());
    b->cones.push_back(c);
  }
  const float total = b->integral.average();
  for (size_t i = 0; i < b->cones.size(); ++i) {
    b->cones[i].p = total > 0 ? power[i] / total : 0.0f;
    b->p_cones += b->cones[i].p;
  }
  if (!(b->p_cones < 1.0f)) b->p_cones = 0.0f, b->cones.clear();  // (a black sky: the sums round)
  if (keep) b->terms = std::move(terms);  // (it lives while a graph samples by it)
  return b;
}

bool WorldGraph::sample(Vec2 u, Vec3* dir, float* pdf) const {
  const WorldBake& b = *baked_;
  Vec3 v;
  if (u.x < b.p_cones) {
    // One of the suns' cones, in proportion to its power (one-sample MIS with the grid).
    float acc = 0;
    size_t i = 0;
    for (; i + 1 < b.cones.size() && u.x >= acc + b.cones[i].p; ++i) acc += b.cones[i].p;
    const float ux = std::min((u.x - acc) / b.cones[i].p, 0x1.fffffep-1f);
    v = sample_cone(b.cones[i].dir, b.cones[i].one_minus_cos, Vec2(ux, u.y));
  } else {
    if (b.p_cones > 0) u.x = std::min((u.x - b.p_cones) / (1.0f - b.p_cones), 0x1.fffffep-1f);
    if (!b.grid.sample(u, &v)) return false;
  }
  *dir = from_bake(v);
  *pdf = this->pdf(*dir);
  return std::isfinite(*pdf) && *pdf > 0;
}

float WorldGraph::pdf(const Vec3& dir) const {
  const WorldBake& b = *baked_;
  const Vec3 v = to_bake(dir);
  float p = b.grid.density(v) * (1.0f - b.p_cones);
  for (const WorldBake::Cone& c : b.cones)
    if (precise_angle(v, c.dir) <= c.half) p += static_cast<float>(c.p / (2.0 * M_PI * c.one_minus_cos));
  return std::isfinite(p) ? p : 0.0f;
}

}  // namespace gp
