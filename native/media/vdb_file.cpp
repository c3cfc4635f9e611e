#include "media/vdb_file.h"

#include "core/memory.h"

#include <array>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>

#include <blosc.h>
#include <fmt/format.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

namespace gp {

namespace {

void init_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

// ---- A bounded walk of the archive before OpenVDB reads it ----
// OpenVDB 10's readers trust the lengths and counts in a file: readString (util/Name.h) fills a
// std::string of a 32-bit length before reading it; bloscFromStream and unzipFromStream
// (io/Compression.cc) allocate a 64-bit chunk size from the file, and copy an uncompressed chunk
// of the size the file gives into a buffer of the size the tree expects; DelayedLoadMetadata's
// readValue (io/DelayedLoadMetadata.cc) reserves what a blosc header claims; a root node's tile
// and child counts loop past the end. So the whole archive is walked first, exactly as
// io::Stream will read it (front to back: io/Stream.cc, Archive::readGrid, GridDescriptor::read),
// every length and count checked against the bytes left, every compressed chunk's header
// checked (blosc's own validation, sizes against what the node holds), and the tree's topology
// and buffers followed node by node (tree/Tree.h, RootNode.h, InternalNode.h, LeafNode*.h
// readTopology / readBuffers; io/Compression.h readCompressedValues): any file either passes
// (and OpenVDB then reads only what was checked) or is a VdbError naming the file and what was
// wrong. Files older than file version 222 (OpenVDB 3; Blender writes 224) are refused, as are
// grid types whose trees are not the standard 5-4-3 trees of plain values (point grids).
class ArchiveScan {
 public:
  ArchiveScan(std::istream& in, const std::string& label) : in_(in), label_(label) {
    in_.seekg(0, std::ios::end);
    size_ = static_cast<int64_t>(in_.tellg());
    in_.seekg(0);
  }
  void run() {
    if (size_ < 8 || u64() != 0x56444220ULL) return;  // not a VDB: OpenVDB says so
    version_ = u32();
    if (version_ < 222 || version_ > 224)
      fail(fmt::format("file version {}: versions 222 (OpenVDB 3) to 224 (OpenVDB 10) are read", version_));
    u32();  // library major
    u32();  // minor
    const bool offsets = u8() != 0;
    skip(36);  // UUID as text
    meta_map("the file's metadata");
    const int32_t count = static_cast<int32_t>(u32());
    if (count < 0 || count > left() / 36) fail(fmt::format("a grid count of {}", count));
    for (int32_t g = 0; g < count; ++g) {
      const std::string name = string("a grid name");
      std::string type = string("a grid type");
      const std::string parent = string("a grid's instance parent");
      const int64_t grid = i64(), block = i64(), end = i64();
      const int64_t here = pos();
      // io::Stream reads a grid right after its descriptor, whatever the offsets say; a file
      // with offsets (io::File's) must agree with that (an instance has no block: 0).
      if (offsets && !(grid == here && grid <= end && end <= size_ && (block == 0 || (grid <= block && block <= end))))
        fail(fmt::format("grid '{}' placed at bytes {}..{} (block {}) of {}", name, grid, end, block, size_));
      const std::string what = fmt::format("grid '{}'", name);
      const bool half = ends_with(type, "_HalfFloat");
      if (half) type.resize(type.size() - 10);
      const Tree tree = tree_of(type, half, what);
      compression_ = u32();
      meta_map(what + "'s metadata");
      transform(what, 0);
      if (parent.empty()) this->tree(tree, what);  // an instance shares its parent's tree
      if (offsets && pos() != end)
        fail(fmt::format("grid '{}' ends at byte {}, its descriptor says {}", name, pos(), end));
    }
  }

