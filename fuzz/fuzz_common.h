// Shared by the fuzz targets (fuzz/README in docs/reliability.md): what a target may throw and
// how it checks the message. A target returns normally for every input that ends in the
// documented error type with a message naming the file; anything else (another exception, a
// crash, a sanitizer report, a hang, more memory than libFuzzer's limit) is a finding.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>

#include <unistd.h>

namespace gp::fuzz {

// Aborts (a libFuzzer crash with this message) when an error message does not name `what`.
inline void require_mentions(const std::exception& e, std::string_view what) {
  const std::string_view msg = e.what();
  if (msg.find(what) == std::string_view::npos) {
    std::fprintf(stderr, "error message does not name '%.*s': %s\n", int(what.size()), what.data(), e.what());
    std::abort();
  }
}

// A per-process scratch file for targets whose code under test reads from a path.
inline std::string scratch_path(const char* stem, const char* extension) {
  const char* tmp = std::getenv("TMPDIR");
  return std::string(tmp && *tmp ? tmp : "/tmp") + "/gradphoton-fuzz-" + stem + "-" + std::to_string(::getpid()) + extension;
}

}  // namespace gp::fuzz
