// libFuzzer target: OBJ files through the scene loader (scene/loader.cpp, load_obj and
// tinyobjloader). The input is written to a scratch .obj file that a fixed scene places with a
// fallback material. Every input must load or throw SceneError naming the JSON path and the file.
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "fuzz/fuzz_common.h"
#include "scene/loader.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "256", 0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = gp::fuzz::scratch_path("obj", ".obj");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  const std::string scene = R"({"materials": {"white": {"type": "diffuse"}, "red": {"type": "diffuse"}},
    "objects": [{"type": "obj", "file": ")" + path + R"(", "material": "white"}]})";
  try {
    gp::Scene s = gp::load_scene_from_string(scene, "", "fuzz.json");
  } catch (const gp::SceneError& e) {
    gp::fuzz::require_mentions(e, "fuzz.json: /objects/0");
  }
  return 0;
}
