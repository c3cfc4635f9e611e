// Node graphs: malformed tables refused with the material and node named; compilation keeps
// only what the outputs need and folds constants; conversions between socket types.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "shading/graph.h"
#include "shading/node_types.h"
#include "shading/thread_registers.h"
#include "shading_test_util.h"

namespace gp::shading {
namespace {

using test::compile_output;
using test::one_node;

std::string error_of(const std::string& nodes, const std::string& node = "a", const std::string& output = "Color") {
  try {
    compile_output(nodes, node, output);
  } catch (const GraphError& e) {
    return e.what();
  }
  return "";
}

TEST(ShadingGraph, UnknownNodeTypeNamesMaterialAndNode) {
  const std::string e = error_of(R"({"a": {"type": "ShaderNodeTexBogus"}})");
  EXPECT_NE(e.find("material 'M'"), std::string::npos) << e;
  EXPECT_NE(e.find("node 'a'"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown node type 'ShaderNodeTexBogus'"), std::string::npos) << e;
}

TEST(ShadingGraph, UnknownInputSocket) {
  const std::string e = error_of(R"({"a": {"type": "ShaderNodeTexChecker", "inputs": {"Colour1": [1, 0, 0]}}})");
  EXPECT_NE(e.find("node 'a'"), std::string::npos) << e;
  EXPECT_NE(e.find("no input 'Colour1'"), std::string::npos) << e;
}

TEST(ShadingGraph, UnknownOutputSocket) {
  const std::string e = error_of(R"({"a": {"type": "ShaderNodeTexChecker"}})", "a", "Colour");
  EXPECT_NE(e.find("no output 'Colour'"), std::string::npos) << e;
}

TEST(ShadingGraph, WrongValueShapes) {
  EXPECT_NE(error_of(R"({"a": {"type": "ShaderNodeTexChecker", "inputs": {"Scale": [1, 2, 3]}}})").find("input 'Scale' must be a number"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"a": {"type": "ShaderNodeTexChecker", "inputs": {"Color1": 0.5}}})").find("input 'Color1' must be [x, y, z]"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"a": {"type": "ShaderNodeTexChecker", "inputs": {"Color1": [1, 2]}}})").find("Color1"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"a": {"type": "ShaderNodeMath", "props": {"operation": "FROBNICATE"}}})", "a", "Value")
                .find("unknown value 'FROBNICATE'"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"a": 3})").find("node 'a': a node must be an object"), std::string::npos);
}

TEST(ShadingGraph, LinkToMissingNode) {
  const std::string e = error_of(R"({"a": {"type": "ShaderNodeTexChecker", "inputs": {"Vector": {"link": "nowhere", "output": "UV"}}}})");
  EXPECT_NE(e.find("node 'a'"), std::string::npos) << e;
  EXPECT_NE(e.find("missing node 'nowhere'"), std::string::npos) << e;
}

TEST(ShadingGraph, CyclesAreRefused) {
  const std::string e = error_of(R"({
    "a": {"type": "ShaderNodeMath", "inputs": {"Value": {"link": "b", "output": "Value"}}},
    "b": {"type": "ShaderNodeMath", "inputs": {"Value": {"link": "a", "output": "Value"}}}})", "a", "Value");
  EXPECT_NE(e.find("cycle"), std::string::npos) << e;
  // A node feeding itself.
  EXPECT_NE(error_of(R"({"a": {"type": "ShaderNodeMath", "inputs": {"Value": {"link": "a", "output": "Value"}}}})", "a", "Value")
                .find("cycle"),
            std::string::npos);
}

TEST(ShadingGraph, SizeLimit) {
  nlohmann::json nodes = nlohmann::json::object();
  for (size_t i = 0; i <= kMaxGraphNodes; ++i) nodes["n" + std::to_string(i)] = {{"type", "ShaderNodeMath"}};
  try {
    GraphCompiler g("Big", nodes, nullptr);
    FAIL() << "a graph over the limit was accepted";
  } catch (const GraphError& e) {
    EXPECT_NE(std::string(e.what()).find("over the limit of 4096"), std::string::npos) << e.what();
  }
}