 private:
  // ---- Grid types: the value size of a standard tree (RootNode<Internal<5>, Internal<4>, Leaf<3>>) ----
  struct Tree {
    int value = 0;      // sizeof(ValueType) (bool: 1)
    int stored = 0;     // bytes per value in compressed buffers (2 per component for half floats)
    bool real = false;  // HalfReader's isReal: floating point (half applies)
    enum { kValues, kBool, kMask } leaf = kValues;
  };
  static bool ends_with(const std::string& s, const std::string& t) {
    return s.size() >= t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
  }
  Tree tree_of(const std::string& type, bool half, const std::string& what) const {
    struct Known {
      const char* name;
      int value, components;
      bool real;
    };
    static const Known known[] = {{"float", 4, 1, true},  {"double", 8, 1, true},  {"int32", 4, 1, false},
                                  {"int64", 8, 1, false}, {"vec2s", 8, 2, true},   {"vec2d", 16, 2, true},
                                  {"vec2i", 8, 2, false}, {"vec3s", 12, 3, true},  {"vec3d", 24, 3, true},
                                  {"vec3i", 12, 3, false}, {"bool", 1, 1, false}, {"mask", 1, 1, false}};
    const std::string prefix = "Tree_", suffix = "_5_4_3";
    if (type.size() > prefix.size() + suffix.size() && type.compare(0, prefix.size(), prefix) == 0 &&
        ends_with(type, suffix)) {
      const std::string v = type.substr(prefix.size(), type.size() - prefix.size() - suffix.size());
      for (const Known& k : known)
        if (v == k.name) {
          Tree t;
          t.value = k.value;
          t.real = k.real;
          t.stored = half && k.real ? 2 * k.components : k.value;
          t.leaf = v == "bool" ? Tree::kBool : v == "mask" ? Tree::kMask : Tree::kValues;
          return t;
        }
    }
    fail(fmt::format("{} is of type '{}', not a tree of plain values that this loader reads", what,
                     type.substr(0, 64)));
  }

  // ---- Transform (math/Transform.cc read, math/Maps.h each map's read) ----
  void transform(const std::string& what, int depth) {
    const std::string type = string(what + "'s transform type");
    if (type == "AffineMap" || type == "UnitaryMap") skip(128);  // a Mat4d
    else if (type == "ScaleMap" || type == "UniformScaleMap") skip(5 * 24);  // five Vec3d
    else if (type == "ScaleTranslateMap" || type == "UniformScaleTranslateMap") skip(6 * 24);
    else if (type == "TranslationMap") skip(24);
    else if (type == "NonlinearFrustumMap" && depth == 0) {
      skip(48 + 16);  // bounding box (two Vec3d), taper and depth
      transform(what, 1);  // its second (linear) map
    } else {
      fail(fmt::format("{}'s transform is of type '{}'", what, type.substr(0, 64)));
    }
  }

