// Mesh attributes (vertex colours and generic attributes) read by the Color Attribute and
// Attribute nodes: interpolation per domain, Cycles' outputs (svm/vertex_color.h,
// svm/attribute.h) for found and missing attributes, the scene format's `colors` and
// `attributes`, and their errors.
#include <gtest/gtest.h>

#include "render_for_tests.h"
#include "scene/loader.h"
#include "shading_test_util.h"

namespace gp {
namespace {

using shading::SocketType;
using shading::test::compile_output;

// The furnace quad (render_for_tests.h) with attributes; triangle 0 is (0, 1, 2) (below the
// diagonal y = x), triangle 1 (0, 2, 3).
std::string quad_with(const std::string& material, const std::string& mesh_keys) {
  std::string json = furnace_scene(material);
  const std::string at = R"("material": "m")";
  json.replace(json.find(at), at.size(), at + ", " + mesh_keys);
  return json;
}

const char* kEmitColor = R"({"type": "emission", "strength": 1.0, "emission": [1, 1, 1]})";
const char* kAttrs = R"("colors": [[1, 0, 0, 1], [0, 1, 0, 0.5], [0, 0, 1, 0], [1, 1, 1, 0.25]],
  "attributes": {"corner_c": {"domain": "corner", "values": [[1, 0, 0], [0, 1, 0], [0, 0, 1], [2, 2, 2], [3, 3, 3], [4, 4, 4]]},
                 "face_f": {"domain": "face", "values": [0.25, 0.75]},
                 "uvish": {"values": [[0, 0], [1, 0], [1, 1], [0, 1]]}})";

// The shading context where the ray from above meets the quad at (x, y).
shading::ShadingContext context_at(const Scene& s, float x, float y) {
  Ray r;
  r.o = Vec3(x, y, 1);
  r.d = Vec3(0, 0, -1);
  const auto h = s.intersect(r);
  EXPECT_TRUE(h.has_value());
  return s.shading_context(*h);
}

const char* kNodes = R"({"vc": {"type": "ShaderNodeVertexColor", "props": {"layer_name": ""}},
  "vn": {"type": "ShaderNodeVertexColor", "props": {"layer_name": "corner_c"}},
  "vm": {"type": "ShaderNodeVertexColor", "props": {"layer_name": "nope"}},
  "at": {"type": "ShaderNodeAttribute", "props": {"attribute_name": "Color"}},
  "af": {"type": "ShaderNodeAttribute", "props": {"attribute_name": "face_f"}},
  "a2": {"type": "ShaderNodeAttribute", "props": {"attribute_name": "uvish"}},
  "am": {"type": "ShaderNodeAttribute", "props": {"attribute_name": "missing"}}})";

Vec3 eval(const shading::ShadingContext& c, const char* node, const char* out, SocketType t = SocketType::Color) {
  return compile_output(kNodes, node, out, t).at(c);
}

TEST(ShadingAttributes, PointCornerAndFaceDomainsInterpolateAsCycles) {
  const Scene s = load_scene_from_string(quad_with(kEmitColor, kAttrs), ".", "attrs.json");
  // (0.5, -0.5) in triangle 0: barycentrics of vertices (0, 1, 2) = (0.25, 0.5, 0.25).
  const auto c = context_at(s, 0.5f, -0.5f);
  const Vec3 col = eval(c, "vc", "Color");
  EXPECT_NEAR(col.x, 0.25f, 1e-5f);
  EXPECT_NEAR(col.y, 0.5f, 1e-5f);
  EXPECT_NEAR(col.z, 0.25f, 1e-5f);
  EXPECT_NEAR(eval(c, "vc", "Alpha", SocketType::Float).x, 0.25f + 0.25f, 1e-5f);  // 1 * .25 + .5 * .5 + 0
  // Corner values of triangle 0 are its first three entries.
  const Vec3 corner = eval(c, "vn", "Color");
  EXPECT_NEAR(corner.x, 0.25f, 1e-5f);
  EXPECT_NEAR(corner.y, 0.5f, 1e-5f);
  EXPECT_NEAR(eval(c, "vn", "Alpha", SocketType::Float).x, 1.0f, 1e-6f);  // an RGB attribute: alpha 1
  EXPECT_NEAR(eval(c, "af", "Fac", SocketType::Float).x, 0.25f, 1e-6f);
  // Triangle 1 at (-0.5, 0.5): vertices (0, 2, 3) with weights (0.25, 0.25, 0.5); corners 3-5.
  const auto c1 = context_at(s, -0.5f, 0.5f);
  EXPECT_NEAR(eval(c1, "vn", "Color").x, 0.25f * 2 + 0.25f * 3 + 0.5f * 4, 1e-5f);
  EXPECT_NEAR(eval(c1, "af", "Fac", SocketType::Float).x, 0.75f, 1e-6f);
}

