#include "core/film.h"

#include <stdexcept>

namespace gp {

Pass& Film::add_pass(std::string_view name, int channels) {
  if (channels != 1 && channels != 3)
    throw std::invalid_argument("pass '" + std::string(name) + "': channels must be 1 or 3");
  auto it = passes_.find(name);
  if (it != passes_.end()) {
    if (it->second.channels != channels)
      throw std::invalid_argument("pass '" + std::string(name) + "' exists with another channel count");
    return it->second;
  }
  Pass p;
  p.channels = channels;
  p.data.assign(pixel_count() * channels, 0.0f);
  return passes_.emplace(std::string(name), std::move(p)).first->second;
}

const Pass& Film::pass(std::string_view name) const {
  auto it = passes_.find(name);
  if (it == passes_.end()) throw std::out_of_range("film has no pass '" + std::string(name) + "'");
  return it->second;
}

Pass& Film::pass(std::string_view name) {
  auto it = passes_.find(name);
  if (it == passes_.end()) throw std::out_of_range("film has no pass '" + std::string(name) + "'");
  return it->second;
}

RGB Film::rgb(std::string_view name, int x, int y) const {
  const Pass& p = pass(name);
  const size_t i = (static_cast<size_t>(y) * width_ + x) * p.channels;
  if (p.channels == 1) return RGB(p.data[i]);
  return {p.data[i], p.data[i + 1], p.data[i + 2]};
}

void Film::set_rgb(std::string_view name, int x, int y, const RGB& c) {
  Pass& p = pass(name);
  const size_t i = (static_cast<size_t>(y) * width_ + x) * p.channels;
  if (p.channels == 1) {
    p.data[i] = c.luminance();
    return;
  }
  p.data[i] = c.r; p.data[i + 1] = c.g; p.data[i + 2] = c.b;
}

}  // namespace gp
