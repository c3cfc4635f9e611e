// OpenEXR I/O for Film: one single-part, multi-channel scanline EXR, one layer per pass.
//
// Writing: float channels, ZIP compression. An RGB pass "combined" becomes the channels
// "combined.R", "combined.G", "combined.B"; a scalar pass "error" becomes "error.V".
//
// Reading (any EXR, half / float / uint channels, converted to float):
//   channels are grouped into layers by the prefix before the last '.' ("" if none);
//   - a layer with R, G, B            -> RGB pass named by the layer ("" -> "combined");
//   - else a layer with X, Y, Z       -> RGB pass (Blender's Normal / Vector passes);
//   - a layer with a single channel   -> scalar pass named by the layer ("" -> the channel name);
//   - any other channel (A, W, ...)   -> scalar pass named by the full channel name
//                                        ("combined.A", or "A" for unlayered files).
//   Blender multilayer names keep their prefix: "ViewLayer.Combined.R" -> pass "ViewLayer.Combined".
//   Row 0 of the film is the top row of the data window.
// Header: `attributes` become string attributes (the run's record, distributed/run_info.h);
// read_exr_attributes returns every string attribute of a file's header.
// Every failure throws std::runtime_error whose message contains the path.
#pragma once

#include <map>
#include <string>

#include "core/film.h"

namespace gp {

void write_exr(const std::string& path, const Film& film,
               const std::map<std::string, std::string>& attributes = {});
Film read_exr(const std::string& path);
std::map<std::string, std::string> read_exr_attributes(const std::string& path);

}  // namespace gp
