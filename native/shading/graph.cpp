// Reading, checking and compiling node graphs (graph.h), and running the compiled program.
#include "shading/graph.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "shading/node_types.h"
#include "shading/thread_registers.h"

namespace gp::shading {

using nlohmann::json;

// ---- Properties ----

const json* PropReader::get(const char* key) const {
  if (!props_) return nullptr;
  auto it = props_->find(key);
  return it == props_->end() || it->is_null() ? nullptr : &*it;
}
void PropReader::fail(const std::string& message) const { throw GraphError(fmt::format("{}: {}", where_, message)); }
void PropReader::warn(const std::string& message) const {
  if (warnings_) warnings_->push_back(fmt::format("{}: {}", where_, message));
}
int PropReader::choice(const char* key, std::initializer_list<const char*> names, int def) const {
  const json* j = get(key);
  if (!j) return def;
  if (!j->is_string()) fail(fmt::format("property '{}' must be a string, got {}", key, j->type_name()));
  const std::string v = j->get<std::string>();
  int i = 0;
  for (const char* n : names) {
    if (v == n) return i;
    ++i;
  }
  std::string known;
  for (const char* n : names) known += (known.empty() ? "" : ", ") + std::string(n);
  fail(fmt::format("property '{}': unknown value '{}' (known: {})", key, v, known));
}
bool PropReader::boolean(const char* key, bool def) const {
  const json* j = get(key);
  if (!j) return def;
  if (!j->is_boolean()) fail(fmt::format("property '{}' must be true or false", key));
  return j->get<bool>();
}
int PropReader::integer(const char* key, int def, int lo, int hi) const {
  const json* j = get(key);
  if (!j) return def;
  if (!j->is_number()) fail(fmt::format("property '{}' must be a number", key));
  const double v = j->get<double>();
  if (!(v >= lo && v <= hi)) fail(fmt::format("property '{}' must be in [{}, {}] (got {})", key, lo, hi, v));
  return static_cast<int>(v);
}
float PropReader::number(const char* key, float def) const {
  const json* j = get(key);
  if (!j) return def;
  if (!j->is_number()) fail(fmt::format("property '{}' must be a number", key));
  const float v = j->get<float>();
  if (!std::isfinite(v)) fail(fmt::format("property '{}' must be finite", key));
  return v;
}
std::string PropReader::string(const char* key, const std::string& def) const {
  const json* j = get(key);
  if (!j) return def;
  if (!j->is_string()) fail(fmt::format("property '{}' must be a string", key));
  return j->get<std::string>();
}

bool is_link(const json& j) { return j.is_object() && j.contains("link"); }

// ---- Running ----

float EvalArgs::height_at(const ShadingContext& moved) const {
  // The ops upstream of the height input, run again into a copy of the registers.
  const uint32_t n = static_cast<uint32_t>(prog.num_registers());
  thread_local std::vector<std::vector<Vec3>> pool;
  thread_local size_t depth = 0;
  if (pool.size() <= depth) pool.resize(depth + 1);
  std::vector<Vec3>& scratch = pool[depth];
  scratch.assign(regs, regs + n);
  ++depth;
  for (uint32_t k = 0; k < op.n_sub; ++k) prog.run_op(prog.sub_ops_[op.first_sub + k], moved, scratch.data());
  --depth;
  const InputSource& s = prog.inputs_[op.first_in + op.sub_input];
  return as_float(scratch[s.reg], s.conv);
}

void ShaderProgram::run_op(uint32_t i, const ShadingContext& ctx, Vec3* regs) const {
  const Op& op = ops_[i];
  EvalArgs a{*this, op, ctx, regs, inputs_.data() + op.first_in, outputs_.data() + op.first_out};
  (op.eval ? op.eval : op.type->eval)(a);  // (constant folding runs ops before Op::eval is set)
}

namespace {
thread_local uint64_t tl_runs = 0;
}  // namespace
uint64_t ShaderProgram::runs_on_this_thread() { return tl_runs; }

// The ops in order over registers already holding the constants (graph.h's friend).
struct OpRunner {
  static void run_ops(const ShaderProgram& p, const ShadingContext& ctx, Vec3* regs) {
    const InputSource* in = p.inputs_.data();
    const uint32_t* outs = p.outputs_.data();
    for (const Op& op : p.ops_) {
      EvalArgs a{p, op, ctx, regs, in + op.first_in, outs + op.first_out};
      op.eval(a);
    }
  }
};

void ShaderProgram::run(const ShadingContext& ctx, Vec3* regs) const {
  ++tl_runs;
  std::copy(constants_.begin(), constants_.end(), regs);
  OpRunner::run_ops(*this, ctx, regs);
}

namespace {
// One program's register file on a thread. The weak pointer names the program by its control
// block, which it keeps allocated: no later program can take a released one's identity, so a
// file found is that program's (an expired entry is never matched, only replaced).
struct ThreadRegisters {
  std::weak_ptr<const ShaderProgram> program;
  std::vector<Vec3> regs;
};
// Enough for the materials a path meets in turn (a mix's components included); more alternating
// programs only copy their constants again, as run() does.
constexpr int kThreadRegisterFiles = 8;
thread_local ThreadRegisters tl_files[kThreadRegisterFiles];
thread_local int tl_next_file = 0;
}  // namespace

const Vec3* run_in_thread_registers(const std::shared_ptr<const ShaderProgram>& program, const ShadingContext& ctx) {
  ThreadRegisters* file = nullptr;
  for (ThreadRegisters& f : tl_files)
    if (!f.program.owner_before(program) && !program.owner_before(f.program)) {  // same control block
      file = &f;
      break;
    }
  if (!file) {
    file = &tl_files[tl_next_file];
    tl_next_file = (tl_next_file + 1) % kThreadRegisterFiles;
    file->program = program;
    file->regs.assign(program->constants().begin(), program->constants().end());
  }
  ++tl_runs;
  OpRunner::run_ops(*program, ctx, file->regs.data());
  return file->regs.data();
}

Vec3 ShaderProgram::evaluate(const ShadingContext& ctx, InputSource source) const {
  thread_local std::vector<Vec3> regs;
  regs.resize(num_registers());
  run(ctx, regs.data());
  const Vec3 v = regs[source.reg];
  return source.conv == Conversion::None ? v : Vec3(as_float(v, source.conv));
}

// ---- Reading and compiling ----

struct ParsedInput {
  bool linked = false;
  bool given = false;    // a constant written in the file (not the socket's default)
  int node = -1;         // linked: the upstream node
  int output = -1;       // linked: its output index
  Vec3 value;            // constant
};
struct ParsedNode {
  std::string id;
  const NodeType* type = nullptr;
  NodeProps props;
  std::vector<ParsedInput> inputs;
};

struct GraphCompiler::Impl {
  std::string material;
  ImageLoader images;
  std::vector<std::string> warnings;
  std::vector<ParsedNode> nodes;
  std::unordered_map<std::string, int> index;
  struct Root {
    int node, output;
    SocketType want;
  };
  std::vector<Root> roots;
  std::vector<InputSource> root_sources;
  bool specialize = true;  // set_specialize

