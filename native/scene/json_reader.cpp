// JSON helpers of the scene loader: JSON Pointer paths, joining names, parsing with positioned errors.
#include "scene/json_reader.h"

namespace gp {

namespace {
// Finds the byte offset of a JSON error when the DOM parser's exception does not carry one
// (number overflow such as 1e999 is reported as out_of_range without a position).
struct ErrorPositionFinder : nlohmann::json_sax<json> {
  size_t position = 0;
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(size_t pos, const std::string&, const nlohmann::detail::exception&) override {
    position = pos;
    return false;
  }
};
}  // namespace

std::string pointer_token(std::string_view key) {
  std::string out;
  for (char c : key) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}
std::string sub(const std::string& path, std::string_view key) { return path + "/" + pointer_token(key); }
std::string sub(const std::string& path, size_t index) { return fmt::format("{}/{}", path, index); }

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? ", " : "") + items[i];
  return out;
}

json parse_json(const std::string& text, const std::string& file) {
  try {
    // Comments (// and /* */) are accepted as an extension; the bundled scenes are strict JSON.
    return json::parse(text, nullptr, true, true);
  } catch (const json::parse_error& e) {
    throw SceneError(fmt::format("{}: JSON syntax error at byte {}: {}", file, e.byte, e.what()));
  } catch (const json::exception& e) {
    ErrorPositionFinder finder;
    json::sax_parse(text, &finder, json::input_format_t::json, true, true);
    throw SceneError(fmt::format("{}: JSON error at byte {}: {}", file, finder.position, e.what()));
  }
}

}  // namespace gp
