// Node graphs in scene files: a Checker on a quad under a constant environment (white furnace:
// a diffuse surface shows its albedo), emission driven by a graph, and load errors naming the
// file, the material and the node.
#include <gtest/gtest.h>

#include "render_for_tests.h"
#include "scene/loader.h"

namespace gp {
namespace {

const char* kChecker = R"({"type": "diffuse",
  "color": {"link": "Checker Texture", "output": "Color"},
  "nodes": {
    "Checker Texture": {"type": "ShaderNodeTexChecker",
                        "inputs": {"Vector": {"link": "Mapping", "output": "Vector"},
                                   "Color1": [0.8, 0.8, 0.8], "Color2": [0.2, 0.2, 0.2], "Scale": 1.0}},
    "Mapping": {"type": "ShaderNodeMapping", "props": {"vector_type": "POINT"},
                "inputs": {"Vector": {"link": "Texture Coordinate", "output": "UV"},
                           "Location": [0, 0, 0], "Rotation": [0, 0, 0], "Scale": [2, 2, 2]}},
    "Texture Coordinate": {"type": "ShaderNodeTexCoord"}}})";

TEST(ShadingScene, CheckerOnAQuadUnderPathTracing) {
  const Scene scene = load_scene_from_string(furnace_scene(kChecker), ".", "checker.json");
  // uv scaled by 2: four squares, one per image quadrant; (u, v) in [0, 0.5)^2 is cell (0, 0, 0),
  // Color2 (checker.h), its neighbours Color1. The view shows a centred square of the quad, so
  // each colour covers exactly half: the image mean is 0.5 (0.8 + 0.2) = 0.5.
  const Film f = render("pt", scene, 16, Params());
  const float expect[2][2] = {{0.8f, 0.2f}, {0.2f, 0.8f}};  // [qy from the top][qx]
  for (int qy = 0; qy < 2; ++qy)
    for (int qx = 0; qx < 2; ++qx)
      EXPECT_NEAR(quadrant_mean(f, qx, qy).g, expect[qy][qx], 0.02f) << "quadrant " << qx << "," << qy;
  // Headroom: 16 samples of a furnace give noise ~0.01 on the mean; a wrong checker parity or
  // scale moves a quadrant by 0.6 and an unlinked colour (0.8 grey) the mean by 0.3.
  EXPECT_NEAR(image_mean(f).g, 0.5f, 0.02f);
}

TEST(ShadingScene, TangentsReachTheGraphsThatReadThem) {
  // The shading context carries dPdu / dPdv only for materials whose graphs read them
  // (Material::graph_reads_tangents). A tangent-space Normal Map of colour (1, 0.5, 0.5) gives
  // the tangent along u, here +x: linked as the albedo, red under the white furnace. Without the
  // tangents the node returns the normal (0, 0, 1): blue. In a Mix's component too.
  const std::string nm = R"({"type": "diffuse", "color": {"link": "nm", "output": "Normal"},
    "nodes": {"nm": {"type": "ShaderNodeNormalMap", "inputs": {"Color": [1.0, 0.5, 0.5]}}}})";
  // (furnace_scene's material "m" here a mix of two more materials written beside it, its factor
  // from a graph of its own or a constant: a mix without a graph once shaded its components at
  // the uv alone, the Normal Map's blue)
  const std::string mix = R"({"type": "mix", "factor": {"link": "f", "output": "Value"}, "a": "grey", "b": "nmap",
    "nodes": {"f": {"type": "ShaderNodeValue", "inputs": {"Value": 1.0}}}},
    "grey": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}, "nmap": )" + nm;
  const std::string plain_mix = R"({"type": "mix", "factor": 1.0, "a": "grey", "b": "nmap"},
    "grey": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}, "nmap": )" + nm;
  for (const std::string& mat : {nm, mix, plain_mix}) {
    const Scene scene = load_scene_from_string(furnace_scene(mat), ".", "tangents.json");
    const RGB m = image_mean(render("pt", scene, 4, Params()));
    // Headroom: a furnace's mean is the albedo within ~0.02 at 4 samples; red 1 against 0.
    EXPECT_NEAR(m.r, 1.0f, 0.05f) << mat;
    EXPECT_NEAR(m.b, 0.0f, 0.05f) << mat;
  }
}

