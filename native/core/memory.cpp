#include "core/memory.h"

#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

namespace gp {

double memory_budget_bytes() {
  if (const char* env = std::getenv("GRADPHOTON_MEMORY_LIMIT_MB"); env && *env) {
    char* end = nullptr;
    const double mb = std::strtod(env, &end);
    if (end != env && mb > 0) return mb * 1024.0 * 1024.0;
  }
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  double kb = 0;
  while (meminfo >> key >> kb) {
    if (key == "MemAvailable:") return kb * 1024.0;
    meminfo.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return 0;
}

}  // namespace gp
