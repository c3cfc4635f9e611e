// libFuzzer target: the JSON scene loader (scene/loader.h, load_scene_from_string) on arbitrary
// bytes. Every input must load or throw SceneError naming the file ("fuzz.json").
// Relative OBJ paths resolve against fuzz/corpus/obj, so the fuzzer can reach the OBJ reader.
#include <cstdint>
#include <cstdlib>
#include <string>

#include <tbb/global_control.h>

#include "fuzz/fuzz_common.h"
#include "scene/loader.h"

#ifndef GRADPHOTON_SOURCE_DIR
#define GRADPHOTON_SOURCE_DIR "."
#endif

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // Shapes that would need more than this fail with a clear error (loader.cpp, reserve_triangles)
  // instead of running libFuzzer into its memory limit.
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "256", 0);
  // One thread: the loader's parallel builds (the Nishita sky's image and sampling grid) ran 5x
  // slower on two TBB threads than on one under ASan (sky-sum.json: 27 s against 4.8 s, past the
  // 10 s hang limit); a fuzzer finds nothing more with threads.
  static tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
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
