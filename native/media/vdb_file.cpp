#include "media/vdb_file.h"

#include "core/memory.h"

#include <fstream>
#include <mutex>
#include <sstream>

#include <fmt/format.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

namespace gp {

namespace {

void init_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

// One parser for files and memory: OpenVDB's stream reader (a .vdb file is an archive it reads
// front to back), every grid loaded (no delayed loading: nothing stays mapped).
openvdb::GridPtrVecPtr read_archive(std::istream& in, const std::string& label) {
  init_openvdb();
  try {
    // A read past the end throws: OpenVDB's readers loop on counts read from the file without
    // testing the stream (a corrupt tile count read past the end for ever: fuzz/corpus/vdb).
    in.exceptions(std::ios::failbit | std::ios::badbit);
    openvdb::io::Stream stream(in, /*delayLoad=*/false);
    openvdb::GridPtrVecPtr grids = stream.getGrids();
    if (!grids) throw VdbError(fmt::format("{}: not an OpenVDB file (no grids)", label));
    return grids;
  } catch (const VdbError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw VdbError(fmt::format("{}: corrupt OpenVDB file (asks for more memory than there is)", label));
  } catch (const std::exception& e) {
    throw VdbError(fmt::format("{}: not a readable OpenVDB file ({})", label, e.what()));
  }
}

openvdb::GridPtrVecPtr read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw VdbError(fmt::format("'{}': cannot open the OpenVDB file (missing or unreadable)", path));
  return read_archive(in, fmt::format("'{}'", path));
}

template <class GridT, int C>
std::shared_ptr<VoxelGrid> dense_copy(const GridT& grid, const std::string& label) {
  auto out = std::make_shared<VoxelGrid>();
  out->name = grid.getName();
  out->channels = C;
  const openvdb::math::Transform& xf = grid.transform();
  if (!xf.isLinear())
    throw VdbError(fmt::format("{}: grid '{}' has a non-linear (frustum) transform, not supported", label, out->name));
  const openvdb::math::Mat4d m = xf.baseMap()->getAffineMap()->getMat4();
  // OpenVDB multiplies row vectors (p' = p M, translation in the last row).
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out->index_to_object.m[i][j] = static_cast<float>(m(j, i));
    out->index_to_object.m[i][3] = static_cast<float>(m(3, i));
  }
  if (!out->index_to_object.is_finite())
    throw VdbError(fmt::format("{}: grid '{}' has a transform that is not finite", label, out->name));
  const auto bg = grid.background();
  for (int c = 0; c < C; ++c) {
    if constexpr (C == 1) out->background[c] = static_cast<float>(bg);
    else out->background[c] = static_cast<float>(bg[c]);
  }
  const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
  if (box.empty()) return out;  // no active voxel: the background everywhere
  const openvdb::Coord dim = box.dim();
  int64_t n = 1;
  for (int a = 0; a < 3; ++a) {
    if (dim[a] <= 0) throw VdbError(fmt::format("{}: grid '{}' has an invalid bounding box", label, out->name));
    n *= dim[a];
    if (n > kMaxGridVoxels)
      throw VdbError(fmt::format("{}: grid '{}' spans more than {} voxels (its active bounding box is {} x {} x {})",
                                 label, out->name, kMaxGridVoxels, dim[0], dim[1], dim[2]));
    out->lo[a] = box.min()[a];
    out->size[a] = dim[a];
  }
  const double bytes = double(n) * C * sizeof(float), budget = memory_budget_bytes();
  if (budget > 0 && bytes > budget)
    throw VdbError(fmt::format("{}: grid '{}' needs {:.0f} MB dense, more than the memory budget ({:.0f} MB)", label,
                               out->name, bytes / 1e6, budget / 1e6));
  try {
    out->data.assign(static_cast<size_t>(n) * C, 0.0f);
  } catch (const std::bad_alloc&) {
    throw VdbError(fmt::format("{}: grid '{}' does not fit in memory", label, out->name));
  }
  auto acc = grid.getConstAccessor();
  size_t at = 0;
  for (int k = box.min().z(); k <= box.max().z(); ++k)
    for (int j = box.min().y(); j <= box.max().y(); ++j)
      for (int i = box.min().x(); i <= box.max().x(); ++i) {
        const auto v = acc.getValue(openvdb::Coord(i, j, k));
        for (int c = 0; c < C; ++c) {
          float f;
          if constexpr (C == 1) f = static_cast<float>(v);
          else f = static_cast<float>(v[c]);
          out->data[at++] = std::isfinite(f) ? f : 0.0f;  // NaN / Inf never reach a pass
        }
      }
  for (float& b : out->background)
    if (!std::isfinite(b)) b = 0.0f;
  return out;
}