  // ---- The tree (tree/Tree.h, RootNode.h, InternalNode.h, LeafNode.h, LeafNodeBool.h, LeafNodeMask.h) ----
  static constexpr int kMask5 = 32768 / 8, kMask4 = 4096 / 8, kMask3 = 512 / 8;  // node masks' bytes
  void tree(const Tree& t, const std::string& what) {
    u32();  // buffer count (TreeBase::readTopology)
    // Root: background, tile and child counts, tiles, then children keyed by their coordinates
    // (std::map: a repeated key replaces the earlier entry; buffers follow in key order).
    skip(t.value);
    const uint32_t tiles = u32(), children = u32();
    if (tiles > static_cast<uint64_t>(left()) / (12 + t.value + 1) ||
        children > static_cast<uint64_t>(left()) / (12 + 2 * kMask5))
      fail(fmt::format("{}'s root claims {} tiles and {} children", what, tiles, children));
    std::map<std::array<int32_t, 3>, int> table;  // value: index into nodes, -1 a tile
    for (uint32_t n = 0; n < tiles; ++n) {
      table[coord()] = -1;
      skip(t.value);
      if (u8() > 1) fail(what + ": a root tile's active flag is not 0 or 1");
    }
    std::vector<std::vector<int>> nodes;  // per root child: each of its children's leaf count
    double memory = 0;
    for (uint32_t n = 0; n < children; ++n) {
      const auto key = coord();
      std::vector<int> leaves;
      // Internal node of 32^3: child and value masks, values, then its children (16^3 nodes).
      const std::vector<uint64_t> child = mask(kMask5);
      const std::vector<uint64_t> active = mask(kMask5);
      values(t, 32768, active, what);
      for (int i = 0; i < bits(child); ++i) {
        const std::vector<uint64_t> child4 = mask(kMask4);
        const std::vector<uint64_t> active4 = mask(kMask4);
        values(t, 4096, active4, what);
        const int nleaf = bits(child4);
        skip(int64_t(nleaf) * kMask3);  // each leaf's topology: one mask
        leaves.push_back(nleaf);
        memory += 4096.0 * std::max(t.value, 8) + 512.0 * t.value * nleaf;
      }
      memory += 32768.0 * std::max(t.value, 8);
      nodes.push_back(std::move(leaves));
      table[key] = static_cast<int>(nodes.size()) - 1;
    }
    // What OpenVDB's tree will hold, against the memory budget (a few bytes of masks can ask
    // for a node of 32^3 values).
    const double budget = memory_budget_bytes();
    if (budget > 0 && memory > budget)
      fail(fmt::format("{}'s tree needs about {:.0f} MB, more than the memory budget ({:.0f} MB)", what, memory / 1e6,
                       budget / 1e6));
    // Buffers, leaf by leaf, in the root's key order.
    for (const auto& [key, index] : table) {
      if (index < 0) continue;
      for (int nleaf : nodes[index])
        for (int l = 0; l < nleaf; ++l) leaf_buffers(t, what);
    }
  }
  void leaf_buffers(const Tree& t, const std::string& what) {
    switch (t.leaf) {
      case Tree::kMask:  // LeafNode<ValueMask>: its mask, its origin
        skip(kMask3 + 12);
        return;
      case Tree::kBool:  // LeafNode<bool>: value mask, origin, value bits
        skip(kMask3 + 12 + kMask3);
        return;
      case Tree::kValues: {
        const std::vector<uint64_t> active = mask(kMask3);
        values(t, 512, active, what);
        return;
      }
    }
  }
  // io/Compression.h readCompressedValues over a node of `count` values with value mask `active`.
  void values(const Tree& t, int count, const std::vector<uint64_t>& active, const std::string& what) {
    const bool mask_compressed = compression_ & 0x2;  // COMPRESS_ACTIVE_MASK
    const int8_t meta = static_cast<int8_t>(u8());  // NO_MASK_OR_INACTIVE_VALS ... NO_MASK_AND_ALL_VALS
    if (meta == 2 || meta == 4 || meta == 5) skip(t.value);  // one inactive value
    if (meta == 5) skip(t.value);                            // a second one
    if (meta == 3 || meta == 4 || meta == 5) skip(count / 8);  // the selection mask
    int64_t n = count;
    if (mask_compressed && meta != 6) n = bits(active);
    if (t.stored != t.value && n < 1) return;  // HalfReader reads nothing for no values
    const int64_t bytes = n * t.stored;
    if (compression_ & 0x4) chunk(bytes, true, what);       // COMPRESS_BLOSC
    else if (compression_ & 0x1) chunk(bytes, false, what);  // COMPRESS_ZIP
    else skip(bytes);
  }
  // One blosc or zip chunk (io/Compression.cc bloscFromStream / unzipFromStream) that must hold
  // `bytes` bytes: a 64-bit size, negative for stored bytes.
  void chunk(int64_t bytes, bool blosc, const std::string& what) {
    const int64_t n = i64();
    if (n <= 0) {
      if (n == std::numeric_limits<int64_t>::min() || -n != bytes)
        fail(fmt::format("{}: an uncompressed chunk of {} bytes where {} belong", what, n == std::numeric_limits<int64_t>::min() ? n : -n, bytes));
      skip(bytes);
      return;
    }
    if (n > left()) fail(fmt::format("{}: a compressed chunk of {} bytes at byte {}, past the end of its {} bytes", what, n, pos(), size_));
    if (!blosc) {
      skip(n);  // zlib's uncompress writes at most the node's bytes
      return;
    }
    blosc_chunk(n, bytes, what);
  }
  // A blosc buffer of `n` bytes in the file that must decompress to `bytes` bytes (`padded`:
  // or to 128 when fewer, as points/StreamCompression.cc pads small buffers).
  void blosc_chunk(int64_t n, int64_t bytes, const std::string& what, bool padded = false) {
    std::vector<char> buf(static_cast<size_t>(n));
    read(buf.data(), n);
    size_t nbytes = 0;
    if (n < BLOSC_MIN_HEADER_LENGTH || blosc_cbuffer_validate(buf.data(), static_cast<size_t>(n), &nbytes) != 0)
      fail(fmt::format("{}: a blosc chunk with an invalid header at byte {}", what, pos() - n));
    if (static_cast<int64_t>(nbytes) != bytes && !(padded && bytes < 128 && nbytes == 128))
      fail(fmt::format("{}: a blosc chunk of {} bytes where {} belong", what, nbytes, bytes));
  }

