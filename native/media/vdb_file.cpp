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

// ---- A bounded look at the archive before OpenVDB reads it ----
// OpenVDB's readers trust the lengths in a file: readString (util/Name.h) builds a std::string
// of a 32-bit length read from it, filled, before reading its bytes, so one corrupt length in a
// 10 KB file had the loader touch 4 GB and take seconds before failing. Every string and
// metadata value stands in the file itself, so each length is checked against the bytes left,
// through the header, the file's metadata, the grid descriptors and each grid's metadata and
// transform type (what precedes its tree), following the archive layout of OpenVDB 10
// (io/Archive.cc readHeader, io/GridDescriptor.cc, math/Transform.cc; version.h's file versions).
// Files older than file version 222 (OpenVDB 3) are left to OpenVDB as they are.
class ArchiveScan {
 public:
  ArchiveScan(std::istream& in, const std::string& label) : in_(in), label_(label) {
    in_.seekg(0, std::ios::end);
    size_ = static_cast<int64_t>(in_.tellg());
    in_.seekg(0);
  }
  void run() {
    if (u64() != 0x56444220ULL) return;  // not a VDB: OpenVDB says so
    const uint32_t version = u32();
    if (version < 222) return;
    u32();  // library major
    u32();  // minor
    const bool offsets = u8() != 0;
    skip(36);  // UUID as text
    meta_map("the file's metadata");
    const int32_t count = static_cast<int32_t>(u32());
    if (count < 0 || count > left() / 36) fail(fmt::format("a grid count of {}", count));
    for (int32_t g = 0; g < count; ++g) {
      const std::string name = string("a grid name");
      string("a grid type");
      string("a grid's instance parent");
      const int64_t grid = i64(), block = i64(), end = i64();
      const int64_t here = pos();
      if (!offsets) {  // grids follow their descriptors: only the first can be found
        grid_head(name);
        return;
      }
      if (!(here <= grid && grid <= block && block <= end && end <= size_))
        fail(fmt::format("grid '{}' placed at bytes {}..{} (block {}) of {}", name, grid, end, block, size_));
      seek(grid);
      grid_head(name);
      seek(end);
    }
  }

 private:
  // What precedes a grid's tree: its compression flags, metadata and transform type.
  void grid_head(const std::string& name) {
    u32();
    meta_map(fmt::format("grid '{}''s metadata", name));
    string(fmt::format("grid '{}''s transform type", name));
  }
  void meta_map(const std::string& what) {
    const uint32_t n = u32();
    if (n > static_cast<uint64_t>(left()) / 12) fail(fmt::format("{} claims {} entries", what, n));
    for (uint32_t i = 0; i < n; ++i) {
      string(what + " (a name)");
      string(what + " (a type)");
      string(what + " (a value)");  // Metadata::read: a 32-bit size, then the value's bytes
    }
  }
  std::string string(const std::string& what) {
    const uint32_t n = u32();
    if (n > left()) fail(fmt::format("{} of {} bytes at byte {}, past the end of its {} bytes", what, n, pos(), size_));
    if (n <= 256) {
      std::string s(n, ' ');
      read(s.data(), n);
      return s;
    }
    skip(n);
    return std::string();
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw VdbError(fmt::format("{}: corrupt OpenVDB file ({})", label_, what));
  }
  int64_t pos() { return static_cast<int64_t>(in_.tellg()); }
  int64_t left() { return size_ - pos(); }
  void seek(int64_t p) { in_.seekg(p); }
  void skip(int64_t n) {
    if (n > left()) fail(fmt::format("{} bytes expected at byte {} of {}", n, pos(), size_));
    in_.seekg(n, std::ios::cur);
  }
  void read(char* p, int64_t n) {
    if (n > left()) fail(fmt::format("the file ends at byte {}", size_));
    in_.read(p, n);
  }
  uint8_t u8() {
    char c;
    read(&c, 1);
    return static_cast<uint8_t>(c);
  }
  uint32_t u32() {
    uint32_t v;
    read(reinterpret_cast<char*>(&v), 4);
    return v;
  }
  uint64_t u64() {
    uint64_t v;
    read(reinterpret_cast<char*>(&v), 8);
    return v;
  }
  int64_t i64() { return static_cast<int64_t>(u64()); }

  std::istream& in_;
  const std::string& label_;
  int64_t size_ = 0;
};

// One parser for files and memory: OpenVDB's stream reader (a .vdb file is an archive it reads
// front to back), every grid loaded (no delayed loading: nothing stays mapped), after the bounded
// scan above.
openvdb::GridPtrVecPtr read_archive(std::istream& in, const std::string& label) {
  init_openvdb();
  try {
    // A read past the end throws: OpenVDB's readers loop on counts read from the file without
    // testing the stream (a corrupt tile count read past the end for ever: fuzz/corpus/vdb).
    in.exceptions(std::ios::failbit | std::ios::badbit);
    ArchiveScan(in, label).run();
    in.seekg(0);
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
