// libFuzzer target: the OpenVDB grid loader behind grid media (media/vdb_file.h read_vdb_grid,
// which the scene loader calls for a medium's "grid"). The input is written to a scratch .vdb
// file; every input must read (every grid of it densified and looked up) or throw VdbError
// naming that file, never crash or hang.
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "fuzz/fuzz_common.h"
#include "media/vdb_file.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // A few header bytes may ask for a dense grid up to the limit (media/vdb_file.cpp): 64 MB.
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "64", 0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = gp::fuzz::scratch_path("vdb", ".vdb");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    for (const gp::VdbGridInfo& info : gp::vdb_grid_names(path)) {
      try {
        const auto g = gp::read_vdb_grid(path, info.name);
        float v[3];
        g->lookup(gp::Vec3(0.5f, 0.25f, 0.75f), v);
      } catch (const gp::VdbError& e) {
        gp::fuzz::require_mentions(e, path);
      }
    }
  } catch (const gp::VdbError& e) {
    gp::fuzz::require_mentions(e, path);
  }
  return 0;
}