TEST(ShadingGraph, LongChainCompilesWithoutRecursion) {
  // 4000 Math nodes in a chain: add 1 each, folded to one constant.
  nlohmann::json nodes = nlohmann::json::object();
  nodes["n0"] = {{"type", "ShaderNodeMath"}, {"inputs", {{"Value", 0.0}, {"Value_001", 1.0}}}};
  for (int i = 1; i < 4000; ++i)
    nodes["n" + std::to_string(i)] = {{"type", "ShaderNodeMath"},
                                      {"inputs", {{"Value", {{"link", "n" + std::to_string(i - 1)}, {"output", "Value"}}},
                                                  {"Value_001", 1.0}}}};
  GraphCompiler g("Chain", nodes, nullptr);
  const int r = g.link({{"link", "n3999"}, {"output", "Value"}}, SocketType::Float);
  auto p = g.compile();
  EXPECT_EQ(p->op_count(), 0u);  // all constant: folded
  EXPECT_FLOAT_EQ(p->evaluate(ShadingContext(), g.source(r)).x, 4000.0f);
}

TEST(ShadingGraph, OnlyNeededNodesAndConstantFolding) {
  // The checker reads a constant vector: folded; the noise is not linked: not compiled; the
  // texture coordinate feeds a math node: kept.
  auto c = compile_output(R"({
    "chk": {"type": "ShaderNodeTexChecker", "inputs": {"Vector": [0.1, 0.1, 0.1], "Scale": 1.0}},
    "unused": {"type": "ShaderNodeTexNoise"},
    "tc": {"type": "ShaderNodeTexCoord"},
    "sep": {"type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": "tc", "output": "UV"}}},
    "mix": {"type": "ShaderNodeMixRGB", "inputs": {"Fac": {"link": "sep", "output": "X"},
                                                     "Color1": {"link": "chk", "output": "Color"},
                                                     "Color2": [0, 0, 1]}}})",
                          "mix", "Color");
  EXPECT_EQ(c.program->op_count(), 3u);  // tc, sep, mix
  ShadingContext ctx;
  ctx.uv = Vec2(0.25f, 0.0f);
  const Vec3 v = c.at(ctx);
  // Checker at (0.1, 0.1, 0.1) scale 1: cell (0, 0, 0) is Color2 (checker.h: (x == y) == odd z); 1/4 to blue.
  EXPECT_NEAR(v.x, 0.75f * 0.2f, 1e-6);
  EXPECT_NEAR(v.z, 0.75f * 0.2f + 0.25f, 1e-6);
}

TEST(ShadingGraph, SocketConversions) {
  // Colour -> float: Rec.709 luminance (Cycles: 0.2126729, 0.7151522, 0.0721750); vector ->
  // float: average; float -> colour: grey.
  auto lum = compile_output(R"({
    "rgb": {"type": "ShaderNodeCombineRGB", "inputs": {"R": 1.0, "G": 0.5, "B": 0.25}},
    "m": {"type": "ShaderNodeMath", "props": {"operation": "ADD"}, "inputs": {"Value": {"link": "rgb", "output": "Image"}, "Value_001": 0.0}}})",
                            "m", "Value", SocketType::Float);
  EXPECT_NEAR(lum.f(ShadingContext()), 0.2126729f + 0.7151522f * 0.5f + 0.0721750f * 0.25f, 1e-6);
  auto avg = compile_output(R"({
    "v": {"type": "ShaderNodeCombineXYZ", "inputs": {"X": 1.0, "Y": 0.5, "Z": 0.0}},
    "m": {"type": "ShaderNodeMath", "props": {"operation": "ADD"}, "inputs": {"Value": {"link": "v", "output": "Vector"}, "Value_001": 0.0}}})",
                            "m", "Value", SocketType::Float);
  EXPECT_NEAR(avg.f(ShadingContext()), 0.5f, 1e-6);
  // A colour output read by a float consumer (the material input) converts too.
  auto root = compile_output(R"({"rgb": {"type": "ShaderNodeCombineRGB", "inputs": {"R": 1.0, "G": 0.0, "B": 0.0}}})", "rgb",
                             "Image", SocketType::Float);
  EXPECT_NEAR(root.f(ShadingContext()), 0.2126729f, 1e-6);
}

