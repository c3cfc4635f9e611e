// Shader node graphs (DESIGN.md "Blender: as Cycles does it"; docs/scene-format.md "Node graphs"):
// a material's `nodes` table, read from the scene JSON with Blender's node type names
// (bl_idname), socket identifiers and property names, checked (unknown types and sockets, wrong
// shapes, links to missing nodes, cycles, size), and compiled once into a flat program in
// topological order holding only the nodes the material's inputs need, with nodes whose inputs
// are all constant folded at compile time -- the role of Cycles' SVM compiler
// (scene/shader_graph.cpp). ShaderProgram::run() evaluates it at a shading point.
//
// Values live in registers of three floats: colours (RGB), vectors (XYZ), and floats splatted
// (v, v, v), so float -> colour/vector links need no conversion; colour -> float takes the
// Rec.709 luminance and vector -> float the average, as Cycles' convert nodes (svm/convert.h).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/color.h"
#include "core/math.h"
#include "shading/attributes.h"
#include "textures/texture.h"

namespace gp::shading {

enum class SocketType : uint8_t { Float, Vector, Color };

// What an object contributes to shading (Texture Coordinate's Generated and Object, Object
// Info, Vector Transform): its transforms and object-space bounds (Blender's auto texture
// space: Generated = (P_object - lo) / (hi - lo)).
// The scene's camera as shading sees it (Texture Coordinate's Camera and Window, Vector
// Transform's Camera space): Cycles' camera space (x right, y up, z towards the view: Blender's
// camera matrix with z negated, blender/camera.cpp) and the projection onto the frame.
struct ShadingCamera {
  Transform world_to_camera, camera_to_world;  // Cycles' camera space
  bool orthographic = false;
  Vec2 ext{1.0f, 1.0f};       // half extents of the image plane (at distance 1, or in metres)
  Vec2 shift{0.0f, 0.0f};     // Blender's shift, in the same units
  Vec3 camera_position;
  // Cycles' camera_world_to_ndc: (x, y) in [0, 1] over the frame from its bottom-left corner,
  // z 0. A World point is a direction, taken from the camera (Cycles adds its position).
  Vec3 window(const Vec3& p, bool direction) const {
    const Vec3 c = direction ? world_to_camera.vector(p) : world_to_camera.point(p);
    float sx = c.x, sy = c.y;
    if (!orthographic) {
      if (!(c.z != 0.0f)) return Vec3(0.0f);
      sx /= c.z, sy /= c.z;
    }
    return Vec3(0.5f * ((sx - shift.x) / ext.x + 1.0f), 0.5f * ((sy - shift.y) / ext.y + 1.0f), 0.0f);
  }
};

struct ShadingObject {
  Transform to_world, to_object;
  Bounds3 bounds;       // object space
  float random = 0.0f;  // Object Info's Random (Cycles: hash of the object's name)
  // Color Attribute / Attribute: the mesh's named attributes and its triangles' vertex indices
  // (null: none; valid while the scene's meshes are, as this object).
  const MeshAttributes* attributes = nullptr;
  const uint32_t* indices = nullptr;
  Vec3 location() const { return {to_world.m[0][3], to_world.m[1][3], to_world.m[2][3]}; }
};

// One shading point, as Cycles' ShaderData: what the input nodes read. Unknown fields keep their
// defaults (a context with only a direction, for the World: surface = false, I = -direction).
struct ShadingContext {
  Vec3 P;            // world position (the World: the direction)
  Vec3 N{0, 0, 1};   // shading normal (interpolated, before normal/bump maps: Cycles' sd->N)
  Vec3 Ng{0, 0, 1};  // geometric normal
  Vec3 I{0, 0, 1};   // unit direction towards the viewer (-ray direction)
  Vec2 uv;           // the mesh's UV map (barycentrics without one)
  Vec2 bary;         // barycentric (u, v) of the hit in its triangle (Geometry's Parametric)
  Vec3 dPdu, dPdv;   // surface tangents along u and v (zero: unknown; bump picks a frame)
  int prim = -1;     // the hit triangle in its object's mesh (attributes; -1: none)
  const ShadingObject* object = nullptr;
  // Where `object` is a moving object at the path's time (set_object_at), the copy it points to.
  std::shared_ptr<const ShadingObject> object_at_time;
  const ShadingCamera* camera = nullptr;  // Texture Coordinate's Camera and Window, Vector Transform
  bool backfacing = false;
  bool surface = true;
  // Light Path: what the integrator knows of the ray that arrived here (core/math.h RayState:
  // Cycles' path flags and bounce counts). Default: no path's ray (flags 0, depth 0), as a
  // light's emission evaluated for a light sample (Cycles' PATH_RAY_EMISSION).
  RayState ray;