  std::string where(const std::string& node) const { return fmt::format("material '{}', node '{}'", material, node); }
  [[noreturn]] void fail(const std::string& node, const std::string& msg) const {
    throw GraphError(fmt::format("{}: {}", where(node), msg));
  }

  // A link object resolved to (node, output index); `from` names the node holding it.
  std::pair<int, int> resolve(const json& link, const std::string& from) const {
    if (!link.is_object()) fail(from, "a link must be {\"link\": node, \"output\": identifier}");
    for (auto it = link.begin(); it != link.end(); ++it)
      if (it.key() != "link" && it.key() != "output") fail(from, fmt::format("unknown key '{}' in a link", it.key()));
    const json& l = link["link"];
    if (!l.is_string()) fail(from, "a link's 'link' must be a node id (a string)");
    const std::string target = l.get<std::string>();
    auto found = index.find(target);
    if (found == index.end()) fail(from, fmt::format("link to a missing node '{}'", target));
    const ParsedNode& t = nodes[found->second];
    const auto& outs = t.type->outputs;
    int out = 0;
    if (auto o = link.find("output"); o != link.end()) {
      if (!o->is_string()) fail(from, "a link's 'output' must be an output identifier (a string)");
      const std::string name = o->get<std::string>();
      out = -1;
      for (size_t k = 0; k < outs.size(); ++k)
        if (name == outs[k].id) out = static_cast<int>(k);
      if (out < 0) {
        std::string known;
        for (const auto& s : outs) known += (known.empty() ? "" : ", ") + std::string(s.id);
        fail(from, fmt::format("node '{}' ({}) has no output '{}' (outputs: {})", target, t.type->idname, name, known));
      }
    }
    return {found->second, out};
  }