TEST(ShadingGraph, WorldContextWithOnlyADirection) {
  auto c = compile_output(R"({"tc": {"type": "ShaderNodeTexCoord"},
    "g": {"type": "ShaderNodeTexGradient", "inputs": {"Vector": {"link": "tc", "output": "Generated"}}}})",
                          "g", "Fac", SocketType::Float);
  const ShadingContext w = ShadingContext::direction(normalize(Vec3(0.6f, 0.8f, 0.0f)));
  EXPECT_NEAR(c.f(w), 0.6f, 1e-6);  // Generated of the World is the direction
}

// run_in_thread_registers keeps each program's constants in the thread's file for it (no copy
// per run): the values of run() over fresh registers, for more programs in turn than the thread
// keeps files (each replaced one filled again), and for a new program compiled where a released
// one was (its file is never taken for the new one's).
TEST(ShadingGraph, ThreadRegistersAreWhatRunGives) {
  auto make = [](float k) {
    // A constant colour (its own register) mixed with the uv: a stale constant shows in the value.
    return compile_output(R"({"tc": {"type": "ShaderNodeTexCoord"},
      "mix": {"type": "ShaderNodeMixRGB", "props": {"blend_type": "ADD"},
              "inputs": {"Fac": 1.0, "Color1": {"link": "tc", "output": "UV"}, "Color2": [)" +
                              std::to_string(k) + ", " + std::to_string(2 * k) + R"(, 0.5]}}})",
                          "mix", "Color");
  };
  std::vector<test::Compiled> programs;
  for (int i = 0; i < 11; ++i) programs.push_back(make(0.125f * static_cast<float>(i + 1)));
  ShadingContext ctx;
  for (int round = 0; round < 3; ++round)
    for (size_t i = 0; i < programs.size(); i += (round == 1 ? 3 : 1)) {
      ctx.uv = Vec2(0.01f * static_cast<float>(i), 0.25f * static_cast<float>(round));
      const uint64_t runs = ShaderProgram::runs_on_this_thread();
      const Vec3* regs = run_in_thread_registers(programs[i].program, ctx);
      EXPECT_EQ(ShaderProgram::runs_on_this_thread(), runs + 1);
      const Vec3 want = programs[i].at(ctx);  // run() over registers filled from the constants
      const Vec3 got = regs[programs[i].source.reg];
      EXPECT_EQ(got.x, want.x) << "program " << i << ", round " << round;
      EXPECT_EQ(got.y, want.y) << "program " << i << ", round " << round;
      EXPECT_EQ(got.z, want.z) << "program " << i << ", round " << round;
      // The whole file as run() leaves fresh registers (constants and outputs; register 0, the
      // outputs nothing reads, apart).
      std::vector<Vec3> fresh(programs[i].program->num_registers(), Vec3(-7.0f));
      programs[i].program->run(ctx, fresh.data());
      EXPECT_EQ(std::memcmp(fresh.data() + 1, run_in_thread_registers(programs[i].program, ctx) + 1,
                            (fresh.size() - 1) * sizeof(Vec3)), 0)
          << "program " << i << ", round " << round;
    }
  // Released programs and new ones made in their place (often at the same address).
  for (int i = 0; i < 20; ++i) {
    programs[0] = test::Compiled{};  // released first, so that the new one may take its memory
    programs[0] = make(3.0f + static_cast<float>(i));
    const Vec3* regs = run_in_thread_registers(programs[0].program, ctx);
    EXPECT_EQ(regs[programs[0].source.reg].x, programs[0].at(ctx).x) << i;
  }
}

// What the thread register files rely on (node_types.h NodeType::eval): every node type writes
// each output the program reads on every run or on none. Each type with every input linked to
// the shading point (Texture Coordinate's Object, so that inputs vary and nothing folds) and
// every output read, run at points that take different paths (signs, zero, a World direction,
// backfacing, ray flags): the thread's file is after each run what run() makes of fresh
// registers, byte for byte.
TEST(ShadingGraph, EveryNodeWritesItsReadOutputsOnEveryRun) {
  std::vector<ShadingContext> points;
  const Vec3 ps[] = {{0.3f, -0.7f, 0.2f}, {0.0f, 0.0f, 0.0f}, {-2.5f, 1.5f, 3.25f}, {0.51f, 0.49f, -0.01f}};
  for (int i = 0; i < 4; ++i) {
    ShadingContext c;
    c.P = ps[i];
    c.uv = Vec2(ps[i].x, ps[i].y);
    c.N = normalize(Vec3(0.2f * static_cast<float>(i) - 0.3f, 0.5f, 1.0f));
    c.I = normalize(Vec3(0.1f, -0.4f * static_cast<float>(i), 1.0f));
    c.backfacing = i % 2 == 1;
    c.ray.flags = static_cast<uint16_t>(i == 2 ? 0 : 1u << i);
    points.push_back(c);
  }
  points.push_back(ShadingContext::direction(normalize(Vec3(0.6f, 0.0f, -0.8f))));
  int checked = 0;
  for (const NodeType& t : node_types()) {
    nlohmann::json node = {{"type", t.idname}, {"inputs", nlohmann::json::object()}};
    for (const SocketDesc& in : t.inputs) node["inputs"][in.id] = {{"link", "tc"}, {"output", "Object"}};
    nlohmann::json nodes = {{"tc", {{"type", "ShaderNodeTexCoord"}}}, {"n", node}};
    std::shared_ptr<const ShaderProgram> prog;
    try {
      GraphCompiler g("M", nodes, nullptr);
      for (const SocketDesc& out : t.outputs) g.link(nlohmann::json{{"link", "n"}, {"output", out.id}}, out.type);
      prog = g.compile();
    } catch (const GraphError&) {
      continue;  // needs properties (an image, a ramp's table): covered by its own tests
    }
    ++checked;
    std::vector<Vec3> fresh(prog->num_registers());
    for (int round = 0; round < 2; ++round)
      for (size_t i = 0; i < points.size(); ++i) {
        const size_t k = round == 0 ? i : points.size() - 1 - i;  // each path after each other one
        const Vec3* file = run_in_thread_registers(prog, points[k]);
        std::fill(fresh.begin(), fresh.end(), Vec3(-7.0f));
        prog->run(points[k], fresh.data());
        // (Register 0 takes the outputs nothing reads: never read, not compared.)
        EXPECT_EQ(std::memcmp(fresh.data() + 1, file + 1, (fresh.size() - 1) * sizeof(Vec3)), 0)
            << t.idname << " at point " << k;
      }
  }
  EXPECT_GT(checked, 40);
}

// Specialised ops (NodeType::specialize: Mix's lerp blends, Map Range's Float Linear) give what
// the node's general evaluation gives, to the bit: each graph compiled with and without them and
// run at the same random points. Factors and values reach the node as plain floats or through
// a conversion (vector -> float), over [-0.5, 1.5] so that the clamps act.
TEST(ShadingGraph, SpecialisedOpsAreTheGeneralOnes) {
  auto build = [](const std::string& nodes, const std::string& node, const std::string& output, bool specialize) {
    GraphCompiler g("M", nlohmann::json::parse(nodes), nullptr);
    const int root = g.link(nlohmann::json{{"link", node}, {"output", output}}, SocketType::Color);
    g.set_specialize(specialize);
    test::Compiled c;
    c.program = g.compile();
    c.source = g.source(root);
    return c;
  };
  const std::string inputs = R"("tc": {"type": "ShaderNodeTexCoord"},
      "xyz": {"type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": "tc", "output": "UV"}}},)";
  const std::string plain = R"({"link": "xyz", "output": "X"})", converted = R"({"link": "tc", "output": "UV"})";
  std::vector<std::pair<std::string, std::string>> graphs;  // (nodes, output of node n)
  for (const char* blend : {"MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN"})
    for (const char* cf : {"true", "false"})
      for (const char* cr : {"true", "false"})
        for (const std::string& fac : {plain, converted})
          graphs.emplace_back(inputs + R"("n": {"type": "ShaderNodeMix", "props": {"data_type": "RGBA", "blend_type": ")" +
                           blend + R"(", "clamp_factor": )" + cf + R"(, "clamp_result": )" + cr +
                           R"(}, "inputs": {"Factor_Float": )" + fac +
                           R"(, "A_Color": {"link": "tc", "output": "Object"}, "B_Color": {"link": "tc", "output": "UV"}}}})",
                          "Result_Color");
  for (const char* clamp : {"true", "false"})
    for (const std::string& value : {plain, converted})
      for (const std::string& from_max : {std::string("0.7"), std::string("0.2"), plain})  // 0.2: from_min == from_max
        for (const char* interp : {"LINEAR", "STEPPED"})
          graphs.emplace_back(inputs + R"("n": {"type": "ShaderNodeMapRange", "props": {"clamp": )" + clamp +
                           R"(, "interpolation_type": ")" + interp + R"("}, "inputs": {"Value": )" + value +
                           R"(, "From Min": 0.2, "From Max": )" + from_max + R"(, "To Min": 0.9, "To Max": -0.3}}})",
                          "Result");
  for (const char* dims : {"3D", "2D"})
    for (const std::string& scale : {plain, converted, std::string("2.5")})
      for (const char* out : {"Fac", "Color"})
        graphs.emplace_back(inputs + R"("n": {"type": "ShaderNodeTexNoise", "props": {"noise_dimensions": ")" + dims +
                                R"("}, "inputs": {"Vector": {"link": "tc", "output": "Object"}, "Scale": )" + scale +
                                R"(, "Detail": 2.0, "Distortion": 0.3}}})",
                            out);
  // Texture Coordinate read at UV, at Object, at both (through a Mix), at UV with Generated.
  const std::string tc_mix = R"("n": {"type": "ShaderNodeMix", "props": {"data_type": "RGBA"}, "inputs": {"A_Color": )";
  graphs.emplace_back(inputs + R"("n": {"type": "ShaderNodeTexCoord"}})", "UV");
  graphs.emplace_back(inputs + R"("n": {"type": "ShaderNodeTexCoord"}})", "Object");
  graphs.emplace_back(inputs + tc_mix + R"({"link": "tc", "output": "UV"}, "B_Color": {"link": "tc", "output": "Object"}}}})",
                      "Result_Color");
  graphs.emplace_back(inputs + tc_mix + R"({"link": "tc", "output": "UV"}, "B_Color": {"link": "tc", "output": "Generated"}}}})",
                      "Result_Color");
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-0.5f, 1.5f);
  // An object (Object coordinates through its inverse transform) on half the points, the World
  // (no surface) on a quarter.
  ShadingObject object;
  object.to_world = Transform::translate(Vec3(0.3f, -0.2f, 0.1f)) * Transform::scale(Vec3(1.5f, 0.5f, 2.0f));
  object.to_object = invert_affine(object.to_world);
  object.bounds.extend(Vec3(-1.0f, -2.0f, 0.0f));
  object.bounds.extend(Vec3(1.0f, 1.0f, 3.0f));
  for (const auto& [body, output] : graphs) {
    const std::string nodes = "{" + body;
    const test::Compiled fast = build(nodes, "n", output, true);
    const test::Compiled general = build(nodes, "n", output, false);
    ShadingContext ctx;
    for (int i = 0; i < 200; ++i) {
      ctx.uv = Vec2(u(rng), u(rng));
      ctx.P = Vec3(u(rng), u(rng), u(rng));
      ctx.object = i % 2 ? &object : nullptr;
      ctx.surface = i % 4 != 3;
      const Vec3 a = fast.at(ctx), b = general.at(ctx);
      const bool same = std::memcmp(&a, &b, sizeof(Vec3)) == 0;
      EXPECT_TRUE(same) << nodes << " at uv " << ctx.uv.x << ", " << ctx.uv.y << ": "
                                                      << a.x << " " << a.y << " " << a.z << " against " << b.x << " "
                                                      << b.y << " " << b.z;
      if (!same) break;  // one message per graph
    }
  }
}

TEST(ShadingGraph, SupportedTypesListed) {
  const auto t = supported_node_types();
  EXPECT_TRUE(std::is_sorted(t.begin(), t.end()));
  for (const char* n : {"ShaderNodeTexImage", "ShaderNodeTexChecker", "ShaderNodeMix", "ShaderNodeValToRGB",
                        "ShaderNodeBump", "ShaderNodeNormalMap", "ShaderNodeTexVoronoi"})
    EXPECT_TRUE(std::binary_search(t.begin(), t.end(), std::string(n))) << n;
}

}  // namespace
}  // namespace gp::shading