  // `object` placed by `to_world` instead of its frame transform (a moving object at a time).
  void set_object_at(const ShadingObject& o, const Transform& to_world) {
    auto placed = std::make_shared<ShadingObject>(o);
    placed->to_world = to_world;
    placed->to_object = invert_affine(to_world);
    object = placed.get();
    object_at_time = std::move(placed);
  }

  ShadingContext() = default;
  // A surface hit's context, each field written once (Scene::shading_context: the default
  // members then overwritten cost a zero-fill of the whole context per graph run).
  ShadingContext(const Vec3& P_, const Vec3& N_, const Vec3& Ng_, const Vec3& I_, Vec2 uv_, Vec2 bary_,
                 const ShadingCamera* camera_, bool backfacing_)
      : P(P_), N(N_), Ng(Ng_), I(I_), uv(uv_), bary(bary_), camera(camera_), backfacing(backfacing_) {}

  // A context for a direction only (World shaders): P = dir, I = -dir.
  static ShadingContext direction(const Vec3& dir) {
    ShadingContext c;
    c.P = dir;
    c.I = -dir;
    c.N = -dir;
    c.Ng = -dir;
    c.surface = false;
    return c;
  }
  // A context knowing only a texture coordinate (tables, tests, uv-only callers).
  static ShadingContext at_uv(Vec2 uv) {
    ShadingContext c;
    c.uv = uv;
    c.P = Vec3(uv.x, uv.y, 0.0f);
    return c;
  }
  // The same surface moved by dP along it, uv by duv (bump's offset evaluations).
  ShadingContext offset(const Vec3& dP, Vec2 duv) const {
    ShadingContext c = *this;
    c.P = P + dP;
    c.uv = uv + duv;
    return c;
  }
};

// Thrown for a malformed graph; the message names the material and the node.
struct GraphError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr size_t kMaxGraphNodes = 4096;

struct NodeType;  // nodes.cpp: one per supported bl_idname
struct NodeData;  // a node's tables (colour ramp, curves, image)

// A node's properties, parsed from `props` into what its evaluation switches on.
struct NodeProps {
  int mode = 0, mode2 = 0, mode3 = 0, mode4 = 0;
  bool flag = false, flag2 = false;
  std::shared_ptr<const NodeData> data;
};

// Where an op reads one input from: a register, with the conversion to its socket's type.
enum class Conversion : uint8_t { None, ColorToFloat, VectorToFloat };
struct InputSource {
  uint32_t reg = 0;
  Conversion conv = Conversion::None;
};

struct EvalArgs;
using EvalFn = void (*)(EvalArgs&);

struct Op {
  const NodeType* type = nullptr;
  // What runs the op: type->eval, or the node's version specialised at compile time for its
  // properties and inputs (NodeType::specialize: the same maths without the mode switches).
  EvalFn eval = nullptr;
  NodeProps props;
  uint32_t first_in = 0, first_out = 0;  // into ShaderProgram::inputs_ / outputs_
  // Bump and Normal Map nodes re-run the ops upstream of their height input (bump_ops_).
  uint32_t first_sub = 0, n_sub = 0;
  uint32_t sub_input = 0;  // which input those ops feed
  std::string name;        // the node id, for messages
};

// A compiled graph: ops in topological order over a register file whose first registers hold
// the constants (folded values included). Immutable and shared by threads.
class ShaderProgram {
 public:
  // Evaluates every op into regs (size num_registers(), filled from constants() first).
  void run(const ShadingContext& ctx, Vec3* regs) const;
  // Runs, and returns the value at `source` (convenience for tests and single reads).
  Vec3 evaluate(const ShadingContext& ctx, InputSource source) const;
  // How many runs (of any program) this thread has made: what tests count to see that a
  // shading point evaluates each graph once.
  static uint64_t runs_on_this_thread();

