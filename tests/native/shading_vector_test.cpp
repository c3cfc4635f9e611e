// Vector and input nodes whose values need a shading point: Bump (Cycles' svm_node_set_bump by
// offset evaluation), Normal Map (tangent space), Fresnel / Layer Weight, Texture Coordinate.
#include <gtest/gtest.h>

#include <cmath>

#include "shading_test_util.h"

namespace gp::shading {
namespace {

using test::compile_output;

ShadingContext flat_point() {
  // The plane z = 0 seen from above, uv = (x, y): dP/du = x, dP/dv = y.
  ShadingContext c;
  c.P = Vec3(0.3f, 0.2f, 0.0f);
  c.uv = Vec2(0.3f, 0.2f);
  c.N = c.Ng = Vec3(0, 0, 1);
  c.I = Vec3(0, 0, 1);
  c.dPdu = Vec3(1, 0, 0);
  c.dPdv = Vec3(0, 1, 0);
  return c;
}

TEST(ShadingVector, BumpOfALinearHeightTiltsByItsSlope) {
  // Height h = 2 x (Geometry Position's x): the bumped normal is normalize(N - distance grad h)
  // = normalize(-2 d, 0, 1); strength 0.5 blends it halfway back to N, then normalises.
  auto c = compile_output(R"({
    "geo": {"type": "ShaderNodeNewGeometry"},
    "sep": {"type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": "geo", "output": "Position"}}},
    "h": {"type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"}, "inputs": {"Value": {"link": "sep", "output": "X"}, "Value_001": 2.0}},
    "bump": {"type": "ShaderNodeBump", "inputs": {"Strength": 1.0, "Distance": 0.3, "Height": {"link": "h", "output": "Value"}}}})",
                          "bump", "Normal", SocketType::Vector);
  const Vec3 n = c.at(flat_point());
  const Vec3 e = normalize(Vec3(-2.0f * 0.3f, 0.0f, 1.0f));
  EXPECT_NEAR(n.x, e.x, 1e-3);
  EXPECT_NEAR(n.y, e.y, 1e-3);
  EXPECT_NEAR(n.z, e.z, 1e-3);
  // Inverted: the other way.
  auto inv = compile_output(R"({
    "geo": {"type": "ShaderNodeNewGeometry"},
    "sep": {"type": "ShaderNodeSeparateXYZ", "inputs": {"Vector": {"link": "geo", "output": "Position"}}},
    "bump": {"type": "ShaderNodeBump", "props": {"invert": true}, "inputs": {"Distance": 0.5, "Height": {"link": "sep", "output": "Y"}}}})",
                            "bump", "Normal", SocketType::Vector);
  const Vec3 m = inv.at(flat_point());
  const Vec3 f = normalize(Vec3(0.0f, 0.5f, 1.0f));
  EXPECT_NEAR(m.y, f.y, 1e-3);
  EXPECT_NEAR(m.z, f.z, 1e-3);
}

TEST(ShadingVector, NormalMapInTangentSpace) {
  // Colour (0.8, 0.5, 0.9) -> (0.6, 0, 0.8) in (T, B, N) = (x, y, z) here.
  auto c = compile_output(R"({"nm": {"type": "ShaderNodeNormalMap", "inputs": {"Color": [0.8, 0.5, 0.9]}}})", "nm",
                          "Normal", SocketType::Vector);
  const Vec3 n = c.at(flat_point());
  EXPECT_NEAR(n.x, 0.6f, 1e-5);
  EXPECT_NEAR(n.y, 0.0f, 1e-5);
  EXPECT_NEAR(n.z, 0.8f, 1e-5);
  // Strength 0 keeps the shading normal.
  auto z = compile_output(R"({"nm": {"type": "ShaderNodeNormalMap", "inputs": {"Strength": 0.0, "Color": [0.8, 0.5, 0.9]}}})",
                          "nm", "Normal", SocketType::Vector);
  EXPECT_NEAR(z.at(flat_point()).z, 1.0f, 1e-6);
}

TEST(ShadingVector, FresnelAndLayerWeight) {
  // Normal incidence, IOR 1.5: ((1.5 - 1) / (1.5 + 1))^2 = 0.04 (fresnel_dielectric_cos).
  auto f = compile_output(R"({"f": {"type": "ShaderNodeFresnel", "inputs": {"IOR": 1.5}}})", "f", "Fac", SocketType::Float);
  EXPECT_NEAR(f.f(flat_point()), 0.04f, 1e-6);
  // Layer Weight Facing at 60 degrees with blend 0.5: 1 - |cos| = 0.5; blend 0.25: 1 - cos^0.5.
  ShadingContext c = flat_point();
  c.I = Vec3(std::sqrt(3.0f) / 2, 0, 0.5f);
  auto lw = compile_output(R"({"l": {"type": "ShaderNodeLayerWeight", "inputs": {"Blend": 0.5}}})", "l", "Facing", SocketType::Float);
  EXPECT_NEAR(lw.f(c), 0.5f, 1e-6);
  auto lw2 = compile_output(R"({"l": {"type": "ShaderNodeLayerWeight", "inputs": {"Blend": 0.25}}})", "l", "Facing", SocketType::Float);
  EXPECT_NEAR(lw2.f(c), 1.0f - std::sqrt(0.5f), 1e-6);
}

TEST(ShadingVector, TextureCoordinateGeneratedAndObject) {
  ShadingObject obj;
  obj.to_world = Transform::translate(Vec3(1, 2, 3));
  obj.to_object = Transform::translate(Vec3(-1, -2, -3));
  obj.bounds.extend(Vec3(-1, -1, 0));
  obj.bounds.extend(Vec3(1, 1, 2));
  ShadingContext c = flat_point();
  c.P = Vec3(1.5f, 2.0f, 4.0f);  // object space (0.5, 0, 1)
  c.object = &obj;
  auto gen = compile_output(R"({"tc": {"type": "ShaderNodeTexCoord"}})", "tc", "Generated", SocketType::Vector);
  const Vec3 g = gen.at(c);
  EXPECT_NEAR(g.x, 0.75f, 1e-6);
  EXPECT_NEAR(g.y, 0.5f, 1e-6);
  EXPECT_NEAR(g.z, 0.5f, 1e-6);
  auto ob = compile_output(R"({"tc": {"type": "ShaderNodeTexCoord"}})", "tc", "Object", SocketType::Vector);
  EXPECT_NEAR(ob.at(c).x, 0.5f, 1e-6);
  auto info = compile_output(R"({"oi": {"type": "ShaderNodeObjectInfo"}})", "oi", "Location", SocketType::Vector);
  EXPECT_NEAR(info.at(c).y, 2.0f, 1e-6);
}

}  // namespace
}  // namespace gp::shading
