// Helpers of the shading tests: a node table from JSON text, compiled for one output.
#pragma once

#include <nlohmann/json.hpp>

#include <memory>
#include <string>

#include "shading/graph.h"

namespace gp::shading::test {

struct Compiled {
  std::shared_ptr<const ShaderProgram> program;
  InputSource source;
  Vec3 at(const ShadingContext& c) const { return program->evaluate(c, source); }
  float f(const ShadingContext& c) const { return at(c).x; }
};

// Compiles `nodes` (a JSON object text) for output `output` of node `node`, read as `want`.
inline Compiled compile_output(const std::string& nodes, const std::string& node, const std::string& output,
                               SocketType want = SocketType::Color, ImageLoader images = nullptr) {
  GraphCompiler g("M", nlohmann::json::parse(nodes), std::move(images));
  const int root = g.link(nlohmann::json{{"link", node}, {"output", output}}, want);
  Compiled c;
  c.program = g.compile();
  c.source = g.source(root);
  return c;
}

// One node of type `type` with `props` and constant `inputs` (JSON texts), read at `output`.
inline Compiled one_node(const std::string& type, const std::string& props, const std::string& inputs,
                         const std::string& output, SocketType want = SocketType::Color) {
  return compile_output("{\"n\": {\"type\": \"" + type + "\", \"props\": " + props + ", \"inputs\": " + inputs + "}}",
                        "n", output, want);
}

}  // namespace gp::shading::test