  size_t num_registers() const { return constants_.size(); }
  const std::vector<Vec3>& constants() const { return constants_; }
  size_t op_count() const { return ops_.size(); }
  bool empty() const { return ops_.empty(); }
  // Whether an op reads the context's surface tangents (dPdu, dPdv: Bump, Normal Map, Geometry),
  // which a caller may then leave out of the context (Scene::shading_context).
  bool reads_tangents() const { return reads_tangents_; }
  // Whether the value at a source is constant (folded or never written by an op).
  bool is_constant(InputSource s) const { return s.reg < is_constant_.size() && is_constant_[s.reg]; }

 private:
  friend class GraphCompiler;
  friend struct EvalArgs;
  friend struct OpRunner;
  std::vector<Op> ops_;
  std::vector<InputSource> inputs_;
  std::vector<uint32_t> outputs_;  // register per output socket (kTrash when unused)
  std::vector<uint32_t> sub_ops_;  // op indices, per bump/normal-map op's range
  std::vector<Vec3> constants_;
  std::vector<bool> is_constant_;
  uint32_t trash_ = 0;  // the register unused outputs are written to
  bool reads_tangents_ = false;
  void run_op(uint32_t i, const ShadingContext& ctx, Vec3* regs) const;
};

// Reads a register as the type a consumer wants.
inline float as_float(const Vec3& v, Conversion c) {
  switch (c) {
    // Cycles 3.4 with Blender's config: the Y row of sRGB/Rec.709 to XYZ (rgb_to_luminance).
    case Conversion::ColorToFloat: return 0.2126729f * v.x + 0.7151522f * v.y + 0.0721750f * v.z;
    case Conversion::VectorToFloat: return (v.x + v.y + v.z) * (1.0f / 3.0f);
    case Conversion::None: return v.x;
  }
  return v.x;
}

// Loads an image for an Image Texture node: (path as written, colour space) -> image; `warning`
// set when something was approximated. Paths are resolved by the caller (relative to the file).
using ImageLoader = std::function<std::shared_ptr<const TextureImage>(const std::string& path,
                                                                     const std::string& colorspace,
                                                                     std::string* warning)>;

// Reads one material's `nodes` table and compiles what its inputs link to:
//   GraphCompiler g("Ground", nodes_json, loader);
//   int color = g.link(link_json, SocketType::Color);        // each linked material input
//   std::shared_ptr<const ShaderProgram> p = g.compile();   // after every link
//   InputSource s = g.source(color);                         // where p leaves that value
// Throws GraphError naming the material and the node.
class GraphCompiler {
 public:
  GraphCompiler(std::string material, const nlohmann::json& nodes, ImageLoader images);
  ~GraphCompiler();
  // {"link": node_id, "output": output_identifier} read as `want`.
  int link(const nlohmann::json& link, SocketType want);
  std::shared_ptr<const ShaderProgram> compile();
  InputSource source(int root) const;
  // Whether ops may run a node's specialised evaluation (default: yes); off, every op runs its
  // node type's general one (tests compare the two).
  void set_specialize(bool on);
  // Warnings met while reading (unsupported property values approximated, image problems).
  const std::vector<std::string>& warnings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Whether `j` is a link object ({"link": ...}).
bool is_link(const nlohmann::json& j);

// The node types (bl_idname) the evaluator knows, sorted.
std::vector<std::string> supported_node_types();

}  // namespace gp::shading