TEST(ShadingAttributes, AttributeNodeOutputsAsCycles) {
  const Scene s = load_scene_from_string(quad_with(kEmitColor, kAttrs), ".", "attrs.json");
  const auto c = context_at(s, 0.5f, -0.5f);
  // A colour attribute: Color and Vector its RGB, Fac their average, Alpha its alpha.
  EXPECT_NEAR(eval(c, "at", "Vector", SocketType::Vector).y, 0.5f, 1e-5f);
  EXPECT_NEAR(eval(c, "at", "Fac", SocketType::Float).x, (0.25f + 0.5f + 0.25f) / 3, 1e-5f);
  EXPECT_NEAR(eval(c, "at", "Alpha", SocketType::Float).x, 0.5f, 1e-5f);
  // A float attribute: (f, f, f), alpha 1. A float2: (x, y, 0), Fac x.
  EXPECT_NEAR(eval(c, "af", "Color").z, 0.25f, 1e-6f);
  EXPECT_NEAR(eval(c, "af", "Alpha", SocketType::Float).x, 1.0f, 1e-6f);
  const Vec3 uv = eval(c, "a2", "Vector", SocketType::Vector);
  EXPECT_NEAR(uv.x, 0.75f, 1e-5f);  // 0.5 * 1 + 0.25 * 1
  EXPECT_NEAR(uv.y, 0.25f, 1e-5f);
  EXPECT_EQ(uv.z, 0.0f);
  EXPECT_NEAR(eval(c, "a2", "Fac", SocketType::Float).x, 0.75f, 1e-5f);
  // Missing: Color Attribute gives black and alpha 0; Attribute black, Fac 0, alpha 1.
  EXPECT_EQ(eval(c, "vm", "Color").x, 0.0f);
  EXPECT_EQ(eval(c, "vm", "Alpha", SocketType::Float).x, 0.0f);
  EXPECT_EQ(eval(c, "am", "Color").x, 0.0f);
  EXPECT_EQ(eval(c, "am", "Alpha", SocketType::Float).x, 1.0f);
  // The World (no object) finds nothing.
  EXPECT_EQ(eval(shading::ShadingContext::direction(Vec3(0, 0, 1)), "vc", "Alpha", SocketType::Float).x, 0.0f);
}

TEST(ShadingAttributes, FaceColoursRenderUnderPathTracing) {
  // Emission from a face-domain colour: the lower-right quadrant is triangle 0 (red), the
  // upper-left triangle 1 (blue), in a black World.
  const std::string mat = R"({"type": "emission", "strength": 1.0,
    "emission": {"link": "a", "output": "Color"},
    "nodes": {"a": {"type": "ShaderNodeAttribute", "props": {"attribute_name": "tint"}}}})";
  std::string json = quad_with(mat, R"("attributes": {"tint": {"domain": "face", "values": [[1, 0, 0], [0, 0, 1]]}})");
  const std::string white = R"("color": [1, 1, 1], "strength": 1)";
  json.replace(json.find(white), white.size(), R"("color": [0, 0, 0], "strength": 0)");
  const Film f = render("pt", load_scene_from_string(json, ".", "faces.json"), 4, Params());
  EXPECT_NEAR(quadrant_mean(f, 1, 1).r, 1.0f, 1e-3f);
  EXPECT_NEAR(quadrant_mean(f, 1, 1).b, 0.0f, 1e-3f);
  EXPECT_NEAR(quadrant_mean(f, 0, 0).r, 0.0f, 1e-3f);
  EXPECT_NEAR(quadrant_mean(f, 0, 0).b, 1.0f, 1e-3f);
}

std::string load_error(const std::string& keys) {
  try {
    load_scene_from_string(quad_with(kEmitColor, keys), ".", "bad.json");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(ShadingAttributes, BadAttributesNameFileAndPlace) {
  EXPECT_NE(load_error(R"("colors": [[1, 0, 0]])").find("bad.json: /objects/0/colors: 1 values for 4 elements"),
            std::string::npos);
  EXPECT_NE(load_error(R"("colors": [1, 2, 3, 4])").find("colours are [r, g, b] or [r, g, b, a]"), std::string::npos);
  EXPECT_NE(load_error(R"("attributes": {"x": {"domain": "edge", "values": []}})").find("unknown domain 'edge'"),
            std::string::npos);
  EXPECT_NE(load_error(R"("attributes": {"x": {"domain": "face", "values": [[1, 2], [1]]}})")
                .find("/objects/0/attributes/x/values/1"),
            std::string::npos);
  EXPECT_NE(load_error(R"("attributes": {"x": {"values": [[1, 2, 3, 4, 5], [1], [1], [1]]}})")
                .find("an array of 1 to 4 numbers"),
            std::string::npos);
  EXPECT_NE(load_error(R"("attributes": {"x": {"domain": "corner", "values": [1, 2]}})")
                .find("2 values for 6 elements (one per corner)"),
            std::string::npos);
}

}  // namespace
}  // namespace gp
