// Writes the seed corpus of fuzz/corpus/vdb (docs/reliability.md): small valid OpenVDB files
// that cover each path of the loader's archive walk (media/vdb_file.cpp ArchiveScan) and of
// OpenVDB's reader: blosc, zip and uncompressed trees, active-mask compression with its
// inactive-value variants, half floats, double / int / vec3 / bool / mask trees, root tiles,
// an instanced grid, a frustum transform and a stream without grid offsets. Run by hand when
// the walk learns a new path:  build/fuzz/fuzz_vdb_corpus fuzz/corpus/vdb
#include <cstdio>
#include <fstream>
#include <string>

#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

namespace {

template <class GridT>
typename GridT::Ptr blob(const std::string& name, typename GridT::ValueType bg, typename GridT::ValueType v) {
  typename GridT::Ptr g = GridT::create(bg);
  g->setName(name);
  auto acc = g->getAccessor();
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 9; ++i)
        if ((i + j + k) % 3 != 0) acc.setValue(openvdb::Coord(i - 2, j, k + 3), v);
  g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
  return g;
}

void write(const std::string& dir, const std::string& file, const openvdb::GridPtrVec& grids, uint32_t compression) {
  openvdb::io::File f(dir + "/" + file);
  f.setCompression(compression);
  f.write(grids);
  f.close();
  std::printf("%s/%s\n", dir.c_str(), file.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DIRECTORY\n", argv[0]);
    return 2;
  }
  openvdb::initialize();
  const std::string dir = argv[1];
  using namespace openvdb;
  const uint32_t blosc = io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK;
  // Float with a varying field and inactive values of three kinds (mask compression's metadata).
  {
    FloatGrid::Ptr g = blob<FloatGrid>("density", 0.0f, 1.0f);
    auto acc = g->getAccessor();
    acc.setValueOff(Coord(0, 0, 3), -0.0f);
    acc.setValueOff(Coord(1, 1, 4), 0.5f);
    acc.setValueOff(Coord(2, 2, 5), 0.25f);
    write(dir, "float-zip.vdb", {g}, io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK);
    write(dir, "float-mask-only.vdb", {g}, io::COMPRESS_ACTIVE_MASK);  // neither blosc nor zip
    g->setSaveFloatAsHalf(true);
    write(dir, "float-half-blosc.vdb", {g}, blosc);
  }
  // A root tile (a whole 4096^3 region constant) next to voxels.
  {
    FloatGrid::Ptr g = blob<FloatGrid>("density", 0.0f, 2.0f);
    g->tree().addTile(/*level=*/3, Coord(8192, 0, 0), 0.5f, true);
    write(dir, "float-root-tile.vdb", {g}, blosc);
  }
  // Other value types, an instance (a second grid sharing the first's tree) and a frustum map.
  {
    Vec3SGrid::Ptr c = blob<Vec3SGrid>("color", Vec3s(0), Vec3s(1.0f, 0.5f, 0.25f));
    c->setSaveFloatAsHalf(true);
    DoubleGrid::Ptr d = blob<DoubleGrid>("temperature", 0.0, 1.5);
    Int32Grid::Ptr i = blob<Int32Grid>("index", 0, 7);
    BoolGrid::Ptr b = blob<BoolGrid>("inside", false, true);
    MaskGrid::Ptr m = MaskGrid::create();
    m->setName("mask");
    m->topologyUnion(*b);
    FloatGrid::Ptr f = blob<FloatGrid>("density", 0.0f, 1.0f);
    GridBase::Ptr inst = f->copyGrid();  // shares the tree: written as an instance
    inst->setName("density_copy");
    write(dir, "many-types.vdb", {c, d, i, b, m, f, inst}, blosc);
    FloatGrid::Ptr fr = blob<FloatGrid>("density", 0.0f, 1.0f);
    fr->setTransform(math::Transform::createFrustumTransform(BBoxd(Vec3d(0), Vec3d(8)), 0.5, 2.0, 0.1));
    write(dir, "frustum.vdb", {fr}, blosc);
  }
  // A stream (io::Stream: no grid offsets).
  {
    std::ofstream out(dir + "/stream-no-offsets.vdb", std::ios::binary);
    io::Stream(out).write(GridPtrVec{blob<FloatGrid>("density", 0.0f, 1.0f), blob<Vec3SGrid>("color", Vec3s(0), Vec3s(0.5f))});
    std::printf("%s/stream-no-offsets.vdb\n", dir.c_str());
  }
  return 0;
}
