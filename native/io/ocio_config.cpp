#include "io/ocio_config.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <vector>

namespace fs = std::filesystem;

namespace gp {

namespace {

// Compares version-like directory names ("3.4" < "3.10" < "4.0"); newest first when sorted.
bool version_greater(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      const unsigned long long na = std::stoull(a.substr(i, std::min<size_t>(ie - i, 18)));
      const unsigned long long nb = std::stoull(b.substr(j, std::min<size_t>(je - j, 18)));
      if (na != nb) return na > nb;
      i = ie; j = je;
    } else {
      if (a[i] != b[j]) return a[i] > b[j];
      ++i; ++j;
    }
  }
  return a.size() - i > b.size() - j;
}

}  // namespace

std::string find_blender_config() {
  const fs::path root = "/usr/share/blender";
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return {};
  std::vector<std::string> versions;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (e.is_directory(ec)) versions.push_back(e.path().filename().string());
  std::sort(versions.begin(), versions.end(), version_greater);
  for (const auto& v : versions) {
    const fs::path p = root / v / "datafiles/colormanagement/config.ocio";
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  const fs::path p = root / "datafiles/colormanagement/config.ocio";
  if (fs::is_regular_file(p, ec)) return p.string();
  return {};
}

// Blender ships its config as <...>/datafiles/colormanagement/config.ocio.
bool looks_like_blender(const std::string& path) {
  const std::string generic = fs::path(path).lexically_normal().generic_string();
  return generic.find("datafiles/colormanagement/") != std::string::npos;
}

std::string default_ocio_config() {
  const char* env = std::getenv("OCIO");
  if (env && *env) return env;
  return find_blender_config();
}

}  // namespace gp
