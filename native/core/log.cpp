#include "core/log.h"

#include <fmt/format.h>

namespace gp {

void Warnings::add(const std::string& kind, const std::string& message) {
  if (counts_[kind]++ == 0) first_[kind] = message;
}

size_t Warnings::count(const std::string& kind) const {
  auto it = counts_.find(kind);
  return it == counts_.end() ? 0 : it->second;
}

size_t Warnings::total() const {
  size_t n = 0;
  for (const auto& [k, c] : counts_) n += c;
  return n;
}

std::vector<std::string> Warnings::summary() const {
  std::vector<std::string> lines;
  for (const auto& [kind, c] : counts_) {
    if (c == 1)
      lines.push_back(fmt::format("{}: {}", kind, first_.at(kind)));
    else
      lines.push_back(fmt::format("{} x {} (first: {})", c, kind, first_.at(kind)));
  }
  return lines;
}

}  // namespace gp