  Vec3 constant(const json& v, const SocketDesc& s, const std::string& node) const {
    if (s.type == SocketType::Float) {
      if (!v.is_number()) fail(node, fmt::format("input '{}' must be a number or a link, got {}", s.id, v.type_name()));
      const float f = v.get<float>();
      if (!std::isfinite(f)) fail(node, fmt::format("input '{}' is not finite", s.id));
      return Vec3(f);
    }
    if (!v.is_array() || v.size() < 3 || v.size() > 4)
      fail(node, fmt::format("input '{}' must be [x, y, z] (a colour may add alpha) or a link, got {}", s.id,
                             v.is_array() ? fmt::format("{} numbers", v.size()) : std::string(v.type_name())));
    Vec3 r;
    for (int i = 0; i < 3; ++i) {
      if (!v[i].is_number()) fail(node, fmt::format("input '{}' must hold numbers", s.id));
      r[i] = v[i].get<float>();
      if (!std::isfinite(r[i])) fail(node, fmt::format("input '{}' is not finite", s.id));
    }
    return r;
  }

  void parse(const json& table) {
    if (!table.is_object()) throw GraphError(fmt::format("material '{}': 'nodes' must be an object", material));
    if (table.size() > kMaxGraphNodes)
      throw GraphError(fmt::format("material '{}': node graph of {} nodes is over the limit of {}", material,
                                   table.size(), kMaxGraphNodes));
    for (auto it = table.begin(); it != table.end(); ++it) {
      const std::string& id = it.key();
      const json& n = it.value();
      if (!n.is_object()) fail(id, "a node must be an object");
      auto t = n.find("type");
      if (t == n.end() || !t->is_string()) fail(id, "missing 'type' (a Blender bl_idname)");
      const NodeType* type = find_node_type(t->get<std::string>());
      if (!type) fail(id, fmt::format("unknown node type '{}'", t->get<std::string>()));
      ParsedNode p;
      p.id = id;
      p.type = type;
      index[id] = static_cast<int>(nodes.size());
      nodes.push_back(std::move(p));
    }
    for (ParsedNode& p : nodes) {
      const json& n = table[p.id];
      for (auto k = n.begin(); k != n.end(); ++k)
        if (k.key() != "type" && k.key() != "props" && k.key() != "inputs")
          fail(p.id, fmt::format("unknown key '{}' (known: type, props, inputs)", k.key()));
      const json* props = nullptr;
      if (auto pr = n.find("props"); pr != n.end()) {
        if (!pr->is_object()) fail(p.id, "'props' must be an object");
        props = &*pr;
      }
      if (p.type->parse) p.type->parse(PropReader(props, where(p.id), &images, &warnings), p.props);
      p.inputs.resize(p.type->inputs.size());
      for (size_t k = 0; k < p.type->inputs.size(); ++k) p.inputs[k].value = p.type->inputs[k].def;
      if (auto in = n.find("inputs"); in != n.end()) {
        if (!in->is_object()) fail(p.id, "'inputs' must be an object keyed by socket identifier");
        for (auto k = in->begin(); k != in->end(); ++k) {
          int slot = -1;
          for (size_t s = 0; s < p.type->inputs.size(); ++s)
            if (k.key() == p.type->inputs[s].id) slot = static_cast<int>(s);
          if (slot < 0) {
            std::string known;
            for (const auto& s : p.type->inputs) known += (known.empty() ? "" : ", ") + std::string(s.id);
            fail(p.id, fmt::format("{} has no input '{}' (inputs: {})", p.type->idname, k.key(),
                                   known.empty() ? "none" : known));
          }
          ParsedInput& pi = p.inputs[slot];
          if (is_link(k.value())) {
            const auto [node, out] = resolve(k.value(), p.id);
            pi.linked = true, pi.node = node, pi.output = out;
          } else {
            pi.value = constant(k.value(), p.type->inputs[slot], p.id);
            pi.given = true;
          }
        }
      }
    }
    // Cycles anywhere in the table are errors, reached or not (Blender marks them invalid).
    std::vector<int> state(nodes.size(), 0);
    for (size_t i = 0; i < nodes.size(); ++i) check_cycle(static_cast<int>(i), state);
  }

