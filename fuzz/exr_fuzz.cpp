// libFuzzer target: the EXR reader behind diff, merge and reconstruct (io/exr.h read_exr and
// read_exr_attributes) and the run record it carries (distributed/run_info.h from_attributes).
// The input is written to a scratch .exr file; every input must read or throw
// std::runtime_error naming that file.
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>

#include "distributed/run_info.h"
#include "fuzz/fuzz_common.h"
#include "io/exr.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // A header may ask for any size: read_exr refuses what exceeds the limit (core/memory.h).
  // 32 MB, not the loaders' 256: a tiny file may legally ask for a film up to the limit, and
  // filling 256 MB under ASan at nice 19 on a busy machine ran past libFuzzer's timeout.
  setenv("GRADPHOTON_MEMORY_LIMIT_MB", "32", 0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = gp::fuzz::scratch_path("exr", ".exr");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const auto attributes = gp::read_exr_attributes(path);
    if (gp::has_run_info(attributes)) {
      try {
        gp::from_attributes(attributes, path);
      } catch (const std::runtime_error& e) {
        gp::fuzz::require_mentions(e, path);
      }
    }
    gp::Film film = gp::read_exr(path);
  } catch (const std::runtime_error& e) {
    gp::fuzz::require_mentions(e, path);
  }
  return 0;
}