std::shared_ptr<VoxelGrid> convert(const openvdb::GridBase::Ptr& base, const std::string& label) {
  if (auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) return dense_copy<openvdb::FloatGrid, 1>(*g, label);
  if (auto g = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) return dense_copy<openvdb::DoubleGrid, 1>(*g, label);
  if (auto g = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base)) return dense_copy<openvdb::Vec3SGrid, 3>(*g, label);
  if (auto g = openvdb::gridPtrCast<openvdb::Vec3DGrid>(base)) return dense_copy<openvdb::Vec3DGrid, 3>(*g, label);
  return nullptr;
}

std::string join_names(const std::vector<std::string>& names) {
  if (names.empty()) return "none";
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "'" : ", '") + n + "'";
  return s;
}

std::shared_ptr<VoxelGrid> find_grid(const openvdb::GridPtrVec& grids, const std::string& name, const std::string& label) {
  std::vector<std::string> names;
  for (const auto& g : grids) {
    if (!g) continue;
    if (name.empty() || g->getName() == name) {
      if (auto v = convert(g, label)) return v;
      if (!name.empty())
        throw VdbError(fmt::format("{}: grid '{}' is of type {} (float or vector grids are read)", label, name, g->type()));
    }
    names.push_back(g->getName());
  }
  if (name.empty()) return nullptr;
  throw VdbError(fmt::format("{}: no grid named '{}' (the file has: {})", label, name,
                             join_names(names)));
}

}  // namespace

std::vector<VdbGridInfo> vdb_grid_names(const std::string& path) {
  std::vector<VdbGridInfo> out;
  const openvdb::GridPtrVecPtr grids = read_file(path);  // (held: a range-for over *read_file() would dangle)
  for (const auto& g : *grids)
    if (g) out.push_back({g->getName(), g->valueType()});
  return out;
}

std::shared_ptr<VoxelGrid> read_vdb_grid(const std::string& path, const std::string& name) {
  const openvdb::GridPtrVecPtr grids = read_file(path);
  return find_grid(*grids, name, fmt::format("'{}'", path));
}

std::shared_ptr<VoxelGrid> read_vdb_grid_from_memory(const std::string& bytes, const std::string& name,
                                                     const std::string& label) {
  std::istringstream in(bytes, std::ios::binary);
  const openvdb::GridPtrVecPtr grids = read_archive(in, label);
  return find_grid(*grids, name, label);
}

namespace {
template <class GridT, int C>
openvdb::GridBase::Ptr to_openvdb(const VoxelGrid& v) {
  using Value = typename GridT::ValueType;
  Value bg;
  if constexpr (C == 1) bg = v.background[0];
  else bg = Value(v.background[0], v.background[1], v.background[2]);
  typename GridT::Ptr grid = GridT::create(bg);
  grid->setName(v.name);
  openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m(j, i) = v.index_to_object.m[i][j];
    m(3, i) = v.index_to_object.m[i][3];
  }
  grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
  auto acc = grid->getAccessor();
  size_t at = 0;
  for (int k = 0; k < v.size[2]; ++k)
    for (int j = 0; j < v.size[1]; ++j)
      for (int i = 0; i < v.size[0]; ++i, at += C) {
        Value val;
        if constexpr (C == 1) val = v.data[at];
        else val = Value(v.data[at], v.data[at + 1], v.data[at + 2]);
        if (val != bg) acc.setValue(openvdb::Coord(v.lo[0] + i, v.lo[1] + j, v.lo[2] + k), val);
      }
  return grid;
}
}  // namespace

void write_vdb(const std::string& path, const std::vector<const VoxelGrid*>& grids) {
  init_openvdb();
  openvdb::GridPtrVec out;
  for (const VoxelGrid* g : grids) {
    if (g->data.size() != static_cast<size_t>(g->voxels()) * g->channels)
      throw VdbError(fmt::format("'{}': grid '{}' has {} values for {} voxels", path, g->name, g->data.size(), g->voxels()));
    out.push_back(g->channels == 1 ? to_openvdb<openvdb::FloatGrid, 1>(*g) : to_openvdb<openvdb::Vec3SGrid, 3>(*g));
  }
  try {
    openvdb::io::File file(path);
    file.write(out);
    file.close();
  } catch (const std::exception& e) {
    throw VdbError(fmt::format("'{}': cannot write the OpenVDB file ({})", path, e.what()));
  }
}

}  // namespace gp
