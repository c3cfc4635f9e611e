// Warnings collected while loading or rendering: counted by kind and kept for reports, so a
// scene with ten thousand degenerate triangles gives one line, not ten thousand.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace gp {

class Warnings {
 public:
  // Records a warning of `kind` (e.g. "zero-area triangle"); keeps the first few messages.
  void add(const std::string& kind, const std::string& message);
  size_t count(const std::string& kind) const;
  size_t total() const;
  bool empty() const { return counts_.empty(); }
  // One line per kind: "<count> x <kind>: <first message>".
  std::vector<std::string> summary() const;

 private:
  std::map<std::string, size_t> counts_;
  std::map<std::string, std::string> first_;
};

}  // namespace gp
