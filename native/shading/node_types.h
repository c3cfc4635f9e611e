// Internal to native/shading: the table of node types (nodes.cpp) the compiler (graph.cpp)
// reads. One NodeType per Blender bl_idname: its sockets with Blender 3.4's identifiers and
// defaults, the parser of its properties and its evaluation, named after the node.
#pragma once

#include <initializer_list>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "shading/graph.h"

namespace gp {
class SkyTexture;  // lights/sky.h
}

namespace gp::shading {

// What an unlinked input without a value of its own reads (Cycles' SocketType::LINK_*).
enum class Implicit : uint8_t { None, Generated, UV, Normal, Position };

struct SocketDesc {
  const char* id;
  SocketType type;
  Vec3 def;
  Implicit implicit = Implicit::None;
};

// Curves of an RGB / Float / Vector Curves node: points sampled by the exporter, evaluated
// piecewise linearly (as Cycles' 256-entry tables), extrapolated or extended past the ends.
struct Curve {
  std::vector<Vec2> points;  // sorted by x
  float eval(float x, bool extrapolate) const;
};

struct NodeData {
  std::vector<Vec3> table;      // Color Ramp: Cycles' 256-entry table (kernel/svm/ramp.h)
  std::vector<float> alpha;     // its alpha
  std::vector<Curve> curves;    // RGB (R, G, B, combined) / Vector (X, Y, Z) / Float curves
  bool extrapolate = true;
  std::shared_ptr<const TextureImage> image;
  float blend = 0.0f;           // Image's projection_blend
  std::string name;             // Color Attribute's layer_name, Attribute's attribute_name
  std::shared_ptr<const SkyTexture> sky;  // Sky Texture: the precomputed sky (shared)
  Transform transform;          // Texture Coordinate with an object: the inverse of its matrix
};

class PropReader {
 public:
  PropReader(const nlohmann::json* props, std::string where, const ImageLoader* images,
             std::vector<std::string>* warnings)
      : props_(props), where_(std::move(where)), images_(images), warnings_(warnings) {}
  const nlohmann::json* get(const char* key) const;
  // The index of the enum identifier at `key` in `names`, `def` when absent.
  int choice(const char* key, std::initializer_list<const char*> names, int def) const;
  bool boolean(const char* key, bool def) const;
  int integer(const char* key, int def, int lo, int hi) const;
  float number(const char* key, float def) const;
  std::string string(const char* key, const std::string& def) const;
  [[noreturn]] void fail(const std::string& message) const;
  void warn(const std::string& message) const;
  const ImageLoader* images() const { return images_; }
  const std::string& where() const { return where_; }

 private:
  const nlohmann::json* props_;
  std::string where_;
  const ImageLoader* images_;
  std::vector<std::string>* warnings_;
};

// The register unused outputs are written to: the first (GraphCompiler::compile makes it so).
inline constexpr uint32_t kTrashRegister = 0;

struct EvalArgs;
struct NodeType {
  const char* idname;
  std::vector<SocketDesc> inputs, outputs;
  void (*parse)(const PropReader&, NodeProps&) = nullptr;
  // Writes each output the program reads (EvalArgs::used) on every run, whatever the inputs (an
  // early return writes them first), or on none: the thread register files keep the last run's
  // values (thread_registers.h), so an output written on some runs only would read a stale one.
  void (*eval)(EvalArgs&) = nullptr;
  bool reads_context = false;  // never constant-folded (input nodes, bump)
  int height_input = -1;       // Bump: the input re-evaluated at offset points
  bool reads_tangents = false; // reads the context's dPdu / dPdv (ShaderProgram::reads_tangents)
  // A faster eval for an op of these properties, inputs and outputs (`in`: its input sources,
  // `outs`: its output registers, kTrashRegister where unread), giving
  // bit for bit what `eval` gives, or null (graph.cpp sets Op::eval from it; set after the
  // table's aggregate initialisers, which stop at reads_tangents).
  EvalFn (*specialize)(const NodeProps&, const InputSource* in, const uint32_t* outs) = nullptr;
};

// The evaluation of one op: its inputs read (converted) and outputs written. `in` and `outs`
// point at the op's slices of the program's tables (set once per op: a read is one lookup).
struct EvalArgs {
  const ShaderProgram& prog;
  const Op& op;
  const ShadingContext& ctx;
  Vec3* regs;
  const InputSource* in;
  const uint32_t* outs;
  Vec3 v(int i) const { return regs[in[i].reg]; }
  // A float input known (at compile time) to need no conversion: f(i) without the test.
  float x(int i) const { return regs[in[i].reg].x; }
  float f(int i) const {
    const InputSource& s = in[i];
    const Vec3& r = regs[s.reg];
    return __builtin_expect(s.conv == Conversion::None, 1) ? r.x : as_float(r, s.conv);
  }
  bool used(int j) const { return outs[j] != kTrashRegister; }  // (one load, no program read)
  void out(int j, const Vec3& x) const { regs[outs[j]] = x; }
  void out(int j, float x) const { regs[outs[j]] = Vec3(x); }
  // Bump: the height input evaluated at a moved shading point.
  float height_at(const ShadingContext& moved) const;
};

const NodeType* find_node_type(const std::string& idname);
const std::vector<NodeType>& node_types();
// The hidden input node that supplies an implicit default (graph.cpp inserts it).
const NodeType* implicit_node_type();

}  // namespace gp::shading