TEST(ShadingScene, PhotonMeasurementPointsSeeThePositionOfTheirHit) {
  // A checker on Object coordinates (x, y in [-1, 1], scale 0.5: the quadrants are its cells):
  // a measurement point shaded from its uv alone would see one cell everywhere.
  const std::string mat = R"({"type": "diffuse", "color": {"link": "c", "output": "Color"},
    "nodes": {"tc": {"type": "ShaderNodeTexCoord"},
              "c": {"type": "ShaderNodeTexChecker", "inputs": {"Vector": {"link": "tc", "output": "Object"},
                    "Color1": [0.8, 0.8, 0.8], "Color2": [0.2, 0.2, 0.2], "Scale": 0.5}}}})";
  const Scene scene = load_scene_from_string(furnace_scene(mat), ".", "object-checker.json");
  Params p;
  p.set("seed", 3);
  p.set("photons", int64_t(40000));
  // x < 0 is cell -1 (odd), x > 0 cell 0; likewise y: odd-even pairs are Color1.
  const float expect[2][2] = {{0.8f, 0.2f}, {0.2f, 0.8f}};  // [qy from the top][qx]
  // Tolerances as TexturedScene's (pt 0.04, photon windows 0.12); a uniform colour is off by 0.3.
  for (const auto& [method, tol] : {std::pair{"pt", 0.04f}, {"ppm", 0.12f}, {"sppm", 0.12f}}) {
    const Film f = render(method, scene, std::string(method) == "pt" ? 16 : 24, p);
    for (int qy = 0; qy < 2; ++qy)
      for (int qx = 0; qx < 2; ++qx)
        EXPECT_NEAR(quadrant_mean(f, qx, qy).g, expect[qy][qx], tol) << method << " quadrant " << qx << "," << qy;
  }
}

TEST(ShadingScene, EmissionFromAGraphIsSeenPerPointAndLights) {
  // An emission-only quad whose colour is a checker: the camera sees the squares (radiance per
  // point, not the triangle's average), in black surroundings.
  const std::string mat = R"({"type": "emission", "strength": 2.0,
    "emission": {"link": "c", "output": "Color"},
    "nodes": {"tc": {"type": "ShaderNodeTexCoord"},
              "c": {"type": "ShaderNodeTexChecker", "inputs": {"Vector": {"link": "tc", "output": "UV"},
                    "Color1": [1, 0.5, 0.25], "Color2": [0, 0, 0], "Scale": 2.0}}}})";
  std::string json = furnace_scene(mat);
  const std::string white = R"("color": [1, 1, 1], "strength": 1)";
  json.replace(json.find(white), white.size(), R"("color": [0, 0, 0], "strength": 0)");
  const Scene scene = load_scene_from_string(json, ".", "emit.json");
  const Film f = render("pt", scene, 4, Params());
  EXPECT_NEAR(quadrant_mean(f, 0, 0).r, 2.0f, 1e-3f);  // Color1 * 2
  EXPECT_NEAR(quadrant_mean(f, 0, 0).b, 0.5f, 1e-3f);
  EXPECT_NEAR(quadrant_mean(f, 1, 0).r, 0.0f, 1e-3f);  // Color2
}

std::string load_error(const std::string& mat) {
  try {
    load_scene_from_string(furnace_scene(mat), ".", "bad.json");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(ShadingScene, GraphErrorsNameFileMaterialAndNode) {
  const std::string e = load_error(R"({"type": "diffuse", "color": {"link": "n", "output": "Color"},
    "nodes": {"n": {"type": "ShaderNodeTexChecker", "inputs": {"Scale": "five"}}}})");
  EXPECT_NE(e.find("bad.json"), std::string::npos) << e;
  EXPECT_NE(e.find("/materials/m"), std::string::npos) << e;
  EXPECT_NE(e.find("node 'n'"), std::string::npos) << e;
  EXPECT_NE(e.find("Scale"), std::string::npos) << e;
  const std::string e2 = load_error(R"({"type": "diffuse", "color": {"link": "x", "output": "Color"}, "nodes": {}})");
  EXPECT_NE(e2.find("missing node 'x'"), std::string::npos) << e2;
  const std::string e3 = load_error(R"({"type": "diffuse", "color": {"link": "x", "output": "Color"}})");
  EXPECT_NE(e3.find("has no 'nodes'"), std::string::npos) << e3;
}

}  // namespace
}  // namespace gp
