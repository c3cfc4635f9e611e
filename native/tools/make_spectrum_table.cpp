// make_spectrum_table OUT.cpp: fits Jakob & Hanika's coefficient table with the core's own fit
// (gp::spectrum_table::fit_coefficient_table, core/spectrum.cpp, the same object the core links)
// and writes it as a C++ source that defines gp::spectrum_table::kZ and kCoefficients. Run by
// CMake at build time (CMakeLists.txt, "Jakob & Hanika's coefficient table"); the output lives
// in the build folder, not in the repository. Floats are written as hex literals: exact.
#include <cmath>
#include <cstdio>
#include <string>

#include "core/spectrum_table.h"

namespace {

bool write_array(std::FILE* f, const char* name, const float* v, std::size_t n) {
  std::fprintf(f, "alignas(64) const float %s[%zu] = {\n", name, n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) {
      std::fprintf(stderr, "make_spectrum_table: %s[%zu] is not finite (%g): the fit failed\n", name, i, v[i]);
      return false;
    }
    std::fprintf(f, "%a%s", static_cast<double>(v[i]), (i + 1) % 8 == 0 ? "f,\n" : "f, ");
  }
  std::fprintf(f, "};\n");
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  namespace tb = gp::spectrum_table;
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_spectrum_table OUT.cpp\n");
    return 2;
  }
  const std::string out = argv[1], tmp = out + ".tmp";
  const std::array<float, tb::kRes> z = tb::fit_z_grid();
  const std::vector<float> c = tb::fit_coefficient_table();
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "make_spectrum_table: cannot write %s\n", tmp.c_str());
    return 1;
  }
  std::fprintf(f,
               "// Generated at build time by make_spectrum_table (native/tools/make_spectrum_table.cpp): "
               "Jakob & Hanika's\n// coefficient table as the core's fit computes it. Do not edit.\n"
               "#include \"core/spectrum_table.h\"\n\nnamespace gp::spectrum_table {\n\n");
  bool ok = write_array(f, "kZ", z.data(), z.size());
  std::fprintf(f, "\n");
  ok = ok && write_array(f, "kCoefficients", c.data(), c.size());
  std::fprintf(f, "\n}  // namespace gp::spectrum_table\n");
  ok = (std::fclose(f) == 0) && ok;
  // Written whole and then renamed, so an interrupted build never leaves half a table behind.
  if (!ok || std::rename(tmp.c_str(), out.c_str()) != 0) {
    std::remove(tmp.c_str());
    std::fprintf(stderr, "make_spectrum_table: writing %s failed\n", out.c_str());
    return 1;
  }
  return 0;
}