  void check_cycle(int start, std::vector<int>& state) const {
    // Iterative DFS (graphs of thousands of nodes must not exhaust the stack).
    if (state[start] == 2) return;
    std::vector<std::pair<int, size_t>> stack{{start, 0}};
    state[start] = 1;
    while (!stack.empty()) {
      auto& [n, k] = stack.back();
      const ParsedNode& p = nodes[n];
      if (k < p.inputs.size()) {
        const ParsedInput& in = p.inputs[k++];
        if (!in.linked) continue;
        if (state[in.node] == 1)
          fail(p.id, fmt::format("cycle: input '{}' depends on this node's own output (through '{}')",
                                 p.type->inputs[k - 1].id, nodes[in.node].id));
        if (state[in.node] == 0) {
          state[in.node] = 1;
          stack.push_back({in.node, 0});
        }
      } else {
        state[n] = 2;
        stack.pop_back();
      }
    }
  }
};

GraphCompiler::GraphCompiler(std::string material, const json& nodes, ImageLoader images)
    : impl_(std::make_unique<Impl>()) {
  impl_->material = std::move(material);
  impl_->images = std::move(images);
  impl_->parse(nodes);
}
GraphCompiler::~GraphCompiler() = default;

const std::vector<std::string>& GraphCompiler::warnings() const { return impl_->warnings; }

int GraphCompiler::link(const json& link, SocketType want) {
  const auto [node, out] = impl_->resolve(link, "(material input)");
  impl_->roots.push_back({node, out, want});
  return static_cast<int>(impl_->roots.size()) - 1;
}

InputSource GraphCompiler::source(int root) const { return impl_->root_sources.at(root); }
void GraphCompiler::set_specialize(bool on) { impl_->specialize = on; }

namespace {
Conversion conversion(SocketType from, SocketType to) {
  if (to != SocketType::Float || from == SocketType::Float) return Conversion::None;
  return from == SocketType::Color ? Conversion::ColorToFloat : Conversion::VectorToFloat;
}
}  // namespace

std::shared_ptr<const ShaderProgram> GraphCompiler::compile() {
  Impl& g = *impl_;
  auto prog = std::make_shared<ShaderProgram>();
  const size_t n = g.nodes.size();

  // ---- Reached nodes in topological order (post-order from the roots) ----
  std::vector<int> order;
  std::vector<char> seen(n, 0);
  for (const auto& r : g.roots) {
    if (seen[r.node]) continue;
    std::vector<std::pair<int, size_t>> stack{{r.node, 0}};
    seen[r.node] = 1;
    while (!stack.empty()) {
      auto& [v, k] = stack.back();
      const ParsedNode& p = g.nodes[v];
      if (k < p.inputs.size()) {
        const ParsedInput& in = p.inputs[k++];
        if (in.linked && !seen[in.node]) {
          seen[in.node] = 1;
          stack.push_back({in.node, 0});
        }
      } else {
        order.push_back(v);
        stack.pop_back();
      }
    }
  }

  // ---- Which outputs are read ----
  std::vector<std::vector<char>> used(n);
  for (int v : order) used[v].assign(g.nodes[v].type->outputs.size(), 0);
  for (int v : order)
    for (const ParsedInput& in : g.nodes[v].inputs)
      if (in.linked) used[in.node][in.output] = 1;
  for (const auto& r : g.roots) used[r.node][r.output] = 1;

  // ---- Registers: constants and outputs ----
  std::vector<Vec3> regs;  // initial values
  std::vector<bool> is_const;
  auto new_reg = [&](const Vec3& v, bool c) {
    regs.push_back(v);
    is_const.push_back(c);
    return static_cast<uint32_t>(regs.size() - 1);
  };
  const uint32_t trash = new_reg(Vec3(0.0f), false);  // the first: kTrashRegister (EvalArgs::used)
  static_assert(kTrashRegister == 0);
  prog->trash_ = trash;
  std::vector<std::vector<uint32_t>> out_reg(n);
  for (int v : order) {
    const ParsedNode& p = g.nodes[v];
    for (size_t k = 0; k < p.type->outputs.size(); ++k)
      out_reg[v].push_back(used[v][k] ? new_reg(Vec3(0.0f), false) : trash);
  }

  // ---- Ops ----
  std::map<Implicit, uint32_t> implicit_reg;  // one hidden input op per kind
  auto implicit_source = [&](Implicit kind) {
    auto it = implicit_reg.find(kind);
    if (it != implicit_reg.end()) return it->second;
    Op op;
    op.type = implicit_node_type();
    op.props.mode = static_cast<int>(kind);
    op.name = "(implicit)";
    op.first_in = static_cast<uint32_t>(prog->inputs_.size());
    op.first_out = static_cast<uint32_t>(prog->outputs_.size());
    const uint32_t r = new_reg(Vec3(0.0f), false);
    prog->outputs_.push_back(r);
    prog->ops_.insert(prog->ops_.begin(), std::move(op));  // inputs first: they depend on nothing
    implicit_reg[kind] = r;
    return r;
  };
  std::vector<int> op_of_node(n, -1);
  for (int v : order) {
    const ParsedNode& p = g.nodes[v];
    Op op;
    op.type = p.type;
    op.props = p.props;
    op.name = p.id;
    op.first_in = static_cast<uint32_t>(prog->inputs_.size());
    for (size_t k = 0; k < p.inputs.size(); ++k) {
      const ParsedInput& in = p.inputs[k];
      const SocketDesc& s = p.type->inputs[k];
      InputSource src;
      if (in.linked) {
        src.reg = out_reg[in.node][in.output];
        src.conv = conversion(g.nodes[in.node].type->outputs[in.output].type, s.type);
      } else if (s.implicit != Implicit::None && !in.given) {
        src.reg = implicit_source(s.implicit);
      } else {
        src.reg = new_reg(in.value, true);
      }
      prog->inputs_.push_back(src);
    }
    op.first_out = static_cast<uint32_t>(prog->outputs_.size());
    for (uint32_t r : out_reg[v]) prog->outputs_.push_back(r);
    prog->ops_.push_back(std::move(op));
  }
  // (implicit ops were inserted at the front: recompute the node -> op index map)
  for (size_t i = 0; i < prog->ops_.size(); ++i) {
    auto it = g.index.find(prog->ops_[i].name);
    if (it != g.index.end() && prog->ops_[i].type != implicit_node_type()) op_of_node[it->second] = static_cast<int>(i);
  }

  // ---- Constant folding: ops whose inputs are all constant and that read no context ----
  {
    ShadingContext none;
    std::vector<Vec3> file = regs;
    std::vector<Op> kept;
    std::vector<char> folded(prog->ops_.size(), 0);
    for (size_t i = 0; i < prog->ops_.size(); ++i) {
      const Op& op = prog->ops_[i];
      bool all_const = !op.type->reads_context;
      for (size_t k = 0; all_const && k < op.type->inputs.size(); ++k)
        all_const = is_const[prog->inputs_[op.first_in + k].reg];
      if (!all_const) continue;
      prog->run_op(static_cast<uint32_t>(i), none, file.data());
      for (size_t k = 0; k < op.type->outputs.size(); ++k) {
        const uint32_t r = prog->outputs_[op.first_out + k];
        if (r != trash) is_const[r] = true;
      }
      folded[i] = 1;
    }
    // Folded values become initial register values; the folded ops go.
    for (size_t r = 0; r < regs.size(); ++r)
      if (is_const[r]) regs[r] = file[r];
    std::vector<int> new_index(prog->ops_.size(), -1);
    for (size_t i = 0; i < prog->ops_.size(); ++i)
      if (!folded[i]) {
        new_index[i] = static_cast<int>(kept.size());
        kept.push_back(std::move(prog->ops_[i]));
      }
    prog->ops_ = std::move(kept);
    for (int& o : op_of_node) o = o >= 0 ? new_index[o] : -1;
  }

  // ---- Bump: the ops upstream of the height input, re-run at moved points ----
  for (Op& op : prog->ops_) {
    if (op.type->height_input < 0) continue;
    const int v = g.index.at(op.name);
    const ParsedInput& h = g.nodes[v].inputs[op.type->height_input];
    op.sub_input = static_cast<uint32_t>(op.type->height_input);
    op.first_sub = static_cast<uint32_t>(prog->sub_ops_.size());
    if (!h.linked) continue;
    // Upstream nodes of the height, in program order (which is topological).
    std::vector<char> up(n, 0);
    std::vector<int> stack{h.node};
    up[h.node] = 1;
    while (!stack.empty()) {
      const int u = stack.back();
      stack.pop_back();
      for (const ParsedInput& in : g.nodes[u].inputs)
        if (in.linked && !up[in.node]) up[in.node] = 1, stack.push_back(in.node);
    }
    std::vector<uint32_t> subs;
    for (size_t i = 0; i < prog->ops_.size(); ++i) {
      const Op& o = prog->ops_[i];
      if (o.type == implicit_node_type()) {
        subs.push_back(static_cast<uint32_t>(i));  // hidden inputs read the moved point too
        continue;
      }
      auto it = g.index.find(o.name);
      if (it != g.index.end() && up[it->second]) subs.push_back(static_cast<uint32_t>(i));
    }
    op.n_sub = static_cast<uint32_t>(subs.size());
    prog->sub_ops_.insert(prog->sub_ops_.end(), subs.begin(), subs.end());
  }

  for (Op& op : prog->ops_) {
    prog->reads_tangents_ = prog->reads_tangents_ || op.type->reads_tangents;
    // The node's specialised evaluation for its properties and inputs, where it has one.
    const EvalFn fast = g.specialize && op.type->specialize
                            ? op.type->specialize(op.props, prog->inputs_.data() + op.first_in,
                                                prog->outputs_.data() + op.first_out)
                            : nullptr;
    op.eval = fast ? fast : op.type->eval;
  }
  prog->constants_ = std::move(regs);
  prog->is_constant_ = std::move(is_const);
  g.root_sources.clear();
  for (const auto& r : g.roots) {
    InputSource s;
    s.reg = out_reg[r.node][r.output];
    s.conv = conversion(g.nodes[r.node].type->outputs[r.output].type, r.want);
    g.root_sources.push_back(s);
  }
  return prog;
}

}  // namespace gp::shading
