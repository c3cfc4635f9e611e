// Nodes against Blender 3.4's Cycles (textures, colour, converter and vector nodes): tests/blender_refs/shading_refs.json holds
// pixels of each case of shading_cases.json rendered by Cycles (render_shading_refs.py says
// how): pixel (i, j) is the node at a constant Vector, an exact binary fraction, so both sides
// evaluate the same float point. Bound 2e-5 absolute: float rounding of Cycles' SSE code paths
// (measured worst per case is recorded); a wrong hash, octave or offset moves values by 1e-2.
// Also the hash against lookup3 as written in util/hash.h, recomputed independently in Python.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "shading/hash.h"
#include "shading/procedural.h"
#include "shading_test_util.h"

namespace gp::shading {
namespace {

nlohmann::json read_json(const std::string& name) {
  std::ifstream f(std::string(GRADPHOTON_SOURCE_DIR) + "/tests/blender_refs/" + name);
  return nlohmann::json::parse(f);
}

TEST(ShadingHash, Lookup3FinalOfKnownKeys) {
  // hash_uint(0): a = b = c = 0xdeadbeef + (1 << 2) + 13, then final(a, b, c): the value below
  // was computed by a separate Python transcription of those lines.
  EXPECT_EQ(hash_uint(0u), 2501500005u);
  // Consistency of the float hashes with the integer ones.
  EXPECT_EQ(hash_float_to_float(0.0f), uint_to_float_incl(hash_uint(0u)));
  EXPECT_NE(hash_uint2(1u, 2u), hash_uint2(2u, 1u));
  EXPECT_NE(hash_uint4(1u, 2u, 3u, 4u), hash_uint4(1u, 2u, 3u, 5u));
}

TEST(ShadingProcedural, MatchesCyclesRenders) {
  const nlohmann::json cases = read_json("shading_cases.json");
  const nlohmann::json refs = read_json("shading_refs.json");
  const int n = refs["n"].get<int>();
  const float x0 = refs["x0"].get<float>(), y0 = refs["y0"].get<float>();
  ShadingObject object;  // identity: Object coordinates are world positions
  for (const auto& c : cases) {
    const std::string name = c["name"].get<std::string>();
    nlohmann::json tex = {{"type", c["type"]}, {"props", c["props"]}, {"inputs", c["inputs"]}};
    const auto& expected = refs["cases"][name];
    // Blackbody and Wavelength: Cycles uses fitted tables, here the CIE observer directly.
    const float tol = c.contains("tol") ? c["tol"].get<float>() : 2e-5f;
    ASSERT_EQ(expected.size(), static_cast<size_t>(n * n)) << name;
    double worst = 0;
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        // The point through a Combine XYZ into the input named by "vary", as the render has it.
        nlohmann::json nodes = {{"tex", tex}};
        const nlohmann::json vary = c.contains("vary") ? c["vary"] : nlohmann::json("Vector");
        if (!vary.is_null()) {
          nodes["xyz"] = {{"type", "ShaderNodeCombineXYZ"},
                          {"inputs", {{"X", x0 + (i + 0.5f) / n}, {"Y", y0 + (j + 0.5f) / n}, {"Z", 0.0f}}}};
          nodes["tex"]["inputs"][vary.get<std::string>()] = {{"link", "xyz"}, {"output", "Vector"}};
        }
        GraphCompiler g(name, nodes, nullptr);
        const int root = g.link({{"link", "tex"}, {"output", c["output"]}}, SocketType::Color);
        const auto prog = g.compile();
        ShadingContext ctx;
        ctx.object = &object;
        const Vec3 v = prog->evaluate(ctx, g.source(root));
        const auto& e = expected[j * n + i];
        for (int k = 0; k < 3; ++k) {
          worst = std::max(worst, std::abs(static_cast<double>(v[k]) - e[k].get<double>()));
          EXPECT_NEAR(v[k], e[k].get<float>(), tol) << name << " pixel (" << i << ", " << j << ") channel " << k;
        }
      }
    RecordProperty(name, std::to_string(worst));
  }
}

}  // namespace
}  // namespace gp::shading
