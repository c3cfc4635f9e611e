// Texture Coordinate's Camera and Window outputs and Vector Transform's Camera space: the
// scene's camera in the shading context (shading::ShadingCamera), as Cycles defines them
// (svm/tex_coord.h: camera space with z towards the view; camera_world_to_ndc).
#include <gtest/gtest.h>

#include <cmath>

#include "render_for_tests.h"
#include "scene/loader.h"
#include "shading_test_util.h"

namespace gp {
namespace {

using shading::SocketType;
using shading::test::compile_output;

const char* kNodes = R"({"tc": {"type": "ShaderNodeTexCoord"},
  "vt": {"type": "ShaderNodeVectorTransform", "props": {"vector_type": "POINT", "convert_from": "CAMERA",
         "convert_to": "WORLD"}, "inputs": {"Vector": {"link": "tc", "output": "Camera"}}}})";

shading::ShadingContext context_at(const Scene& s, const Vec3& target) {
  const Vec3 eye(0, 0, 3);
  Ray r(eye, normalize(target - eye));
  const auto h = s.intersect(r);
  EXPECT_TRUE(h.has_value());
  return s.shading_context(*h);
}

TEST(ShadingCamera, CameraAndWindowAsCycles) {
  // The furnace camera: at (0, 0, 3) looking down -z, up +y, 30 degrees, square frame.
  const Scene s = load_scene_from_string(furnace_scene(R"({"type": "diffuse", "color": 0.5})"), ".", "cam.json");
  const float t = std::tan(15.0f * kPi / 180.0f);
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(0.5f, 0.25f, 0), Vec3(-0.3f, -0.6f, 0)}) {
    const auto c = context_at(s, p);
    const Vec3 cam = compile_output(kNodes, "tc", "Camera", SocketType::Vector).at(c);
    EXPECT_NEAR(cam.x, p.x, 1e-5f);
    EXPECT_NEAR(cam.y, p.y, 1e-5f);
    EXPECT_NEAR(cam.z, 3.0f, 1e-5f);  // Cycles' camera space: z is the distance in front
    const Vec3 win = compile_output(kNodes, "tc", "Window", SocketType::Vector).at(c);
    EXPECT_NEAR(win.x, 0.5f * (p.x / 3.0f / t + 1.0f), 1e-5f);
    EXPECT_NEAR(win.y, 0.5f * (p.y / 3.0f / t + 1.0f), 1e-5f);  // from the bottom, as Blender
    EXPECT_EQ(win.z, 0.0f);
    // Vector Transform from camera space back to world gives the point.
    const Vec3 w = compile_output(kNodes, "vt", "Vector", SocketType::Vector).at(c);
    EXPECT_NEAR(w.x, p.x, 1e-5f);
    EXPECT_NEAR(w.y, p.y, 1e-5f);
    EXPECT_NEAR(w.z, p.z, 1e-5f);
  }
}

}  // namespace
}  // namespace gp
