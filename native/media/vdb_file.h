// OpenVDB files (Debian's libopenvdb, the library Debian's Blender writes its caches with): grids
// read by name into the core's dense VoxelGrid (media/grid.h), and a small writer for tests and
// tools. OpenVDB's types stay in vdb_file.cpp.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "media/grid.h"

namespace gp {

// Any failure to read a grid: the message names the file (and the grid).
struct VdbError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct VdbGridInfo {
  std::string name, type;  // type: OpenVDB's ("float", "vec3s", ...)
};

// The grids of a file, by name and type. Throws VdbError naming the file.
std::vector<VdbGridInfo> vdb_grid_names(const std::string& path);

// Reads grid `name` of `path` (float / double: 1 channel; vec3s / vec3d: 3) into a dense grid over
// its active voxels' bounding box. Throws VdbError naming the file and grid when the file is
// missing, unreadable or corrupt, the grid is absent or of another type, its transform is not
// linear, or it holds more than kMaxGridVoxels voxels.
std::shared_ptr<VoxelGrid> read_vdb_grid(const std::string& path, const std::string& name);

// Reads from memory (the fuzz target: the same parsing as read_vdb_grid through a stream);
// `name` empty: every grid, of which the first float/vec3 grid is returned (null: none).
std::shared_ptr<VoxelGrid> read_vdb_grid_from_memory(const std::string& bytes, const std::string& name,
                                                     const std::string& label);

// Writes grids (their dense values, background and transform; voxels equal to the background
// stay inactive) to a .vdb file. Throws VdbError naming the file.
void write_vdb(const std::string& path, const std::vector<const VoxelGrid*>& grids);

}  // namespace gp
