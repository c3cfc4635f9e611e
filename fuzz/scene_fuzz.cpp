// libFuzzer target: the JSON scene loader (scene/loader.h, load_scene_from_string) on arbitrary
// bytes. Every input must load or throw SceneError naming the file ("fuzz.json").
// Relative OBJ paths resolve against fuzz/corpus/obj, so the fuzzer can reach the OBJ reader.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "fuzz/fuzz_common.h"
#include "scene/loader.h"

#ifndef GRADPHOTON_SOURCE_DIR
#define GRADPHOTON_SOURCE_DIR "."
#endif

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // Shapes that would need more than this fail with a clear error (loader.cpp, reserve_triangles)
  // instead of running libFuzzer into its memory limit.
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "256", 0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    gp::Scene scene = gp::load_scene_from_string(text, GRADPHOTON_SOURCE_DIR "/fuzz/corpus/obj", "fuzz.json");
  } catch (const gp::SceneError& e) {
    gp::fuzz::require_mentions(e, "fuzz.json");
  }
  return 0;
}