  // ---- Metadata (MetaMap::readMeta, Metadata::read, TypedMetadata readValue) ----
  void meta_map(const std::string& what) {
    const uint32_t n = u32();
    if (n > static_cast<uint64_t>(left()) / 12) fail(fmt::format("{} claims {} entries", what, n));
    for (uint32_t i = 0; i < n; ++i) {
      string(what + " (a name)");
      const std::string type = string(what + " (a type)");
      const uint32_t size = u32();
      if (size > left()) fail(fmt::format("{} (a value) of {} bytes at byte {}, past the end of its {} bytes", what, size, pos(), size_));
      // A known type reads its own size whatever the file says: the two must agree.
      const int fixed = fixed_size(type);
      if (fixed >= 0 && static_cast<int64_t>(size) != fixed)
        fail(fmt::format("{}: a value of type {} in {} bytes", what, type, size));
      if (type == "__delayedload") {
        delayed_load(size, what);
      } else {
        skip(size);
      }
    }
  }
  static int fixed_size(const std::string& type) {
    static const std::pair<const char*, int> sizes[] = {
        {"bool", 1},   {"float", 4},   {"double", 8}, {"int32", 4},  {"int64", 8},  {"vec2i", 8},
        {"vec2s", 8},  {"vec2d", 16},  {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24}, {"vec4i", 16},
        {"vec4s", 16}, {"vec4d", 32},  {"mat4s", 64}, {"mat4d", 128}};
    for (const auto& [name, size] : sizes)
      if (type == name) return size;
    return -1;
  }
  // io/DelayedLoadMetadata.cc readValue: a leaf count, a (blosc) mask of a byte per leaf and an
  // optional (blosc) array of 64-bit sizes; it reads what its own fields say, then skips to
  // `size`.
  void delayed_load(uint32_t size, const std::string& what) {
    if (size == 0) return;
    const int64_t start = pos();
    const uint32_t count = u32();
    if (count > size_ / 64) fail(fmt::format("{}: delayed-load data for {} leaves", what, count));
    auto part = [&](uint32_t bytes, int64_t each) {
      if (bytes > 0) {
        if (bytes > left()) fail(fmt::format("{}: delayed-load data past the end", what));
        blosc_chunk(bytes, int64_t(count) * each, what + " (delayed-load data)", /*padded=*/true);
      } else {
        skip(int64_t(count) * each);
      }
    };
    part(u32(), 1);
    const uint32_t bytes = u32();
    if (bytes != std::numeric_limits<uint32_t>::max()) part(bytes, 8);
    if (pos() - start > size) fail(fmt::format("{}: delayed-load data longer than its {} bytes", what, size));
    skip(size - (pos() - start));
  }

  // ---- Bytes ----
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
  std::array<int32_t, 3> coord() {
    std::array<int32_t, 3> c;
    read(reinterpret_cast<char*>(c.data()), 12);
    return c;
  }
  std::vector<uint64_t> mask(int bytes) {
    std::vector<uint64_t> m(static_cast<size_t>(bytes) / 8);
    read(reinterpret_cast<char*>(m.data()), bytes);
    return m;
  }
  static int bits(const std::vector<uint64_t>& m) {
    int n = 0;
    for (uint64_t w : m) n += __builtin_popcountll(w);
    return n;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw VdbError(fmt::format("{}: corrupt OpenVDB file ({})", label_, what));
  }
  int64_t pos() { return static_cast<int64_t>(in_.tellg()); }
  int64_t left() { return size_ - pos(); }
  void skip(int64_t n) {
    if (n < 0 || n > left()) fail(fmt::format("{} bytes expected at byte {} of {}", n, pos(), size_));
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
  uint32_t version_ = 0;
  uint32_t compression_ = 0;  // the grid's (io::COMPRESS_*)
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

std::shared_ptr<VoxelGrid> convert_grid(const openvdb::GridBase::Ptr& base, const std::string& label) {
  if (auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) return dense_copy<openvdb::FloatGrid, 1>(*g, label);
  if (auto g = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) return dense_copy<openvdb::DoubleGrid, 1>(*g, label);
  if (auto g = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base)) return dense_copy<openvdb::Vec3SGrid, 3>(*g, label);
  if (auto g = openvdb::gridPtrCast<openvdb::Vec3DGrid>(base)) return dense_copy<openvdb::Vec3DGrid, 3>(*g, label);
  return nullptr;
}

// OpenVDB throws its own exceptions past the read too: a map that read fine but is singular
// throws ArithmeticError when its affine form is asked for (math/Maps.h, a zero scale).
std::shared_ptr<VoxelGrid> convert(const openvdb::GridBase::Ptr& base, const std::string& label) {
  try {
    return convert_grid(base, label);
  } catch (const VdbError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw VdbError(fmt::format("{}: grid '{}' does not fit in memory", label, base->getName()));
  } catch (const std::exception& e) {
    throw VdbError(fmt::format("{}: grid '{}' is not readable ({})", label, base->getName(), e.what()));
  }
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
    if (g->channels != 1 && g->channels != 3)
      throw VdbError(fmt::format("'{}': grid '{}' has {} channels (float and vec3 grids are written)", path, g->name, g->channels));
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
